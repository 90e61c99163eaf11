"""Continuous responses per case against values computed by hand from a planted results table."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from faultlab.stats.responses import case_responses, rep_values
from faultlab.errors import ResultsError
from faultlab.metrics.detection import DetectionRule


def _results(base: np.ndarray, faulty: np.ndarray, status=None) -> pd.DataFrame:
    """Rows of cases x reps for the baseline and one fault 'f' (errors in mm)."""
    rows = []
    n_cases, k = base.shape
    for c in range(n_cases):
        for r in range(k):
            rows.append({"run": 1, "suite": "morris", "case": c + 1, "variant": "baseline", "rep": r,
                         "status": "ok", "rms_mm": base[c, r]})
            st = "ok" if status is None else status[c, r]
            rows.append({"run": 1, "suite": "morris", "case": c + 1, "variant": "f", "rep": r, "status": st,
                         "rms_mm": faulty[c, r] if st == "ok" else np.nan})
    return pd.DataFrame(rows)


def test_effect_is_the_mean_paired_log_ratio_with_its_standard_error():
    rng = np.random.default_rng(0)
    base = rng.uniform(50, 200, (5, 6))
    faulty = base * np.exp(rng.normal(0.7, 0.2, (5, 6)))
    out = case_responses(_results(base, faulty), rule=DetectionRule())
    eff = out[out["response"] == "effect:f"].set_index("case")
    ratio = np.log(faulty / base)
    np.testing.assert_allclose(eff["value"], ratio.mean(axis=1))
    np.testing.assert_allclose(eff["std_err"], ratio.std(axis=1, ddof=1) / np.sqrt(6))
    diff = out[out["response"] == "difficulty"].set_index("case")
    np.testing.assert_allclose(diff["value"], np.log(base).mean(axis=1))
    assert list(dict.fromkeys(out["response"])) == ["difficulty", "effect:f", "detection:f"]


def test_detection_probability_is_the_share_of_detecting_repetitions():
    base = np.full((2, 4), 100.0)
    faulty = np.array([[100.0, 100.0, 400.0, 400.0], [400.0] * 4])
    rule = DetectionRule(abs_mm=10.0, rel=0.1, rule="paper")
    out = case_responses(_results(base, faulty), rule=rule)
    det = out[out["response"] == "detection:f"].set_index("case")["value"]
    assert det.tolist() == [0.5, 1.0]


def test_a_failed_faulty_repetition_counts_as_the_worst_ratio_seen():
    base = np.full((2, 2), 100.0)
    faulty = np.array([[150.0, 300.0], [120.0, 0.0]])
    status = np.array([["ok", "ok"], ["ok", "crash"]])
    reps = rep_values(_results(base, faulty, status))
    eff = reps[reps["response"] == "effect:f"]
    crashed = eff[(eff["case"] == 2) & (eff["rep"] == 1)]
    assert bool(crashed["failed"].iloc[0])
    assert crashed["value"].iloc[0] == pytest.approx(np.log(3.0))
    out = case_responses(_results(base, faulty, status), detection=False)
    assert out[(out["response"] == "effect:f") & (out["case"] == 2)]["n_failed"].iloc[0] == 1


def test_without_a_baseline_there_is_nothing_to_compare():
    frame = _results(np.ones((1, 2)), np.ones((1, 2)))
    with pytest.raises(ResultsError, match="no baseline"):
        case_responses(frame[frame["variant"] != "baseline"])
