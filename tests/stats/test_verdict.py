"""Per-case verdicts (exact sign-flip test) and clustered rates, against independent references."""

from __future__ import annotations

import itertools
import math
from fractions import Fraction

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import norm, t
from statsmodels.stats.proportion import proportion_confint

from faultlab.errors import ConfigError, ResultsError
from faultlab.inference.exact import (MAX_EXACT_PAIRS, detectable_shift_factor, min_p_value, min_pairs,
                                      sign_flip_pvalues)
from faultlab.inference.intervals import clustered_rate, median_interval
from faultlab.stats.verdict import Verdict, case_verdicts
from tests.stats.synthetic import frame, job


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


# --------------------------------------------------------------------------- case verdicts


FAULTS = ("naive_resampling", "motion_sign_error")


def campaign(k=8, *, seed=0, shifts=(0.0, 600.0, 150.0), statuses=None, base_statuses=None):
    """K repetitions of the baseline and two faults on len(shifts) random-suite cases of run 1.

    ``statuses[(case, fault, rep)]`` / ``base_statuses[(case, rep)]`` override a job's status.
    """
    rng = np.random.default_rng(seed)
    statuses, base_statuses = statuses or {}, base_statuses or {}
    rows = []
    for case, shift in enumerate(shifts, 1):
        base = rng.normal(1000.0, 80.0, k)
        for rep in range(k):
            rows.append(job(1, "random", case, "baseline", rep, base[rep],
                            status=base_statuses.get((case, rep), "ok")))
            for j, fault in enumerate(FAULTS):
                value = base[rep] + (j + 1) * shift + rng.normal(0.0, 40.0)
                rows.append(job(1, "random", case, fault, rep, value, status=statuses.get((case, fault, rep), "ok")))
    return frame(rows)


def test_verdicts_follow_the_exact_test_on_pairs_matched_by_repetition():
    res = campaign(seed=1)  # seed 0 draws a no-effect case whose noise alone is two-sided significant
    shuffled = res.sample(frac=1.0, random_state=1)  # pairing is by repetition, not by row order
    table = case_verdicts(shuffled).set_index(["case", "fault"])
    assert len(table) == 6
    for (case, fault), row in table.iterrows():
        f = res[(res["case"] == case) & (res["variant"] == fault)].set_index("rep")["rms_mm"]
        b = res[(res["case"] == case) & (res["variant"] == "baseline")].set_index("rep")["rms_mm"]
        d = (f - b.reindex(f.index)).to_numpy()
        assert row["p"] == pytest.approx(float(brute_force_p(d, "two-sided")), abs=1e-12)
        assert row["alternative"] == "two-sided"
        assert row["direction"] == ("worse" if d.mean() > 0 else "better")
        s = np.sort(d)
        assert (row["median_low_mm"], row["median_high_mm"]) == (s[0], s[7])  # K = 8: 1 - 2/256 >= 95 %
        r = np.sort(f.to_numpy() / b.reindex(f.index).to_numpy())
        assert row["ratio"] == pytest.approx(np.median(r)) and (row["ratio_low"], row["ratio_high"]) == (r[0], r[7])
        assert row["verdict"] == (Verdict.DETECTED if row["p"] <= 0.05 else Verdict.NOT_DETECTED)
        assert row["detected"] == (row["p"] <= 0.05)
        assert row["n_pairs"] == row["n_reps"] == 8 and row["n_failed"] == 0 and row["reason"] == ""
        assert row["mean_diff_mm"] == pytest.approx(d.mean()) and row["median_diff_mm"] == pytest.approx(np.median(d))
        assert row["p_min"] == 2.0 ** -7
        sd = np.std(b.to_numpy(), ddof=1)
        assert row["baseline_sd_mm"] == pytest.approx(sd)
        assert row["mde_mm"] == pytest.approx(detectable_shift_factor(8, alternative="two-sided")
                                              * math.sqrt(2.0) * sd)
    assert table.loc[(2, "motion_sign_error"), "verdict"] == Verdict.DETECTED
    assert table.loc[(1, "naive_resampling"), "verdict"] == Verdict.NOT_DETECTED


