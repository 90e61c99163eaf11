"""reproduce(): options reach the runner; the campaign writes under its results directory only."""

from __future__ import annotations

from pathlib import Path

import pytest

import faultlab.campaigns.reproduce as rp
from faultlab.errors import ConfigError
from faultlab.analysis.fidelity import FIDELITY
from faultlab.campaigns.reproduce import default_out, default_reports, profile_overrides, quick_overrides, reproduce
from faultlab.report.reproduce import rebuild_report
from faultlab.runner import load_experiment, load_results, parse_experiment
from faultlab.slam.profiles import get_profile

from tests.report.conftest import REPO, write_tiny_experiment

PAPER_TOML = REPO / "experiments" / "paper.toml"


@pytest.fixture
def captured(monkeypatch):
    """Replace the runner by a recorder (nothing runs)."""
    calls = {}

    def fake_run(experiment, out, **kwargs):
        calls["run"] = (experiment, Path(out), kwargs)
        return "summary"

    monkeypatch.setattr(rp, "run_experiment", fake_run)
    return calls


def test_quick_overrides_shrink_the_paper_protocol():
    paper = load_experiment(PAPER_TOML)
    quick = paper.apply(quick_overrides(paper))
    assert quick.runs == 1
    assert {s.kind: s.n_cases for s in quick.suites} == {"systematic": None, "random": 2, "fixed": 2}
    assert quick.variants == ("baseline", "naive_resampling", "missing_angle_wrap", "motion_sign_error")
    assert quick.slam.config.particles == 60 and quick.n_steps == 200 and quick.repetitions == 1
    assert quick.seed == paper.seed and quick.detection == paper.detection
    assert quick.hash != paper.hash


def test_default_out_never_mixes_protocols():
    assert default_out("experiments/paper.toml") == Path("results/paper")
    assert default_out("experiments/paper.toml", quick=True) == Path("results/paper-quick")
    assert default_out("experiments/paper.toml", runs=30) == Path("results/paper-runs30")
    assert default_out("x/y.toml", quick=True, runs=2) == Path("results/y-quick-runs2")


