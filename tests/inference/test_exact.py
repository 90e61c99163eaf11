"""The sign-flip confidence interval: the shifts the exact two-sided test keeps (against scipy's test)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import permutation_test

from faultlab.errors import ConfigError
from faultlab.inference.exact import MAX_EXACT_PAIRS, sign_flip_interval, sign_flip_pvalues


def _scipy_p(x: np.ndarray) -> float:
    """Two-sided exact sign-flip p value of the mean by scipy, every sign pattern enumerated."""
    res = permutation_test((x,), np.mean, permutation_type="samples", n_resamples=np.inf,
                           alternative="two-sided")
    return float(res.pvalue)


values = st.lists(st.floats(-5, 5, allow_nan=False, allow_infinity=False).map(lambda v: round(v, 3)),
                  min_size=6, max_size=9)


@settings(max_examples=40, deadline=None)
@given(values)
def test_the_interval_is_the_set_of_shifts_scipys_test_does_not_reject(xs):
    """Just inside either bound scipy's two-sided test keeps the shift, just outside it rejects it."""
    x = np.array(xs)
    alpha = 0.05
    low, high = sign_flip_interval(x, level=1 - alpha)
    assert low <= x.mean() <= high
    span = max(high - low, 1e-3)
    eps = 1e-6 * span
    if high - low > 4 * eps:
        assert _scipy_p(x - (low + eps)) > alpha and _scipy_p(x - (high - eps)) > alpha
    assert _scipy_p(x - (low - 1e-3 * span)) <= alpha
    assert _scipy_p(x - (high + 1e-3 * span)) <= alpha


def test_the_interval_excludes_zero_exactly_when_the_test_rejects():
    rng = np.random.default_rng(3)
    for shift in np.linspace(0, 1.2, 13):
        x = rng.normal(shift, 1.0, size=10)
        low, high = sign_flip_interval(x, level=0.95)
        p = float(sign_flip_pvalues(x, alternative="two-sided"))
        assert (p <= 0.05) == (not low <= 0 <= high)


def test_the_bounds_are_hartigans_subset_means():
    """n = 6, level 0.9: m = floor(0.05 * 64) = 3, the 3rd smallest and 3rd largest of the 63 subset means."""
    x = np.array([-0.4, 0.1, 0.3, 0.8, 1.1, 2.0])
    means = sorted(np.mean([x[i] for i in range(6) if mask >> i & 1]) for mask in range(1, 64))
    assert sign_flip_interval(x, level=0.9) == pytest.approx((means[2], means[-3]), abs=1e-12)


def test_too_few_values_give_no_interval():
    """Five values: the smallest two-sided p is 2^-4 = 0.0625 > 0.05, so no shift is ever rejected."""
    assert all(math.isnan(b) for b in sign_flip_interval(np.arange(5.0), level=0.95))
    assert not any(math.isnan(b) for b in sign_flip_interval(np.arange(6.0), level=0.95))


def test_beyond_the_enumerated_size_random_subsets_approximate_the_t_interval():
    from statsmodels.stats.weightstats import DescrStatsW

    x = np.random.default_rng(5).normal(0.3, 1.0, size=MAX_EXACT_PAIRS + 20)
    low, high = sign_flip_interval(x, level=0.95, rng=np.random.default_rng(1))
    assert (low, high) == sign_flip_interval(x, level=0.95, rng=np.random.default_rng(1))
    t_low, t_high = DescrStatsW(x).tconfint_mean(alpha=0.05)
    assert low == pytest.approx(t_low, abs=0.05) and high == pytest.approx(t_high, abs=0.05)
    with pytest.raises(ConfigError, match="rng"):
        sign_flip_interval(x, level=0.95)