def test_a_planted_improving_fault_is_a_change_with_direction_better():
    """A fault that lowers the error on every case: the two-sided rule detects it as "better" with
    its effect; the paper's one-sided notion does not detect it."""
    res = campaign(k=10, seed=2, shifts=(-120.0, -200.0, -300.0))
    two = case_verdicts(res).set_index(["case", "fault"])
    assert (two["verdict"] == Verdict.DETECTED).all() and (two["direction"] == "better").all()
    assert (two["median_high_mm"] < 0).all() and (two["ratio_high"] < 1).all()
    for (case, fault), row in two.iterrows():  # the planted shift lies in the effect interval
        planted = (1 + FAULTS.index(fault)) * (-120.0, -200.0, -300.0)[case - 1]
        assert row["median_low_mm"] < planted < row["median_high_mm"]
    one = case_verdicts(res, direction="worse")
    assert (one["verdict"] == Verdict.NOT_DETECTED).all() and (one["p"] > 0.9).all()
    assert (one["alternative"] == "greater").all()


def test_a_failure_of_the_faulty_variant_alone_is_a_detection():
    res = campaign(statuses={(1, "naive_resampling", 3): "crash", (1, "motion_sign_error", 0): "timeout"})
    res.loc[(res["case"] == 2) & (res["variant"] == "naive_resampling") & (res["rep"] == 5), "rms_mm"] = np.nan
    table = case_verdicts(res).set_index(["case", "fault"])
    for cell, failed in (((1, "naive_resampling"), 1), ((1, "motion_sign_error"), 1), ((2, "naive_resampling"), 1)):
        row = table.loc[cell]
        assert row["verdict"] == Verdict.CRASH_DETECTED and bool(row["detected"])
        assert row["n_failed"] == failed and row["n_pairs"] == 7 and np.isnan(row["p"])
    assert table.loc[(2, "motion_sign_error"), "verdict"] == Verdict.DETECTED


def test_a_failed_baseline_makes_the_case_unjudgeable_never_a_miss():
    res = campaign(base_statuses={(1, 4): "crash", (2, 0): "timeout"},
                   statuses={(2, "naive_resampling", 3): "crash"})
    res = res[~((res["case"] == 3) & (res["variant"] == "baseline") & (res["rep"] == 7))]  # missing job
    table = case_verdicts(res).set_index(["case", "fault"])
    assert (table["verdict"] == Verdict.CANNOT_JUDGE).all()
    assert (table["reason"] == "baseline_failed").all()
    assert table["detected"].isna().all()
    assert table["p"].isna().all() and table["mde_mm"].isna().all()


def test_too_few_pairs_cannot_be_judged_at_that_alpha():
    res = campaign(k=4, shifts=(5000.0,))
    table = case_verdicts(res, alpha=0.05)
    assert (table["verdict"] == Verdict.CANNOT_JUDGE).all() and (table["reason"] == "too_few_pairs").all()
    assert np.isinf(table["mde_mm"]).all() and table["detected"].isna().all()
    lenient = case_verdicts(res, alpha=0.1, direction="worse")  # one-sided 2^-4 = 0.0625 <= 0.1
    assert (lenient["verdict"] == Verdict.DETECTED).all() and (lenient["p"] == 2.0 ** -4).all()
    two_sided = case_verdicts(res, alpha=0.1)  # two-sided 2^-3 > 0.1
    assert (two_sided["reason"] == "too_few_pairs").all()
    strict = case_verdicts(campaign(k=6, shifts=(5000.0,)), min_pairs_required=7)
    assert (strict["reason"] == "too_few_pairs").all()
    # a missing faulty job leaves fewer pairs
    res6 = campaign(k=6, shifts=(5000.0,))
    res6 = res6[~((res6["variant"] == "naive_resampling") & (res6["rep"] == 2))]
    row = case_verdicts(res6).set_index("fault").loc["naive_resampling"]
    assert (row["verdict"], row["n_reps"], row["n_pairs"]) == (Verdict.CANNOT_JUDGE, 5, 5)


