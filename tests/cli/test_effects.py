"""``faultlab effects``: the study's verbs beside the logistic view of a campaign."""

from __future__ import annotations

import pandas as pd

from faultlab.cli import main


def test_design_prints_sizes_from_the_formulas_and_writes_only_with_out(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(["effects", "design", "effects", "--quick"]) == 0
    out = capsys.readouterr().out
    # Morris: 8 trajectories x (11 + 1) points; Sobol at most 16 x (11 + 2); 7 variants x K = 3 each
    assert "Morris: 96 cases" in out and f"{96 * 7 * 3} SLAM executions" in out
    assert "at most 208 cases" in out and f"at most {96 * 21 + 208 * 21} SLAM executions" in out
    assert list(tmp_path.iterdir()) == []
    assert main(["effects", "design", "effects", "--quick", "--out", "d"]) == 0
    design = pd.read_csv(tmp_path / "d" / "morris_design.csv")
    assert len(design) == 96 and design["map_size"].between(4, 49).all()


def test_without_a_verb_the_help_lists_the_verbs_and_the_logistic_view(capsys):
    assert main(["effects"]) == 2
    out = capsys.readouterr().out
    for verb in ("effects design", "effects run", "effects report", "effects RESULTS"):
        assert verb in out


def test_report_of_a_directory_that_is_no_study_is_one_clear_error(tmp_path, capsys):
    assert main(["effects", "report", str(tmp_path), "--reports", str(tmp_path / "rep")]) == 1
    err = capsys.readouterr().err
    assert "not an effects study output" in err and "Traceback" not in err
    assert not (tmp_path / "rep").exists()


def test_run_into_a_directory_holding_another_campaigns_store_is_refused_writing_nothing(tmp_path, capsys):

    from tests.runner.suts import write_experiment

    exp = write_experiment(tmp_path / "e.toml", runs=1, suites={"random": 1}, repetitions=1)
    out = tmp_path / "out"
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 0
    before = sorted(p.relative_to(out) for p in out.rglob("*"))
    capsys.readouterr()
    for extra in ([], ["--force-new"]):
        assert main(["effects", "run", "--quick", "--out", str(out), "--no-progress", *extra]) == 1
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and f"holds the store of another campaign ({out / 'results.sqlite'})" in err[0], err
        assert sorted(p.relative_to(out) for p in out.rglob("*")) == before
