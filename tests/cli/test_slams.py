"""``python -m faultlab slams`` lists every built-in SLAM with its units and applicable faults."""

import importlib.util

import pytest

from faultlab.cli import main
from faultlab.faults import applicable_faults, builtin_faults
from faultlab.slam.registry import BUILTIN_SLAMS


def _row(out: str, name: str) -> list[str]:
    return next(line.split() for line in out.splitlines() if line.split()[:1] == [name])


def test_slams_lists_name_units_applicable_faults_and_description(capsys):
    assert main(["slams"]) == 0
    out = capsys.readouterr().out
    n = len(builtin_faults())
    for name, kind in BUILTIN_SLAMS.items():
        row = _row(out, name)
        assert row[1] == str(len(kind.units))
        assert row[2] == f"{len(applicable_faults(name, builtin_faults().values()).applicable)}/{n}"
        assert kind.description in out
    assert _row(out, "fastslam")[1:3] == ["16", f"{n}/{n}"]  # every built-in fault targets FastSLAM 1.0
    assert _row(out, "dead_reckoning")[1:3] == ["0", f"0/{n}"]
    assert _row(out, "ekf")[2] != f"{n}/{n}"  # EKF-SLAM has no resampling, no particle weights
    installed = importlib.util.find_spec("gtsam") is not None
    assert _row(out, "gtsam")[3] == ("yes" if installed else "no")
    assert ("gtsam: installed (" in out) == installed


def test_slams_says_how_to_install_a_missing_optional_dependency(capsys, monkeypatch):
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec", lambda name, *a: None if name == "gtsam" else real(name, *a))
    assert main(["slams"]) == 0
    out = capsys.readouterr().out
    assert _row(out, "gtsam")[3] == "no"
    assert "gtsam: not installed: pip install 'faultlab[gtsam]' to use SLAM 'gtsam'" in out


# -- the cross-SLAM campaign: ``slams run`` and ``slams report`` at a tiny scale -------------------


@pytest.mark.filterwarnings("ignore::faultlab.faults.FaultNotApplicableWarning")
def test_slams_run_then_report_at_a_tiny_scale(tmp_path, capsys):
    """Two SLAMs of the campaign on the tiny protocol: one store each, the same jobs, then the comparison."""
    import pandas as pd

    from faultlab.runner import load_experiment, load_metadata, load_results
    from tests.report.conftest import write_tiny_experiment

    protocol = write_tiny_experiment(tmp_path / "protocol")
    out = tmp_path / "stores"
    assert main(["slams", "run", str(protocol), "--out", str(out), "--only", "fastslam1,ekf", "--jobs", "1",
                 "--no-progress"]) == 0
    printed = capsys.readouterr().out
    # EKF-SLAM has no resampling: naive_resampling does not apply to it and is skipped
    assert "== fastslam1: 18 jobs" in printed and "== ekf: 12 jobs" in printed
    assert sorted(p.name for p in out.iterdir()) == ["ekf", "fastslam1"]
    tiny = load_experiment(protocol)
    keys = ["run", "suite", "case", "variant", "rep"]
    fs, ekf = load_results(out / "fastslam1"), load_results(out / "ekf")
    assert len(fs) == 3 * 3 * 2 and set(ekf["variant"]) == {"baseline", "missing_angle_wrap"}
    shared = fs[fs["variant"] != "naive_resampling"][keys].reset_index(drop=True)
    assert shared.equals(ekf[keys].reset_index(drop=True))  # same cases, variants and repetitions
    assert load_metadata(out / "ekf")["experiment"]["slam"]["name"] == "ekf"
    assert load_metadata(out / "fastslam1")["experiment"]["seed"] == tiny.seed
    # the protocol's cases are shared: each SLAM saw the same saved case files
    assert (out / "ekf" / "cases" / "run1" / "fixed" / "case1.npz").read_bytes() == \
        (out / "fastslam1" / "cases" / "run1" / "fixed" / "case1.npz").read_bytes()

    assert main(["slams", "report", str(out)]) == 0
    report = out / "report"
    accuracy = pd.read_csv(report / "accuracy.csv")
    assert sorted(accuracy["slam"]) == ["ekf", "fastslam1"]
    for label, rows in (("ekf", ekf), ("fastslam1", fs)):
        base = rows[(rows["variant"] == "baseline") & (rows["status"] == "ok")]
        assert accuracy.set_index("slam").loc[label, "n_cases"] == base.groupby(["suite", "case"]).ngroups
    not_judged = pd.read_csv(report / "not_judged.csv")
    assert ("ekf", "naive_resampling") in set(zip(not_judged["slam"], not_judged["fault"]))
    assert (report / "README.md").is_file() and (report / "slams.png").is_file()


def test_slams_run_refuses_an_unknown_label_before_running(tmp_path, capsys):
    assert main(["slams", "run", "--out", str(tmp_path / "o"), "--only", "fastslam9"]) == 1
    assert "unknown SLAM label(s) ['fastslam9']" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_slams_report_without_stores_is_a_clear_error(tmp_path, capsys):
    assert main(["slams", "report", str(tmp_path)]) == 1
    assert "no store of a cross-SLAM campaign" in capsys.readouterr().err
