"""The A/A calibration campaign, in a tiny quick configuration."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from faultlab.cli import build_parser
from faultlab.report.calibrate import EXIT_CODES, calibrate, check_saved, replica_calibration
from faultlab.metrics.detection import DetectionRule
from faultlab.stats.calibration import check_calibration
from tests.stats.synthetic import frame, job
from faultlab.stats.verdict import clustered_rate
from faultlab.vocabulary import BASELINE, REPLICA

TINY = {"n_steps": 25, "suites": {"systematic": "auto", "random": 1, "fixed": 1}, "slam": {"particles": 8}}


@pytest.mark.slow
def test_quick_calibration_runs_an_aa_campaign_and_reports_false_alarms(tmp_path):
    result = calibrate(quick=True, out=tmp_path / "res", reports=tmp_path / "rep", jobs=1, progress=False,
                       overrides=TINY)
    exp = result.experiment
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
    assert (tmp_path / "rep" / "replica_false_alarms.csv").exists() and (tmp_path / "rep" / "calibration.csv").exists()
    # the saved analysis is checked again without running anything
    rates, check, _ = check_saved(tmp_path / "rep")
    pd.testing.assert_frame_equal(rates, result.rates)
    assert check == result.check
    # resumable: the same call runs nothing new
    again = calibrate(quick=True, out=tmp_path / "res", jobs=1, progress=False, overrides=TINY)
    assert again.table.equals(result.table)


def test_calibrate_command_is_registered():
    args = build_parser().parse_args(["calibrate", "--quick", "--jobs", "1", "--out", "x"])
    assert args.quick and args.jobs == 1 and args.out == "x" and callable(args.func)


def _aa_jobs(n_cases, k=10, *, seed=0, replica_shift=0.0):
    """Baseline and replica errors of ``n_cases`` independent cases, K repetitions each."""
    rng = np.random.default_rng(seed)
    rows = []
    for case in range(1, n_cases + 1):
        level = rng.uniform(100.0, 2000.0)
        for rep in range(k):
            rows.append(job(1, "random", case, BASELINE, rep, level * np.exp(rng.normal(0.0, 0.1))))
            rows.append(job(1, "random", case, REPLICA, rep, level * np.exp(rng.normal(replica_shift, 0.1))))
    return frame(rows)


@pytest.mark.slow
def test_an_aa_campaign_of_200_cases_is_calibrated_and_a_rule_that_rejects_too_often_fails():
    jobs = _aa_jobs(200)
    rule = DetectionRule(rule="statistical")
    rates, check = replica_calibration(jobs, rule)
    row = rates.set_index(["scope", "suite"]).loc[("per_case", "all")]
    assert row["n"] == 200 and row["cp_low"] <= 0.05 < 0.1 and check.status == "calibrated"
    assert EXIT_CODES[check.status] == 0
    # a miscalibrated rule: alpha = 0.2 declared as 0.05 -- rejects about four times too often
    lax = replica_calibration(jobs, DetectionRule(rule="statistical", alpha=0.2))[0]
    bad = check_calibration(lax, alpha=0.05)
    assert bad.status == "miscalibrated" and bad.failed and "rejects too often" in bad.reason
    assert EXIT_CODES[bad.status] == 3
    # too few cases to exclude 2 alpha
    few = replica_calibration(jobs[jobs["case"] <= 9], rule)[1]
    assert few.status == "underpowered" and "underpowered calibration" in few.reason and EXIT_CODES[few.status] == 4