def test_vectorised_verdicts_equal_one_case_at_a_time():
    rng = np.random.default_rng(5)
    rows = []
    for case in range(1, 13):
        k = int(rng.integers(5, 10))  # cases with different K in one call
        base = rng.normal(500.0, 50.0, k)
        for rep in range(k):
            rows.append(job(2, "fixed", case, "baseline", rep, base[rep]))
            rows.append(job(2, "fixed", case, "naive_resampling", rep, base[rep] + rng.normal(30.0, 60.0)))
    res = frame(rows)
    together = case_verdicts(res)
    alone = pd.concat([case_verdicts(res[res["case"] == c]) for c in range(1, 13)], ignore_index=True)
    pd.testing.assert_frame_equal(together, alone)
    assert together["n_pairs"].nunique() > 1 and together["p"].nunique() > 3


def test_metric_choice_and_bad_input():
    res = campaign()
    emd = case_verdicts(res, metric="emd")
    assert (emd["mean_diff_mm"].to_numpy() == pytest.approx(case_verdicts(res)["mean_diff_mm"].to_numpy() / 2))
    by_ate = case_verdicts(res.assign(ate_mm=3 * res["rms_mm"]), metric="ate")  # the trajectory error's column
    assert (by_ate["mean_diff_mm"].to_numpy() == pytest.approx(3 * case_verdicts(res)["mean_diff_mm"].to_numpy()))
    with pytest.raises(ConfigError, match="metric"):
        case_verdicts(res, metric="mae")
    with pytest.raises(ConfigError, match="alpha"):
        case_verdicts(res, alpha=0.0)
    with pytest.raises(ConfigError, match="power"):
        case_verdicts(res, power=1.5)
    with pytest.raises(ResultsError, match="more than once"):
        case_verdicts(pd.concat([res, res.iloc[:1]]))
    with pytest.raises(ResultsError, match="status"):
        case_verdicts(res.assign(status="weird"))
    with pytest.raises(ResultsError, match="rms_mm"):
        case_verdicts(res.drop(columns="rms_mm"))
    assert case_verdicts(res[res["variant"] == "baseline"]).empty


# --------------------------------------------------------------------------- clustered rate


def test_clustered_rate_against_the_formula_written_out():
    y = np.array([1, 0, 0, 1, 1, 1, 0, 0, 0, 0, 1, 0, 1, 1, 0])
    c = np.array([0, 0, 0, 1, 1, 1, 2, 2, 2, 3, 3, 3, 4, 4, 4])
    r = clustered_rate(y, c)
    n, g, p = y.size, 5, y.mean()
    resid = pd.Series(y - p).groupby(c).sum().to_numpy()
    var = g / (g - 1) * np.sum(resid ** 2) / n ** 2  # CR1 sandwich for a mean
    deff = var / (p * (1 - p) / n)
    n_eff = n / max(deff, 1.0) * (norm.ppf(0.975) / t.ppf(0.975, g - 1)) ** 2
    assert (r.rate, r.n, r.flagged, r.n_clusters) == (p, n, 7, g)
    assert r.design_effect == pytest.approx(deff, rel=1e-10)
    assert r.n_effective == pytest.approx(n_eff, rel=1e-10)
    # Clopper-Pearson by its beta-quantile definition
    from scipy.stats import beta
    x = p * n_eff
    assert r.low == pytest.approx(beta.ppf(0.025, x, n_eff - x + 1), rel=1e-9)
    assert r.high == pytest.approx(beta.ppf(0.975, x + 1, n_eff - x), rel=1e-9)


def test_clustered_rate_edge_cases():
    zero = clustered_rate(np.zeros(12, bool), np.repeat(np.arange(4), 3))
    assert zero.rate == 0.0 and zero.low == 0.0 and np.isnan(zero.design_effect)
    n_eff = 4 * (norm.ppf(0.975) / t.ppf(0.975, 3)) ** 2  # conservative: one trial per cluster
    assert zero.n_effective == pytest.approx(n_eff)
    assert zero.high == pytest.approx(1 - 0.025 ** (1 / n_eff))  # Clopper-Pearson upper bound for 0 successes
    # independent trials (each its own cluster) with a design effect below 1 keep n
    many = clustered_rate(np.arange(40) % 4 == 0, np.arange(40))
    assert many.n_effective <= 40
    empty = clustered_rate([], [])
    assert np.isnan(empty.rate) and empty.n == 0
    strings = clustered_rate([True, False, True], ["a", "b", "b"])
    assert strings.n_clusters == 2
    with pytest.raises(ConfigError, match="equal length"):
        clustered_rate([1, 0], [1])
    with pytest.raises(ConfigError, match="0/1"):
        clustered_rate([2, 0], [1, 1])
    with pytest.raises(ConfigError, match="alpha"):
        clustered_rate([1, 0], [1, 1], alpha=1.0)


