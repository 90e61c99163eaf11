"""Comparisons of two arms whose cases are nested in clusters (evaluation runs), analysed at the cluster level.

A strategies study draws, in every evaluation run, one suite of each strategy; the cases of a
suite are not independent draws (a systematic suite covers every class once, a covering array is
balanced), and every run shares its seeds' stream.  The independent unit is therefore the run.
Two strategies are compared *paired by run*: each run ``r`` contributes the difference
``d_r = mean(a's cases in r) - mean(b's cases in r)`` of its two suites' mean scores, and the
``R`` differences are the sample:

* the estimate is ``mean(d_r)``;
* the test is the one-sample t test of the ``d_r`` (scipy ``ttest_1samp``), with its interval at
  ``1 - alpha``; a mean of a suite's cases is close to normal, and the t test over cluster
  summaries holds its level at a handful of clusters (the simulations in
  ``tests/inference/test_clusters.py`` check it at the cluster counts the studies use);
* the exact sign-flip test over runs (:func:`faultlab.inference.exact.sign_flip_pvalues`, ``2^R``
  sign patterns, for ``R <= MAX_EXACT_PAIRS``) is reported beside it: exact whenever the ``d_r``
  are symmetric about 0 under the null hypothesis, which holds when the two strategies' suites of
  one run are exchangeable;
* equivalence within a declared ``margin`` is two one-sided t tests at ``alpha`` (the
  ``1 - 2 alpha`` interval inside ``(-margin, margin)``); statsmodels ``ttost_paired`` is the
  reference.

:func:`clusters_for_difference` and :func:`equivalence_power` plan the number of runs from the
run-level standard deviation of an earlier study.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import stats
from statsmodels.stats.power import TTestPower

from faultlab.errors import ConfigError
from faultlab.inference.exact import MAX_EXACT_PAIRS, check_alpha, check_alternative, sign_flip_pvalues
from faultlab.vocabulary import DEFAULT_ALPHA, DEFAULT_POWER

#: Relative spread of the cluster differences below which they are taken as equal (rounding of the means).
_SPREAD_TOLERANCE = 1e-12

__all__ = ["ClusterComparison", "cluster_differences", "compare_by_cluster", "clusters_for_difference",
           "equivalence_power"]


@dataclass(frozen=True)
class ClusterComparison:
    """Two arms compared paired by cluster (:func:`compare_by_cluster`).

    Attributes
    ----------
    clusters : int
        Clusters holding cases of both arms (the sample size).
    estimate : float
        Mean over clusters of the difference of the arms' cluster means (a - b).
    ci_low, ci_high : float
        t interval at ``1 - alpha`` (NaN with fewer than 2 clusters or no spread).
    p : float
        t test of no difference, with the given sidedness (NaN where the interval is).
    p_exact : float
        Exact sign-flip p value over the clusters (NaN above ``MAX_EXACT_PAIRS`` clusters).
    sd : float
        Standard deviation of the cluster differences (ddof 1).
    p_equivalence : float
        Two one-sided t tests of ``|difference| >= margin`` (the larger of the two p values; NaN
        without a margin or where the interval is NaN).
    margin : float
        The margin tested (NaN without one).
    """

    clusters: int
    estimate: float
    ci_low: float
    ci_high: float
    p: float
    p_exact: float
    sd: float
    p_equivalence: float = math.nan
    margin: float = math.nan


def cluster_differences(x, *, arm, cluster) -> tuple[np.ndarray, np.ndarray]:
    """Per cluster holding both arms: ``(cluster labels, mean of arm True - mean of arm False)``.

    Parameters
    ----------
    x : array_like, shape (n,)
        One score per case (finite).
    arm : array_like of bool, shape (n,)
        True for arm a, False for arm b.
    cluster : array_like, shape (n,)
        The case's cluster (evaluation run).
    """
    x = np.asarray(x, dtype=float)
    arm = np.asarray(arm, dtype=bool)
    cluster = np.asarray(cluster)
    if not (x.shape == arm.shape == cluster.shape) or x.ndim != 1:
        raise ConfigError(f"cluster_differences: x, arm and cluster must be 1-d of one length, got "
                          f"{x.shape}, {arm.shape}, {cluster.shape}")
    if not np.all(np.isfinite(x)):
        raise ConfigError("cluster_differences: scores must be finite")
    labels, idx = np.unique(cluster, return_inverse=True)
    k = labels.size
    n_a = np.bincount(idx[arm], minlength=k)
    n_b = np.bincount(idx[~arm], minlength=k)
    s_a = np.bincount(idx[arm], weights=x[arm], minlength=k)
    s_b = np.bincount(idx[~arm], weights=x[~arm], minlength=k)
    both = (n_a > 0) & (n_b > 0)
    return labels[both], s_a[both] / n_a[both] - s_b[both] / n_b[both]


def compare_by_cluster(x, *, arm, cluster, alpha: float = DEFAULT_ALPHA, alternative: str = "two-sided",
                       margin: float | None = None) -> ClusterComparison:
    """Arm a against arm b, paired by cluster: t test and interval over the cluster differences,
    the exact sign-flip p value over clusters, and (with ``margin``) two one-sided tests.

    See the module docstring for the model; ``alternative`` is SciPy's (``"greater"``: a > b).
    """
    check_alpha(alpha, "compare_by_cluster")
    check_alternative(alternative, "compare_by_cluster")
    _, d = cluster_differences(x, arm=arm, cluster=cluster)
    r = d.size
    nan = math.nan
    est = float(d.mean()) if r else nan
    sd = float(d.std(ddof=1)) if r > 1 else nan
    p_exact = float(sign_flip_pvalues(d, alternative=alternative)) if 1 <= r <= MAX_EXACT_PAIRS else nan
    if r < 2 or not sd > _SPREAD_TOLERANCE * max(1.0, float(np.abs(d).max())):  # no spread beyond rounding
        return ClusterComparison(clusters=r, estimate=est, ci_low=nan, ci_high=nan, p=nan, p_exact=p_exact, sd=sd,
                                 margin=nan if margin is None else float(margin))
    res = stats.ttest_1samp(d, 0.0, alternative=alternative)
    ci = stats.ttest_1samp(d, 0.0).confidence_interval(1 - alpha)
    p_eq = nan
    if margin is not None:
        if not margin > 0:
            raise ConfigError(f"compare_by_cluster: margin must be positive, got {margin!r}")
        lower = stats.ttest_1samp(d, -margin, alternative="greater").pvalue
        upper = stats.ttest_1samp(d, margin, alternative="less").pvalue
        p_eq = float(max(lower, upper))
    return ClusterComparison(clusters=r, estimate=est, ci_low=float(ci.low), ci_high=float(ci.high),
                             p=float(res.pvalue), p_exact=p_exact, sd=sd, p_equivalence=p_eq,
                             margin=nan if margin is None else float(margin))


def clusters_for_difference(difference: float, *, sd: float, alpha: float = DEFAULT_ALPHA,
                            power: float = DEFAULT_POWER, alternative: str = "two-sided") -> int:
    """Smallest number of clusters at which the t test over cluster differences detects ``difference``
    with ``power`` (statsmodels ``TTestPower``, effect size ``difference / sd``), at least 2."""
    check_alpha(alpha, "clusters_for_difference")
    if not (difference != 0 and sd > 0 and 0 < power < 1):
        raise ConfigError(f"clusters_for_difference: needs a non-zero difference, sd > 0 and power in (0, 1), "
                          f"got {difference!r}, {sd!r}, {power!r}")
    alt = {"two-sided": "two-sided", "greater": "larger", "less": "smaller"}[check_alternative(alternative,
                                                                                                 "clusters_for_difference")]
    n = TTestPower().solve_power(effect_size=difference / sd, alpha=alpha, power=power, alternative=alt)
    return max(2, math.ceil(n - 1e-9))


def equivalence_power(clusters: int, *, margin: float, difference: float, sd: float,
                      alpha: float = DEFAULT_ALPHA) -> float:
    """Power of two one-sided t tests at ``alpha`` to show ``|mean difference| < margin`` over
    ``clusters`` cluster differences of standard deviation ``sd`` when the true difference is
    ``difference``.

    The usual approximation that treats the two one-sided tests as independent of the estimated
    standard deviation: ``P(T1 > t) + P(T2 > t) - 1`` with ``T1``, ``T2`` noncentral t (``clusters
    - 1`` degrees of freedom, noncentralities ``(margin -+ difference) / se``), at least 0.
    """
    check_alpha(alpha, "equivalence_power")
    if not (clusters >= 2 and margin > 0 and sd > 0):
        raise ConfigError(f"equivalence_power: needs clusters >= 2, margin > 0 and sd > 0, got {clusters!r}, "
                          f"{margin!r}, {sd!r}")
    df = clusters - 1
    se = sd / math.sqrt(clusters)
    t = stats.t.ppf(1 - alpha, df)
    upper = stats.nct.sf(t, df, (margin - difference) / se)
    lower = stats.nct.sf(t, df, (margin + difference) / se)
    return float(max(0.0, upper + lower - 1))
