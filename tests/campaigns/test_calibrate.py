"""The A/A calibration campaign, in a tiny quick configuration, and its assessment."""

from __future__ import annotations

import numpy as np
import pytest

from faultlab.cli import build_parser
from faultlab.analysis.calibration import assess_calibration
from faultlab.campaigns.calibrate import calibrate
from faultlab.stats.verdict import clustered_rate
from faultlab.vocabulary import BASELINE, REPLICA

TINY = {"n_steps": 25, "suites": {"systematic": "auto", "random": 1, "fixed": 1}, "slam": {"particles": 8}}


@pytest.mark.slow
def test_quick_calibration_runs_an_aa_campaign_and_reports_false_alarms(tmp_path):
    run = calibrate(quick=True, out=tmp_path / "res", jobs=1, progress=False, overrides=TINY)
    exp = run.experiment
    assert run.summary.complete and run.out == tmp_path / "res"
    result = assess_calibration(run.out)
    assert result.repetitions == 6
    assert exp.variants == (BASELINE, REPLICA) and exp.repetitions == 6 and exp.runs == 1
    assert exp.detection.rule == "statistical"
    table = result.table.set_index(["rule", "suite"])
    jobs = result.analysis.this_run_jobs
    assert len(jobs) == 7 * 2 * 6
    # the paper rule: one trial per repetition pair, recomputed here from the stored errors
    base = jobs[jobs["variant"] == BASELINE].set_index(["suite", "run", "case", "rep"])["rms_mm"]
    rep = jobs[jobs["variant"] == REPLICA].set_index(["suite", "run", "case", "rep"])["rms_mm"]
    inc = rep - base.reindex(rep.index)
    flags = ((inc > 250) & (inc >= 0.25 * base.reindex(rep.index))).to_numpy()
    clusters = np.array([f"{s}/{c}" for s, _, c, _ in rep.index])
    ref = clustered_rate(flags, clusters)
    row = table.loc[("paper", "all")]
    assert (row["n_pairs"], row["flagged"]) == (42, int(flags.sum()))
    assert np.isclose(row["high"], ref.high)
    stat = table.loc[("statistical", "all")]
    assert stat["n_pairs"] == 7  # one trial per judged case
    assert result.calibrated == bool((result.table.query("rule == 'statistical' and n_pairs > 0")["low"]
                                      < 0.05).all())
    assert "statistical rule: false-alarm rate <= alpha = 0.05" in str(result)
    # resumable: the same call runs nothing new
    again = calibrate(quick=True, out=tmp_path / "res", jobs=1, progress=False, overrides=TINY)
    assert again.summary.n_new == 0 and assess_calibration(again.out).table.equals(result.table)


def test_calibrate_command_is_registered():
    args = build_parser().parse_args(["calibrate", "--quick", "--jobs", "1", "--out", "x"])
    assert args.quick and args.jobs == 1 and args.out == "x" and callable(args.func)
