"""The exact sign-flip test (faultlab.inference.exact): its p values, smallest p value and the pairs it needs
against brute-force enumeration in exact arithmetic, the smallest detectable shift by simulation, and the
sign-flip confidence interval against scipy's test."""

from __future__ import annotations

import itertools
import math
from fractions import Fraction

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import norm, permutation_test

from faultlab.errors import ConfigError
from faultlab.inference.exact import (MAX_EXACT_PAIRS, detectable_shift_factor, min_p_value, min_pairs,
                                      sign_flip_interval, sign_flip_pvalues)
from faultlab.inference.intervals import median_interval


def brute_force_p(d, alternative="greater") -> Fraction:
    """Share of the 2^K sign patterns whose sum is >= the observed sum (<= for "less"; twice the
    smaller, at most 1, for "two-sided"), in exact integer arithmetic."""
    if alternative == "two-sided":
        return min(Fraction(1), 2 * min(brute_force_p(d, "greater"), brute_force_p(d, "less")))
    d = [Fraction(x) for x in d]
    scale = math.lcm(*(x.denominator for x in d))
    ints = np.array([int(x * scale) for x in d], dtype=np.int64)
    signs = np.array(list(itertools.product((1, -1), repeat=len(d))), dtype=np.int64)
    sums = signs @ ints
    hits = sums >= ints.sum() if alternative == "greater" else sums <= ints.sum()
    return Fraction(int(np.sum(hits)), 2 ** len(d))


#: Differences on a grid of 1/8 between -4 and 4 (exact in binary floating point, many ties and zeros).
dyadic = st.integers(-32, 32).map(lambda i: i / 8)


# --------------------------------------------------------------------------- the test itself


@pytest.mark.parametrize("k", range(1, 13))
def test_p_values_equal_brute_force_enumeration_for_every_k(k):
    rng = np.random.default_rng(k)
    rows = np.vstack([rng.integers(-16, 17, (6, k)) / 4,           # dyadic: many ties and zeros
                      np.zeros((1, k)), np.abs(rng.integers(1, 9, (1, k)))])
    p = sign_flip_pvalues(rows)
    for row, pv in zip(rows, p):
        assert pv == float(brute_force_p(row)), row


@settings(max_examples=60, deadline=None)
@given(st.lists(dyadic, min_size=1, max_size=9))
def test_p_values_equal_brute_force_with_ties_and_zeros(d):
    assert sign_flip_pvalues(np.array(d)) == float(brute_force_p(d))


@settings(max_examples=60, deadline=None)
@given(st.lists(dyadic, min_size=1, max_size=9), st.sampled_from(["less", "two-sided"]))
def test_other_alternatives_equal_brute_force(d, alternative):
    assert sign_flip_pvalues(np.array(d), alternative=alternative) == pytest.approx(
        float(brute_force_p(d, alternative)), abs=1e-12)


def test_two_sided_floor_and_the_pairs_it_needs():
    for k in range(1, 13):
        # all of one sign: the two extreme patterns
        assert sign_flip_pvalues(-np.arange(1.0, k + 1), alternative="two-sided") == min(1.0, 2.0 ** (1 - k))
        assert min_p_value(k, alternative="two-sided") == min(1.0, 2.0 ** (1 - k))
    for alpha in (0.1, 0.05, 0.01, 0.05 / 15, 0.05 / 45, 0.001):
        for alt in ("greater", "two-sided"):
            k = min_pairs(alpha, alternative=alt)
            assert min_p_value(k, alternative=alt) <= alpha < min_p_value(k - 1, alternative=alt)
    assert (min_pairs(0.05 / 45), min_pairs(0.05 / 45, alternative="two-sided")) == (10, 11)
    with pytest.raises(ConfigError, match="alternative"):
        sign_flip_pvalues([1.0, 2.0], alternative="worse")


