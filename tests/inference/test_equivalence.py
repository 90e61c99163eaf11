"""Regression / equivalence verdicts on log ratios, against textbook transcriptions and SciPy's one-sided tests."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from faultlab.errors import ConfigError
from faultlab.inference.equivalence import (
    EQUIVALENT,
    IDENTICAL,
    IMPROVEMENT,
    INCONCLUSIVE,
    REGRESSION,
    compare_exact,
    compare_paired,
    compare_samples,
    percent,
    relative_margin,
)

MARGIN = math.log(1.1)


def _textbook_paired(d, alpha, margin):
    """Student's t interval and one-sided tests written out: mean +- t_{1-alpha, n-1} s / sqrt(n)."""
    n = d.size
    se = d.std(ddof=1) / math.sqrt(n)
    t = d.mean() / se
    q = stats.t.ppf(1 - alpha, n - 1)
    p_low = stats.t.sf((d.mean() + margin) / se, n - 1)  # H0: effect <= -margin
    p_high = stats.t.cdf((d.mean() - margin) / se, n - 1)  # H0: effect >= +margin
    return (d.mean() - q * se, d.mean() + q * se), stats.t.sf(t, n - 1), stats.t.cdf(t, n - 1), max(p_low, p_high)


def test_paired_matches_the_textbook_t_interval_and_tests():
    rng = np.random.default_rng(3)
    b = rng.normal(5.0, 1.0, 20)
    c = b + rng.normal(0.03, 0.05, 20)
    got = compare_paired(b, c, margin=MARGIN, alpha=0.05)
    (lo, hi), p_reg, p_imp, p_eq = _textbook_paired(c - b, 0.05, MARGIN)
    assert got.ci_low == pytest.approx(lo, rel=1e-10) and got.ci_high == pytest.approx(hi, rel=1e-10)
    assert got.p_regression == pytest.approx(p_reg, rel=1e-9)
    assert got.p_improvement == pytest.approx(p_imp, rel=1e-9)
    assert got.p_equivalence == pytest.approx(p_eq, rel=1e-9)
    assert got.n == 20


@settings(max_examples=60, deadline=None)
@given(shift=st.floats(-0.3, 0.3), sd=st.floats(0.01, 0.4), n=st.integers(3, 30), seed=st.integers(0, 2**31))
def test_verdict_agrees_with_the_interval(shift, sd, n, seed):
    """TOST at alpha <=> the 1 - 2 alpha interval inside (-margin, margin); regression <=> lower end > 0."""
    rng = np.random.default_rng(seed)
    d = shift + sd * rng.standard_normal(n)
    r = compare_paired(np.zeros(n), d, margin=MARGIN, alpha=0.05)
    inside = -MARGIN < r.ci_low and r.ci_high < MARGIN
    if r.verdict == EQUIVALENT:
        assert inside
    else:
        assert not inside or math.isclose(max(abs(r.ci_low), abs(r.ci_high)), MARGIN, rel_tol=1e-9)
        assert (r.verdict == REGRESSION) == (r.ci_low > 0)
        assert (r.verdict == IMPROVEMENT) == (r.ci_high < 0)


def test_identical_and_constant_differences_are_exact():
    b = np.log([10.0, 20.0, 40.0])
    same = compare_paired(b, b, margin=MARGIN, alpha=0.05)
    assert same.verdict == IDENTICAL and math.isnan(same.ci_low) and math.isnan(same.p_regression)
    worse = compare_paired(b, b + math.log(1.2), margin=MARGIN, alpha=0.05)
    assert worse.verdict == REGRESSION and worse.effect == pytest.approx(math.log(1.2))
    slightly = compare_paired(b, b + math.log(1.05), margin=MARGIN, alpha=0.05)
    assert slightly.verdict == EQUIVALENT
    assert compare_exact(-0.5, margin=MARGIN, alpha=0.05).verdict == IMPROVEMENT


def test_planted_regression_is_found_and_noise_alone_is_not():
    rng = np.random.default_rng(8)
    b = rng.normal(5.0, 1.0, 25)
    assert compare_paired(b, b + 0.3 + rng.normal(0, 0.05, 25), margin=MARGIN, alpha=0.05).verdict == REGRESSION
    assert compare_paired(b, b + rng.normal(0, 0.02, 25), margin=MARGIN, alpha=0.05).verdict == EQUIVALENT
    assert compare_paired(b, b + rng.normal(0, 1.0, 25), margin=MARGIN, alpha=0.05).verdict == INCONCLUSIVE


def test_samples_match_scipy_welch_one_sided_tests_on_shifted_data():
    rng = np.random.default_rng(5)
    b, c = rng.normal(3.0, 0.2, 8), rng.normal(3.05, 0.3, 8)
    got = compare_samples(b, c, margin=MARGIN, alpha=0.05)
    low = stats.ttest_ind(c + MARGIN, b, equal_var=False, alternative="greater").pvalue
    high = stats.ttest_ind(c - MARGIN, b, equal_var=False, alternative="less").pvalue
    assert got.p_equivalence == pytest.approx(max(low, high), rel=1e-9)
    assert got.p_regression == pytest.approx(stats.ttest_ind(c, b, equal_var=False, alternative="greater").pvalue)
    assert got.effect == pytest.approx(c.mean() - b.mean())
    assert got.ci_low < got.effect < got.ci_high


def test_samples_of_deterministic_runs_are_exact():
    r = compare_samples(np.full(3, 2.0), np.full(3, 2.5), margin=MARGIN, alpha=0.05)
    assert r.verdict == REGRESSION and math.isnan(r.p_regression)


def test_inputs_are_validated():
    with pytest.raises(ConfigError):
        compare_paired([1.0, np.inf], [1.0, 2.0], margin=MARGIN, alpha=0.05)
    with pytest.raises(ConfigError):
        compare_paired([1.0, 2.0], [1.0], margin=MARGIN, alpha=0.05)
    with pytest.raises(ConfigError):
        relative_margin(1.5)
    assert relative_margin(0.1) == pytest.approx(math.log(1.1))
    assert percent(math.log(1.1)) == pytest.approx(10.0)
    assert compare_paired([1.0], [2.0], margin=MARGIN, alpha=0.05).verdict == INCONCLUSIVE  # one case: no test
