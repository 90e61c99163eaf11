"""The A/A calibration check of the statistical rule, on synthetic A/A jobs with a known answer."""

from __future__ import annotations

import numpy as np
import pytest

from faultlab.analysis.calibration import EXIT_CODES, replica_calibration
from faultlab.metrics.detection import DetectionRule
from faultlab.stats.calibration import check_calibration
from faultlab.vocabulary import BASELINE, REPLICA
from tests.stats.synthetic import frame, job


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
