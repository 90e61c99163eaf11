"""The effects study campaign: settings, designs as cases, resume, refusals, SIGKILL and resume."""

from __future__ import annotations

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from faultlab.campaigns.effects import (design_cases, effects_plan, load_effects_experiment, run_effects,
                                        stage_design)
from faultlab.cli import main
from faultlab.errors import ConfigError, ResultsError
from faultlab.runner.store import load_sessions
from faultlab.seeds import case_seed

TINY = """
description = "tiny effects study"
seed = 5
n_steps = 15
sensor_range = 2.0
variants = ["baseline", "motion_sign_error"]
repetitions = 2
timeout_s = 120.0

[slam]
name = "fastslam"
particles = 5

[space.map_size.classes]
small = [4, 9]
medium = [9, 16]
large = [16, 25]

[effects]
factors = ["map_size", "landmark_density", "step_size"]
trajectories = 2
keep = 2
sobol_base = 4
resamples = 50
seed = 2
"""


@pytest.fixture
def tiny(tmp_path) -> Path:
    path = tmp_path / "tiny.toml"
    path.write_text(TINY)
    return path


def test_shipped_file_and_its_quick_scale():
    full = load_effects_experiment("effects")
    quick = load_effects_experiment("effects", quick=True)
    assert full.experiment.n_steps == 1000 and quick.experiment.n_steps == 60
    plan = effects_plan(quick)
    d = len(quick.spec.factors)
    assert plan["morris_cases"] == quick.spec.trajectories * (d + 1) == 96
    assert plan["executions_morris"] == 96 * len(quick.experiment.variants) * quick.experiment.repetitions
    assert plan["sobol_cases_max"] == quick.spec.sobol_base * (d + 2)


def test_design_points_become_cases_with_their_own_seeds(tiny):
    eexp = load_effects_experiment(tiny)
    design = stage_design(eexp, "morris")
    cases = design_cases(eexp, design)
    assert len(cases) == design.n_points == 2 * 4
    assert [c.seed for c in cases] == [case_seed(5, 1, "morris", i) for i in range(1, 9)]
    assert all(c.spec.values["directionality"] == "random" for c in cases)  # not varied: fixed value


@pytest.mark.parametrize("edit, match", [
    (("factors = [\"map_size\", \"landmark_density\", \"step_size\"]", "factors = [\"map_size\", \"speed\"]"),
     "unknown parameter 'speed'"),
    (("sobol_base = 4", "sobol_base = 12"), "power of two"),
    (("trajectories = 2", "trajectories = 1"), "trajectories"),
    (("keep = 2", "keep = 1"), "keep"),
    (("[effects]", "[suites]\nfixed = 2\n\n[effects]"), "no suites"),
])
def test_bad_settings_are_one_clear_error_and_write_nothing(tmp_path, tiny, capsys, edit, match):
    tiny.write_text(TINY.replace(*edit))
    with pytest.raises(ConfigError, match=match):
        load_effects_experiment(tiny)
    out = tmp_path / "out"
    assert main(["effects", "run", str(tiny), "--out", str(out), "--no-progress"]) == 1
    err = capsys.readouterr().err
    assert err.startswith("faultlab: error:") and "Traceback" not in err and match.split()[0] in err
    assert not out.exists()


def _run_cli(tiny: Path, out: Path, jobs: int = 1, **kw) -> subprocess.Popen:
    env = dict(os.environ, PYTHONPATH=str(Path(__file__).resolve().parents[2]))
    return subprocess.Popen([sys.executable, "-m", "faultlab", "effects", "run", str(tiny), "--out", str(out),
                             "--jobs", str(jobs), "--no-progress"], env=env, stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, start_new_session=True, **kw)


def _rows(store: Path) -> int:
    try:
        with sqlite3.connect(store / "results.sqlite", timeout=1) as conn:
            return conn.execute("SELECT COUNT(*) FROM results").fetchone()[0]
    except sqlite3.Error:
        return 0