def test_clustered_interval_keeps_its_coverage_where_the_binomial_one_does_not():
    """Beta-binomial clusters: 30 cases x 6 pairs, rate 0.1, intra-case correlation 0.3."""
    rng = np.random.default_rng(2024)
    n_sim, g, m, rate, icc = 300, 30, 6, 0.1, 0.3
    s = 1 / icc - 1
    covered = naive = 0
    clusters = np.repeat(np.arange(g), m)
    for _ in range(n_sim):
        p_case = rng.beta(rate * s, (1 - rate) * s, g)
        y = (rng.random((g, m)) < p_case[:, None]).ravel()
        r = clustered_rate(y, clusters)
        covered += r.low <= rate <= r.high
        lo, hi = proportion_confint(y.sum(), y.size, method="wilson")
        naive += lo <= rate <= hi
    assert 0.91 <= covered / n_sim <= 0.99  # nominal 0.95; Monte Carlo standard error 0.013
    assert naive / n_sim < 0.85             # the binomial interval treats 180 trials as independent


def test_equivalence_is_tost_with_the_shifted_exact_test_and_identity_is_observed():
    rng = np.random.default_rng(4)
    k, rows = 10, []
    base = rng.normal(1000.0, 30.0, k)
    for rep in range(k):
        rows.append(job(1, "fixed", 1, "baseline", rep, base[rep]))
        rows.append(job(1, "fixed", 1, "naive_resampling", rep, base[rep] + rng.normal(0.0, 10.0)))  # within 10 %
        rows.append(job(1, "fixed", 1, "motion_sign_error", rep, base[rep] + 95.0 + rng.normal(0.0, 10.0)))
        rows.append(job(1, "fixed", 1, "missing_angle_wrap", rep, base[rep]))                         # bit-identical
    res = frame(rows)
    table = case_verdicts(res).set_index("fault")
    delta = 0.10 * np.median(base)
    for fault, row in table.iterrows():
        d = res[res["variant"] == fault]["rms_mm"].to_numpy() - base
        # the larger of the two one-sided p values on the shifted differences, by enumeration
        expect = max(brute_force_p(d + delta, "greater"), brute_force_p(d - delta, "less"))
        assert row["margin_mm"] == pytest.approx(delta)
        assert row["p_equivalence"] == pytest.approx(float(expect), abs=1e-12)
    assert table.loc["naive_resampling", "p_equivalence"] <= 0.05          # equivalent within +-10 %
    assert table.loc["motion_sign_error", "p_equivalence"] > 0.05          # 95 mm of 100: not shown
    assert table.loc["missing_angle_wrap", "identical"] and not table.loc["naive_resampling", "identical"]
    assert np.isnan(table.loc["missing_angle_wrap", "median_low_mm"])     # no interval from identical runs
    # an absolute margin replaces a smaller relative one
    wide = case_verdicts(res, margin_mm=200.0).set_index("fault")
    assert wide.loc["motion_sign_error", "p_equivalence"] <= 0.05
    with pytest.raises(ConfigError, match="margin_rel"):
        case_verdicts(res, margin_rel=-0.1)


@pytest.mark.parametrize("k,n,alternative", [(10, 15, "two-sided"), (8, 5, "two-sided"), (7, 5, "greater")])
def test_smallest_detectable_shift_has_its_power_at_the_decisions_level(k, n, alternative):
    """Simulated with an independent generator: the shift c(K) sigma is detected by the decision's test
    (its sidedness, Holm's first step alpha / n) with 80 % power, within 2 percentage points."""
    level = 0.05 / n
    c = detectable_shift_factor(k, alpha=level, alternative=alternative)
    e = np.random.default_rng(np.random.SeedSequence(99)).standard_normal((8000, k))
    p = sign_flip_pvalues(c + e, alternative=alternative)
    assert np.mean(p <= level) == pytest.approx(0.8, abs=0.02)


