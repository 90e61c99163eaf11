"""Two arms compared paired by cluster: against library routines, and by simulation at the studies' cluster counts."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats
from statsmodels.stats.power import TTestPower
from statsmodels.stats.weightstats import ttost_paired

from faultlab.errors import ConfigError
from faultlab.inference.clusters import (cluster_differences, clusters_for_difference, compare_by_cluster,
                                         equivalence_power)
from faultlab.inference.exact import sign_flip_pvalues

ALPHA = 0.05
#: Cluster counts of the studies judged by run: the pilot's 11 evaluation runs and the confirmatory study's 13.
CLUSTER_COUNTS = (11, 13)
#: Simulated studies per cluster count: the Monte Carlo standard error of a rate near 0.05 is 0.0034, so a
#: level within 2 pp of 0.05 is checked with a margin of about six standard errors.
SIMULATIONS = 4000


def _study(rng, *, clusters: int, cases: int = 15, faults: int = 17, shift: float = 0.0,
           interaction: float = 0.0, sims: int = SIMULATIONS):
    """``sims`` simulated studies shaped like the strategies study: per run, each of two arms draws ``cases``
    cases; a case detects each of ``faults`` faults with a probability that varies by fault, by run (shared
    by the arms), by arm within the run (``interaction``: a suite of one run is one stratified draw) and by
    case.  Returns per-case scores (share of faults detected), shape (sims, clusters, 2, cases)."""
    logit = (rng.normal(0.5, 2.0, size=(sims, 1, 1, 1, faults))        # faults, easy and hard
             + rng.normal(0, 0.6, size=(sims, clusters, 1, 1, 1))      # the run
             + rng.normal(0, interaction, size=(sims, clusters, 2, 1, 1))  # the arm's suite in the run
             + rng.normal(0, 0.8, size=(sims, clusters, 2, cases, 1)))   # the case
    logit[:, :, 0] += shift
    return (rng.random(logit.shape) < 1 / (1 + np.exp(-logit))).mean(axis=-1)


def _arms(scores):
    """Flatten one simulated study to (x, arm, cluster)."""
    clusters, _, cases = scores.shape
    arm = np.broadcast_to(np.array([True, False])[None, :, None], scores.shape).reshape(-1)
    cluster = np.broadcast_to(np.arange(clusters)[:, None, None], scores.shape).reshape(-1)
    return scores.reshape(-1), arm, cluster


def test_the_comparison_is_the_paired_t_test_tost_and_sign_flip_test_over_cluster_means():
    rng = np.random.default_rng(3)
    scores = _study(rng, clusters=9, shift=0.3, interaction=0.3, sims=1)[0]
    x, arm, cluster = _arms(scores)
    perm = rng.permutation(x.size)  # the order of the cases does not matter
    res = compare_by_cluster(x[perm], arm=arm[perm], cluster=cluster[perm], margin=0.05)
    a, b = scores[:, 0].mean(axis=1), scores[:, 1].mean(axis=1)
    ref = stats.ttest_rel(a, b)
    assert res.clusters == 9 and res.estimate == pytest.approx(np.mean(a - b), abs=1e-12)
    assert res.p == pytest.approx(ref.pvalue, rel=1e-10)
    ci = ref.confidence_interval(0.95)
    assert (res.ci_low, res.ci_high) == pytest.approx((ci.low, ci.high), rel=1e-10)
    assert res.sd == pytest.approx(np.std(a - b, ddof=1), rel=1e-12)
    assert res.p_equivalence == pytest.approx(ttost_paired(a, b, -0.05, 0.05)[0], rel=1e-10)
    flip = stats.permutation_test((a - b,), np.mean, permutation_type="samples", n_resamples=np.inf).pvalue
    assert res.p_exact == pytest.approx(flip, rel=1e-12)
    assert res.ci_low < res.estimate < res.ci_high


def test_clusters_without_both_arms_are_left_out_and_degenerate_samples_give_no_interval():
    labels, d = cluster_differences([1.0, 0.0, 0.5, 0.25], arm=[True, False, True, True], cluster=[1, 1, 2, 3])
    assert labels.tolist() == [1] and d.tolist() == [1.0]
    one = compare_by_cluster([1.0, 0.0], arm=[True, False], cluster=[1, 1])
    assert one.clusters == 1 and np.isnan(one.ci_low) and np.isnan(one.p)
    flat = compare_by_cluster([0.5, 0.5, 0.5, 0.5], arm=[True, False, True, False], cluster=[1, 1, 2, 2])
    assert flat.estimate == 0 and np.isnan(flat.ci_low) and np.isnan(flat.p)  # no zero-width interval
    with pytest.raises(ConfigError, match="finite"):
        compare_by_cluster([np.nan, 0.0], arm=[True, False], cluster=[1, 1])


@pytest.mark.slow
@pytest.mark.parametrize("clusters", CLUSTER_COUNTS)
def test_the_cluster_level_tests_hold_their_level_where_the_case_level_test_does_not(clusters):
    rng = np.random.default_rng(20261128 + clusters)
    scores = _study(rng, clusters=clusters, interaction=0.35)  # H0: the arms have one distribution
    means = scores.mean(axis=-1)
    d = means[:, :, 0] - means[:, :, 1]                       # (sims, clusters)
    x, arm, cluster = _arms(scores[0])
    res = compare_by_cluster(x, arm=arm, cluster=cluster)     # the unit under test on one study ...
    assert res.p == pytest.approx(stats.ttest_1samp(d[0], 0).pvalue, rel=1e-10)
    t_level = np.mean(stats.ttest_1samp(d, 0, axis=1).pvalue <= ALPHA)  # ... and its test on all of them
    exact_level = np.mean(sign_flip_pvalues(d, alternative="two-sided") <= ALPHA)
    assert abs(t_level - ALPHA) <= 0.02, t_level
    assert abs(exact_level - ALPHA) <= 0.02, exact_level
    # the case as the unit (Welch over the pooled cases) ignores the runs' suites and rejects too often
    a = scores[:, :, 0].reshape(SIMULATIONS, -1)
    b = scores[:, :, 1].reshape(SIMULATIONS, -1)
    case_level = np.mean(stats.ttest_ind(a, b, axis=1, equal_var=False).pvalue <= ALPHA)
    assert case_level > ALPHA + 0.02, case_level


@pytest.mark.slow
@pytest.mark.parametrize("clusters", CLUSTER_COUNTS)
def test_the_cluster_level_interval_covers_a_true_difference_at_its_level(clusters):
    rng = np.random.default_rng(7 + clusters)
    scores = _study(rng, clusters=clusters, shift=0.25, interaction=0.35)
    # the true difference of the arms' expected scores, from a large simulation of the same model
    big = _study(np.random.default_rng(1), clusters=400, shift=0.25, interaction=0.35, sims=50).mean(axis=-1)
    truth = float((big[:, :, 0] - big[:, :, 1]).mean())
    means = scores.mean(axis=-1)
    ci = stats.ttest_1samp(means[:, :, 0] - means[:, :, 1], 0, axis=1).confidence_interval(1 - ALPHA)
    coverage = np.mean((ci.low <= truth) & (truth <= ci.high))
    assert abs(coverage - (1 - ALPHA)) <= 0.02, coverage


def test_the_planned_clusters_are_statsmodels_one_sample_t_power():
    n = clusters_for_difference(0.0175, sd=0.0181, alpha=0.025)
    power = TTestPower().power
    assert power(0.0175 / 0.0181, n, 0.025) >= 0.8 > power(0.0175 / 0.0181, n - 1, 0.025)
    assert clusters_for_difference(10.0, sd=1.0) == 2
    with pytest.raises(ConfigError):
        clusters_for_difference(0.0, sd=1.0)


@pytest.mark.slow
def test_the_equivalence_power_agrees_with_simulated_two_one_sided_tests():
    rng = np.random.default_rng(5)
    clusters, margin, diff, sd = 8, 0.02, 0.005, 0.02
    d = rng.normal(diff, sd, size=(20000, clusters))
    lower = stats.ttest_1samp(d, -margin, axis=1, alternative="greater").pvalue
    upper = stats.ttest_1samp(d, margin, axis=1, alternative="less").pvalue
    simulated = np.mean(np.maximum(lower, upper) <= ALPHA)
    assert equivalence_power(clusters, margin=margin, difference=diff, sd=sd) == pytest.approx(simulated, abs=0.02)