@pytest.mark.slow
def test_sigkill_then_resume_gives_the_same_report_as_an_uninterrupted_run(tmp_path, tiny):
    from faultlab.report.effects import write_effects_report

    killed = tmp_path / "killed"
    proc = _run_cli(tiny, killed)
    deadline = time.time() + 300
    while _rows(killed / "morris") < 6 and proc.poll() is None and time.time() < deadline:
        time.sleep(0.2)
    assert proc.poll() is None, "the run finished before it could be killed"
    os.killpg(proc.pid, signal.SIGKILL)
    proc.wait()
    # killed mid-study: inside the Morris stage, or (a fast machine) inside or before the Sobol stage
    assert 0 < _rows(killed / "morris") <= 2 * 2 * 2 * 4
    morris_done = load_sessions(killed / "morris")[-1]["state"] == "complete"
    if not morris_done or (killed / "sobol" / "results.sqlite").exists():
        # a report of an unfinished stage is refused with one clear error
        with pytest.raises(ResultsError, match="unfinished"):
            write_effects_report(killed, tmp_path / "rep-partial")
    else:  # the Morris stage alone is a report of its own, which says the Sobol stage is still to run
        write_effects_report(killed, tmp_path / "rep-partial")
        assert "Sobol stage not run yet" in (tmp_path / "rep-partial" / "effects.md").read_text()
    assert _run_cli(tiny, killed).wait() == 0
    whole = tmp_path / "whole"  # uninterrupted, and with two workers: the same results whatever the workers
    assert _run_cli(tiny, whole, jobs=2).wait() == 0
    a = write_effects_report(killed, tmp_path / "rep-killed")
    b = write_effects_report(whole, tmp_path / "rep-whole")
    for pa, pb in zip(a, b):
        if pa.suffix == ".csv":
            pd.testing.assert_frame_equal(pd.read_csv(pa), pd.read_csv(pb), check_exact=True)
    assert (tmp_path / "rep-killed" / "effects.md").read_text().split("## ")[1:] == \
        (tmp_path / "rep-whole" / "effects.md").read_text().split("## ")[1:]
    # the effect-guided weights are the analysis's (computed once), one file per fault with an effect response
    from faultlab.analysis.effects import analyse_effects

    analysis = analyse_effects(whole)
    effects = [r for r in analysis.responses if r.startswith("effect:")]
    assert effects and sorted(analysis.weights) == sorted(r.partition(":")[2] for r in effects)
    for r in effects:
        fault = r.partition(":")[2]
        written = pd.read_csv(tmp_path / "rep-whole" / f"weights_{fault}.csv")
        pd.testing.assert_frame_equal(written, analysis.weights[fault].reset_index(drop=True), check_dtype=False)


def test_a_study_killed_after_every_case_had_one_job_is_still_unfinished(tmp_path, tiny):
    """Every design point has a stored job, but not every variant and repetition: the analysis refuses it."""
    from faultlab.report.effects import write_effects_report

    tiny.write_text(TINY.replace("sobol_base = 4", "sobol_base = 0"))
    out = tmp_path / "out"
    run_effects(load_effects_experiment(tiny), out, jobs=1, progress=False)
    write_effects_report(out, tmp_path / "rep-done")  # the finished study renders
    with sqlite3.connect(out / "morris" / "results.sqlite") as conn:  # what a SIGKILL mid-resume leaves
        n_cases = conn.execute("SELECT COUNT(DISTINCT \"case\") FROM results").fetchone()[0]
        conn.execute("DELETE FROM results WHERE variant = 'motion_sign_error'")
        conn.execute("INSERT INTO sessions (started, state, n_todo, n_new, started_unix) "
                     "VALUES ('now', 'running', 16, 0, 0.0)")
    assert n_cases == 8
    with pytest.raises(ResultsError, match="unfinished"):
        write_effects_report(out, tmp_path / "rep-partial")
    assert not (tmp_path / "rep-partial").exists()


def test_resume_with_other_settings_is_refused_before_writing(tmp_path, tiny):
    eexp = load_effects_experiment(tiny)
    out = tmp_path / "out"
    out.mkdir()
    (out / "effects.json").write_text('{"effects": {}, "quick": false, "experiment_hash": "x"}')
    before = (out / "effects.json").read_text()
    with pytest.raises(ResultsError, match="other settings"):
        run_effects(eexp, out, progress=False)
    assert (out / "effects.json").read_text() == before and sorted(os.listdir(out)) == ["effects.json"]


def test_a_directory_with_stores_but_no_study_record_is_refused(tmp_path, tiny):
    out = tmp_path / "out"
    (out / "morris").mkdir(parents=True)
    with pytest.raises(ResultsError, match="not an effects study"):
        run_effects(load_effects_experiment(tiny), out, progress=False)
    assert not (out / "effects.json").exists()


def test_the_analysis_rebuilds_the_campaigns_designs_from_the_study_record(tmp_path, tiny):
    """effects.json keeps the space's class order, so the designs and class indices are the campaign's."""
    from faultlab.stats.screening import read_effects_json, saved_design
    from faultlab.campaigns.effects import _write_json

    eexp = load_effects_experiment(tiny)
    _write_json(tmp_path, eexp.to_json() | {"kept": ["map_size", "step_size"]})
    saved = read_effects_json(tmp_path)
    assert list(saved["space"]["map_size"]["classes"]) == ["small", "medium", "large"]
    for stage, kept in (("morris", None), ("sobol", ["map_size", "step_size"])):
        a, b = stage_design(eexp, stage, factors=kept), saved_design(saved, stage)
        assert a.factors == b.factors and (a.unit == b.unit).all()
        assert [c.classes for c in a.cases] == [c.classes for c in b.cases]
