import math

import numpy as np
import pytest

from faultlab.errors import ConfigError, ResultsError
from faultlab.vocabulary import Outcome
from faultlab.stats import DetectionRule, classify, detects, outcomes, pair_with_baseline
from tests.stats.synthetic import frame, job

PAPER = DetectionRule()


@pytest.mark.parametrize("faulty, baseline, expected", [
    # absolute threshold (small baselines): the increase must EXCEED 250 mm
    (290.0, 40.0, False),        # +250 exactly
    (290.001, 40.0, True),
    (289.999, 40.0, False),
    (250.0, 0.0, False),
    (250.5, 0.0, True),
    # relative threshold (large baselines): the increase must be AT LEAST 25 %
    (2500.0, 2000.0, True),      # +25 % exactly, +500 mm
    (2499.99, 2000.0, False),
    (2500.01, 2000.0, True),
    (1250.0, 1000.0, False),     # +25 % but only +250 mm: the absolute condition fails
    (1250.001, 1000.0, True),
    # both decide together
    (9000.0, 8000.0, False),     # +1000 mm but only +12.5 %
    (100.0, 1000.0, False),      # a decrease
    (math.nan, 100.0, False),
    (1000.0, math.nan, False),
])
def test_paper_rule_at_and_around_both_thresholds(faulty, baseline, expected):
    assert detects(faulty, baseline, rule=PAPER) is expected


def test_configurable_thresholds():
    assert detects(160.0, 100.0, rule=DetectionRule(abs_mm=50.0, rel=0.5)) is True   # +60 > 50, +60 % >= 50 %
    assert detects(150.0, 100.0, rule=DetectionRule(abs_mm=50.0, rel=0.5)) is False  # +50 not > 50
    assert detects(149.0, 99.0, rule=DetectionRule(abs_mm=10.0, rel=0.6)) is False   # +50.5 % < 60 %
    zero = DetectionRule(abs_mm=0.0, rel=0.0)
    assert detects(1.0, 1.0, rule=zero) is False and detects(1.0 + 1e-9, 1.0, rule=zero) is True


def test_vectorised_matches_scalar_loop():
    rng = np.random.default_rng(0)
    b = rng.uniform(0, 3000, 500)
    f = b + rng.uniform(-500, 1500, 500)
    expected = [(fi - bi > 250.0) and (fi - bi >= 0.25 * bi) for fi, bi in zip(f, b)]
    np.testing.assert_array_equal(detects(f, b), expected)


@pytest.mark.parametrize("kw", [{"abs_mm": -1.0}, {"rel": float("nan")}, {"rel": "0.25"}, {"abs_mm": True}])
def test_rule_rejects_bad_thresholds(kw):
    with pytest.raises(ConfigError, match="DetectionRule"):
        DetectionRule(**kw)


def test_pair_with_baseline_joins_on_run_suite_case_rep():
    rows = [job(1, "random", 1, "baseline", 0, 100.0), job(1, "random", 1, "baseline", 1, 200.0),
            job(2, "random", 1, "baseline", 0, 300.0),
            job(1, "random", 1, "naive_resampling", 1, 900.0), job(2, "random", 1, "naive_resampling", 0, 50.0),
            job(1, "fixed", 1, "naive_resampling", 0, 1.0)]  # no fixed baseline at all
    pairs = pair_with_baseline(frame(rows)).set_index(["run", "suite", "case", "rep"])
    assert len(pairs) == 3 and set(pairs["fault"]) == {"naive_resampling"}
    assert pairs.loc[(1, "random", 1, 1), "baseline_rms_mm"] == 200.0
    assert pairs.loc[(2, "random", 1, 0), "baseline_rms_mm"] == 300.0
    assert pairs.loc[(1, "fixed", 1, 0), "baseline_status"] == "missing"
    assert "map_size" in pairs.columns  # scenario parameters travel with the pair


def test_pair_with_baseline_errors():
    rows = [job(1, "random", 1, "baseline", 0, 1.0), job(1, "random", 1, "baseline", 0, 2.0)]
    with pytest.raises(ResultsError, match="run=1, suite=random, case=1, rep=0, variant=baseline appears more"):
        pair_with_baseline(frame(rows))
    with pytest.raises(ResultsError, match="lack column.*status"):
        pair_with_baseline(frame(rows[:1]).drop(columns="status"))


def test_every_outcome_class():
    rows = []
    spec = [  # (case, faulty rms, faulty status, baseline rms, baseline status, expected)
        (1, 900.0, "ok", 100.0, "ok", Outcome.DETECTED),
        (2, 200.0, "ok", 100.0, "ok", Outcome.NOT_DETECTED),
        (3, 0.0, "crash", 100.0, "ok", Outcome.CRASH),
        (4, 0.0, "timeout", 100.0, "ok", Outcome.TIMEOUT),
        (5, 900.0, "ok", 0.0, "crash", Outcome.BASELINE_FAILED),
        (6, 0.0, "crash", 0.0, "timeout", Outcome.BASELINE_FAILED),  # baseline failure takes precedence
        (7, math.nan, "ok", 100.0, "ok", Outcome.CRASH),  # ok but nothing mapped: no usable map
        (8, 900.0, "ok", math.nan, "ok", Outcome.BASELINE_FAILED),
    ]
    for case, f, fs, b, bs, _ in spec:
        rows.append(job(1, "fixed", case, "baseline", 0, b, bs))
        rows.append(job(1, "fixed", case, "motion_sign_error", 0, f, fs))
    oc = outcomes(frame(rows)).set_index("case")
    for case, *_, expected in spec:
        assert oc.loc[case, "outcome"] == expected, case
    assert Outcome("crash") is Outcome.CRASH and str(Outcome.NOT_DETECTED) == "not_detected"


def test_unknown_status_is_rejected():
    rows = frame([job(1, "fixed", 1, "baseline", 0, 1.0), job(1, "fixed", 1, "x", 0, 1.0)])
    rows.loc[1, "status"] = "exploded"
    with pytest.raises(ResultsError, match="unknown status 'exploded'"):
        classify(pair_with_baseline(rows))