def test_median_interval_is_the_order_statistic_interval_with_its_exact_coverage():
    rng = np.random.default_rng(3)
    x = rng.normal(size=(4000, 10))
    lo, hi, cover = median_interval(x, level=0.95)
    # K = 10: [x_(2), x_(9)] covers with 1 - 2 P(B <= 1) = 1 - 22/1024
    assert cover == pytest.approx(1 - 22 / 1024)
    s = np.sort(x, axis=1)
    assert np.array_equal(lo, s[:, 1]) and np.array_equal(hi, s[:, 8])
    # simulated coverage of the true median 0 (binomial error of 4000 draws: sd 0.23 pp)
    assert np.mean((lo <= 0) & (0 <= hi)) == pytest.approx(cover, abs=0.01)
    # too few values for 95 %: the widest interval with its smaller coverage
    lo, hi, cover = median_interval(x[:, :5], level=0.95)
    assert cover == pytest.approx(1 - 2 / 32) and np.array_equal(lo, x[:, :5].min(axis=1))


def test_hand_computed_values():
    assert sign_flip_pvalues([1.0, 2.0, 3.0]) == 1 / 8          # only the observed pattern
    assert sign_flip_pvalues([3.0, -1.0, 2.0]) == 2 / 8         # sums 6 and 4 reach 4
    assert sign_flip_pvalues([1.0, -1.0]) == 3 / 4              # sums 2, 0, 0 reach 0
    assert sign_flip_pvalues([0.0, 0.0, 5.0]) == 1 / 2          # zeros do not count: as [5]
    assert sign_flip_pvalues([0.0, 0.0, 0.0]) == 1.0            # no evidence at all
    assert sign_flip_pvalues([-1.0, -2.0]) == 1.0
    # ties in |d|: (2, 2, -2) -> sums >= 2: (2,2,-2), (2,-2,2), (-2,2,2), (2,2,2) = 4 of 8
    assert sign_flip_pvalues([2.0, 2.0, -2.0]) == 0.5


def test_minimum_p_values():
    for k in range(1, 13):
        assert sign_flip_pvalues(np.arange(1.0, k + 1)) == min_p_value(k) == 2.0 ** -k
        # z zeros: the floor is that of the non-zero differences
        for z in range(k):
            d = np.concatenate([np.zeros(z), np.arange(1.0, k - z + 1)])
            assert sign_flip_pvalues(d) == 2.0 ** -(k - z)
    np.testing.assert_array_equal(min_p_value(np.array([0, 1, 5])), [1.0, 0.5, 1 / 32])
    # the table of the module docstring
    assert [min_pairs(a) for a in (0.5, 0.25, 0.1, 0.0625, 0.05, 0.01, 0.001)] == [1, 2, 4, 4, 5, 7, 10]
    for alpha in np.linspace(0.001, 0.99, 200):
        k = min_pairs(alpha)
        assert 2.0 ** -k <= alpha < 2.0 ** -(k - 1) or k == 0


@settings(max_examples=60, deadline=None)
@given(st.lists(dyadic, min_size=1, max_size=10), st.integers(0, 9), st.integers(1, 16))
def test_p_value_never_increases_when_a_difference_grows(d, i, step):
    d = np.array(d)
    bigger = d.copy()
    bigger[i % d.size] += step / 8
    shifted = d + step / 8
    p = sign_flip_pvalues(d)
    assert sign_flip_pvalues(bigger) <= p
    assert sign_flip_pvalues(shifted) <= p
    assert min_p_value(d.size) <= p <= 1.0


@settings(max_examples=40, deadline=None)
@given(st.lists(dyadic, min_size=1, max_size=10), st.randoms(use_true_random=False))
def test_p_value_ignores_the_order_and_the_scale(d, random):
    d = np.array(d)
    perm = np.array(random.sample(range(d.size), d.size))
    assert sign_flip_pvalues(d[perm]) == sign_flip_pvalues(d) == sign_flip_pvalues(4.0 * d)