def test_default_is_the_shipped_paper_protocol_from_any_directory(captured, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # no experiments/ here: the packaged copy is used
    reproduce(progress=False)
    experiment, out, _ = captured["run"]
    assert experiment.hash == load_experiment(PAPER_TOML).hash and experiment.source == "paper"
    assert out == Path("results/paper")
    reproduce("smoke", quick=True, progress=False)
    assert captured["run"][1] == Path("results/smoke-quick")


def test_options_reach_the_runner_and_the_result(captured, tmp_path):
    result = reproduce(PAPER_TOML, out=tmp_path / "o", reports=tmp_path / "r", runs=30, jobs=1,
                       backend="threading", force_new=True, progress=False)
    experiment, out, kwargs = captured["run"]
    assert experiment.runs == 30 and experiment.suites == load_experiment(PAPER_TOML).suites
    assert out == tmp_path / "o"
    assert kwargs == {"jobs": 1, "backend": "threading", "force_new": True, "progress": False}
    assert result.reports == tmp_path / "r" and result.ablation_dirs == {}
    assert result.summary == "summary" and result.experiment is experiment


def test_quick_and_runs_together(captured, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    reproduce(PAPER_TOML, quick=True, runs=2, progress=False)
    experiment, out, _ = captured["run"]
    assert experiment.runs == 2 and experiment.slam.config.particles == 60
    assert out == Path("results/paper-quick-runs2")


@pytest.mark.parametrize("kwargs, match", [({"runs": 0}, "runs"), ({"jobs": 0}, "jobs"),
                                           ({"runs": True}, "runs")])
def test_bad_options_fail_before_anything_runs(captured, tmp_path, kwargs, match):
    with pytest.raises(ConfigError, match=match):
        reproduce(PAPER_TOML, out=tmp_path / "o", reports=tmp_path / "r", **kwargs)
    assert captured == {}
    assert not (tmp_path / "o").exists()


def test_missing_experiment_file(captured, tmp_path):
    with pytest.raises(ConfigError, match="cannot be read"):
        reproduce(tmp_path / "nope.toml", out=tmp_path / "o", reports=tmp_path / "r")
    assert captured == {}


def test_reproduce_runs_then_resumes_without_rerunning(tmp_path):
    exp = write_tiny_experiment(tmp_path)
    first = reproduce(exp, out=tmp_path / "out", jobs=1, progress=False)
    assert first.summary.n_new == 18 and first.summary.complete
    assert first.out == tmp_path / "out" and first.reports == tmp_path / "out" / "report"
    assert str(first).startswith(f"results: {tmp_path / 'out'} (18 jobs")
    rows = load_results(tmp_path / "out")
    second = reproduce(exp, out=tmp_path / "out", jobs=1, progress=False)
    assert second.summary.n_new == 0 and second.summary.n_skipped == 18
    assert load_results(tmp_path / "out").equals(rows)
    # the campaign wrote its store and cases, nothing else (the report is rendered separately)
    assert sorted(p.name for p in (tmp_path / "out").iterdir()) == ["cases", "results.sqlite"]  # no .lock left


def test_profile_paper_runs_the_papers_filter_with_fov_bug_beside_the_default(captured, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    reproduce(profile="paper", progress=False)
    experiment, out, _ = captured["run"]
    assert experiment.slam.profile == "paper" and experiment.fov_bug
    assert experiment.slam.config == get_profile("paper").config
    assert experiment.slam.build().steps == get_profile("paper").steps
    assert out == Path("results/paper-profile-paper")
    reproduce(profile="paper", quick=True, progress=False)
    experiment, out, _ = captured["run"]
    assert experiment.slam.profile == "paper" and experiment.fov_bug and experiment.slam.config.particles == 60
    assert out == Path("results/paper-profile-paper-quick")
    assert default_reports(Path("x")) == Path("x/report") and default_out("paper", profile="x") == Path("results/paper-profile-x")


def test_profile_overrides_replace_the_files_slam_settings():
    paper = load_experiment(PAPER_TOML)
    custom = paper.merge(slam={"particles": 7, "std_v": 0.5})
    run = custom.apply(profile_overrides(custom, "paper"))
    assert run.slam.config == get_profile("paper").config
    ref = custom.apply(profile_overrides(custom, "reference"))
    assert not ref.fov_bug and ref.slam.profile == "reference" and ref.hash == paper.hash
    with pytest.raises(ConfigError, match="unknown FastSLAM profile"):
        profile_overrides(paper, "nope")
    with pytest.raises(ConfigError, match="needs"):
        profile_overrides(parse_experiment({**paper.to_dict(), "slam": {"name": "dead_reckoning"}}), "paper")


@pytest.mark.slow
def test_reproduce_profile_paper_quick_end_to_end(tmp_path, monkeypatch):
    """The real pipeline on the paper profile, shrunk further: tiny cases, few steps and particles."""
    monkeypatch.setattr(rp, "QUICK_STEPS", 15)
    monkeypatch.setattr(rp, "QUICK_PARTICLES", 6)
    exp = write_tiny_experiment(tmp_path)
    result = reproduce(exp, profile="paper", quick=True, out=tmp_path / "out", reports=tmp_path / "rep", jobs=1,
                       progress=False)
    written = rebuild_report(result.out, result.reports)
    assert result.summary.complete and result.experiment.fov_bug and result.experiment.slam.profile == "paper"
    rows = load_results(tmp_path / "out")
    assert set(rows["variant"]) == {"baseline", "naive_resampling", "missing_angle_wrap", "motion_sign_error"}
    table = FIDELITY.read_csv(tmp_path / "rep" / "fidelity.csv")
    ok = rows[rows["status"] == "ok"]
    assert len(table) == ok.groupby(["suite", "variant"]).ngroups
    for r in table.itertuples():
        cell = ok[(ok["suite"] == r.suite) & (ok["variant"] == r.variant)]["rms_mm"]
        assert r.n == len(cell) and r.median_mm == pytest.approx(cell.median())
    md = (tmp_path / "rep" / "fidelity.md").read_text()
    assert "profile `paper`, fov_bug = true" in md and "REDUCED" in md
    assert (tmp_path / "rep" / "report.pdf").is_file() and "fidelity" in str(written)


def test_ablation_needs_the_paper_profile(captured, tmp_path):
    with pytest.raises(ConfigError, match="ablation needs profile='paper'"):
        reproduce(PAPER_TOML, out=tmp_path / "o", reports=tmp_path / "r", ablation=True)
    with pytest.raises(ConfigError, match="ablation_runs"):
        reproduce(PAPER_TOML, profile="paper", out=tmp_path / "o", reports=tmp_path / "r", ablation=True,
                  ablation_runs=0)
    assert captured == {}


def test_run_ablation_reuses_the_main_run_and_runs_every_other_arm(monkeypatch, tmp_path):
    from faultlab.slam.profiles import ablation_arms

    runs = []
    monkeypatch.setattr(rp, "run_experiment", lambda exp, out, **kw: runs.append((exp, Path(out), kw)))
    paper = load_experiment(PAPER_TOML)
    main = paper.apply(profile_overrides(paper, "paper"))
    computed = rp.run_ablation(main, tmp_path / "main", runs=2, jobs=1, progress=False)
    arms = ablation_arms()
    assert list(computed) == [a.name for a in arms] and computed["paper"] == tmp_path / "main"
    assert len(runs) == len(arms) - 1  # the main run is not run again
    for exp, out, kw in runs:
        name = out.name
        arm = next(a for a in arms if a.name == name)
        assert out.parent == tmp_path / "main" / "ablation" and computed[name] == out
        assert exp.slam.profile == arm.profile and exp.fov_bug == arm.fov_bug
        assert exp.runs == 2 and exp.variants == ("baseline", "missing_angle_wrap")
        assert exp.n_steps == main.n_steps and exp.seed == main.seed and exp.suites == main.suites
        assert exp.slam.config == main.slam.config and kw == {"jobs": 1, "backend": "loky", "progress": False}
    with pytest.raises(ConfigError, match="isolates the differences of the profile 'paper'"):
        rp.run_ablation(paper, tmp_path / "x")
    runs.clear()
    rp.run_ablation(main, tmp_path / "main", suites={"fixed": 3}, progress=False)
    shapes = {out.name: {s.kind: s.n_cases for s in exp.suites} for exp, out, _ in runs}
    # paper_no_aliasing is compared with the main run (the aliasing row): it keeps the main run's suites
    assert shapes.pop("paper_no_aliasing") == {"systematic": 5, "random": 5, "fixed": 5}
    assert shapes and all(v == {"fixed": 3} for v in shapes.values())