# --------------------------------------------------------------------------- deterministic cases


def deterministic_campaign(k=10, *, base=(812.5, 640.25, 1020.0), faulty=(900.0, 640.25, 700.0)):
    """A planted deterministic SLAM: every repetition of a case gives the same error, bit for bit
    (baseline ``base[i]``, the fault ``faulty[i]`` on case i + 1), as EKF-SLAM does whatever its seed."""
    rows = []
    for case, (b, f) in enumerate(zip(base, faulty), 1):
        for rep in range(k):
            rows.append(job(1, "systematic", case, "baseline", rep, b))
            rows.append(job(1, "systematic", case, "naive_resampling", rep, f))
    return frame(rows)


def test_a_deterministic_case_is_judged_by_its_exact_difference_not_a_test_over_copies():
    """Ten copies of one execution: a sign-flip test would report p = 2^-9 from one observation; the
    verdict is the difference itself, with no p value, no interval, and any shift detectable."""
    table = case_verdicts(deterministic_campaign()).set_index("case")
    assert (table["test"] == "exact").all()
    assert table["p"].isna().all() and table["p_min"].isna().all() and table["p_equivalence"].isna().all()
    assert table["median_low_mm"].isna().all() and table["ratio_low"].isna().all()
    assert list(table["verdict"]) == [Verdict.DETECTED, Verdict.NOT_DETECTED, Verdict.DETECTED]
    assert list(table["direction"]) == ["worse", "none", "better"]
    assert list(table["mean_diff_mm"]) == [900.0 - 812.5, 0.0, 700.0 - 1020.0]
    assert table.loc[1, "ratio"] == 900.0 / 812.5 and table.loc[3, "ratio"] == 700.0 / 1020.0
    assert (table["mde_mm"] == 0).all()
    assert list(table["identical"]) == [False, True, False]


def test_a_deterministic_case_needs_no_minimum_of_pairs_and_one_stochastic_repetition_ends_it():
    few = case_verdicts(deterministic_campaign(k=3)).set_index("case")  # K = 3 < min_pairs: still judged
    assert (few["test"] == "exact").all() and few.loc[1, "verdict"] == Verdict.DETECTED
    res = deterministic_campaign()
    wobble = (res["case"] == 1) & (res["variant"] == "baseline") & (res["rep"] == 4)
    res.loc[wobble, "rms_mm"] = 812.5 + 1e-9  # the baseline varies on case 1: the repetitions are evidence
    table = case_verdicts(res).set_index("case")
    assert table.loc[1, "test"] == "sign-flip" and table.loc[1, "p"] == pytest.approx(2.0 ** -9)
    assert list(table.loc[[2, 3], "test"]) == ["exact", "exact"]
    one = case_verdicts(deterministic_campaign(k=1))  # one repetition shows nothing about determinism
    assert (one["test"] == "").all() and (one["verdict"] == Verdict.CANNOT_JUDGE).all()


def test_rule_verdicts_keep_an_exact_case_out_of_the_holm_family():
    from faultlab.metrics.detection import DetectionRule
    from faultlab.stats.cases import rule_verdicts
    from faultlab.stats.detection import outcomes

    res = deterministic_campaign()
    rule = DetectionRule(rule="statistical", family="fault")
    table = rule_verdicts(res, outcomes(res, rule=rule), rule=rule).set_index("case")
    assert table["p_holm"].isna().all() and (table["test"] == "exact").all()
    assert list(table["verdict"]) == [Verdict.DETECTED, Verdict.NOT_DETECTED, Verdict.DETECTED]


def test_the_committed_deterministic_slams_are_judged_exactly_and_the_stochastic_ones_by_the_test(tmp_path):
    """reports/slams: EKF-SLAM's repetitions are bit-identical on every case, FastSLAM's are not."""
    import shutil

    from faultlab.runner.store import load_results
    from tests.report.committed import REPORTS

    for slam, test in (("ekf", "exact"), ("fastslam1", "sign-flip")):
        store = tmp_path / slam
        store.mkdir()
        shutil.copy2(REPORTS / "slams" / "store" / slam / "results.sqlite", store / "results.sqlite")
        v = case_verdicts(load_results(store))
        assert len(v) >= 10 and (v["test"] == test).all(), slam