def test_bad_input():
    with pytest.raises(ConfigError, match="K <= 20"):
        sign_flip_pvalues(np.ones(MAX_EXACT_PAIRS + 1))
    with pytest.raises(ConfigError, match="finite"):
        sign_flip_pvalues([1.0, np.nan])
    with pytest.raises(ConfigError, match="alpha"):
        min_pairs(1.0)
    with pytest.raises(ConfigError, match="-1"):
        min_p_value(-1)


# --------------------------------------------------------------------------- smallest detectable shift


def test_rejection_threshold_of_one_draw_is_the_mth_largest_negated_subset_mean():
    """The identity behind the simulation: reject iff delta > v_(m), checked with the test itself."""
    rng = np.random.default_rng(3)
    k, alpha = 7, 0.05
    m = math.floor(alpha * 2 ** k)
    for _ in range(5):
        e = rng.standard_normal(k)
        v = sorted((-np.mean(e[list(f)]) for r in range(1, k + 1) for f in itertools.combinations(range(k), r)),
                   reverse=True)
        assert sign_flip_pvalues(e + v[m - 1] + 1e-9) <= alpha
        assert sign_flip_pvalues(e + v[m - 1] - 1e-9) > alpha


@pytest.mark.parametrize("k", [5, 8, 11])
def test_detectable_shift_has_the_stated_power(k):
    """At delta = c(K) sigma the test rejects in 80 % of fresh normal samples (another generator)."""
    c = detectable_shift_factor(k, alpha=0.05, power=0.8)
    sigma = 37.0
    d = np.random.default_rng(100 + k).normal(c * sigma, sigma, (3000, k))
    power = np.mean(sign_flip_pvalues(d) <= 0.05)
    assert abs(power - 0.8) < 0.03  # Monte Carlo standard error 0.007
    d_small = np.random.default_rng(200 + k).normal(0.7 * c * sigma, sigma, (3000, k))
    assert np.mean(sign_flip_pvalues(d_small) <= 0.05) < 0.7


def test_detectable_shift_factor_limits_and_shape():
    assert detectable_shift_factor(4, alpha=0.05) == math.inf      # 2^-4 > 0.05: nothing detectable
    assert math.isfinite(detectable_shift_factor(4, alpha=0.1))
    factors = [detectable_shift_factor(k) for k in range(5, MAX_EXACT_PAIRS + 1)]
    assert all(a > b for a, b in zip(factors, factors[1:]))         # more pairs, smaller shifts
    # beyond 12 pairs the paired t test's power: close to the normal-theory value
    for k in (13, 20):
        z = (norm.ppf(0.95) + norm.ppf(0.8)) / math.sqrt(k)
        assert z < detectable_shift_factor(k) < 1.1 * z
    assert detectable_shift_factor(8, power=0.9) > detectable_shift_factor(8, power=0.8)
    assert detectable_shift_factor(8, alpha=0.01) > detectable_shift_factor(8, alpha=0.05)
    with pytest.raises(ConfigError, match="power"):
        detectable_shift_factor(8, power=1.0)
    with pytest.raises(ConfigError, match="k must"):
        detectable_shift_factor(0)


@pytest.mark.parametrize("k,n,alternative", [(10, 15, "two-sided"), (8, 5, "two-sided"), (7, 5, "greater")])
def test_smallest_detectable_shift_has_its_power_at_the_decisions_level(k, n, alternative):
    """Simulated with an independent generator: the shift c(K) sigma is detected by the decision's test
    (its sidedness, Holm's first step alpha / n) with 80 % power, within 2 percentage points."""
    level = 0.05 / n
    c = detectable_shift_factor(k, alpha=level, alternative=alternative)
    e = np.random.default_rng(np.random.SeedSequence(99)).standard_normal((8000, k))
    p = sign_flip_pvalues(c + e, alternative=alternative)
    assert np.mean(p <= level) == pytest.approx(0.8, abs=0.02)


# --------------------------------------------------------------------------- the sign-flip confidence interval


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
