"""The A/A calibration campaign, in a tiny quick configuration, and its assessment."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from faultlab.cli import build_parser
from faultlab.config import ExperimentOverrides
from faultlab.analysis.calibration import assess_calibration, check_saved
from faultlab.campaigns.calibrate import calibrate
from faultlab.stats.calibration import check_calibration
from faultlab.inference.intervals import clustered_rate
from faultlab.vocabulary import BASELINE, REPLICA

TINY = ExperimentOverrides(n_steps=25, suites={"systematic": "auto", "random": 1, "fixed": 1}, particles=8)


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
    # the check judges the per-case (unadjusted) rate over the 7 cases with its exact interval
    per_case = result.rates.set_index(["scope", "suite"]).loc[("per_case", "all")]
    assert per_case["n"] == 7 and result.check == check_calibration(result.rates, alpha=0.05)
    assert result.calibrated == (result.check.status == "calibrated")
    assert result.check.reason in str(result)
    # the saved analysis is checked again without the store
    result.analysis.save(tmp_path / "rep")
    rates, check, _ = check_saved(tmp_path / "rep")
    pd.testing.assert_frame_equal(rates, result.rates)
    assert check == result.check
    # resumable: the same call runs nothing new
    again = calibrate(quick=True, out=tmp_path / "res", jobs=1, progress=False, overrides=TINY)
    assert again.summary.n_new == 0 and assess_calibration(again.out).table.equals(result.table)


def test_calibrate_command_is_registered():
    args = build_parser().parse_args(["calibrate", "--quick", "--jobs", "1", "--out", "x"])
    assert args.quick and args.jobs == 1 and args.out == "x" and callable(args.func)

