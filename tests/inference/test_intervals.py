"""Intervals (faultlab.inference.intervals): bootstrap medians against a resample-by-resample transcription,
Clopper-Pearson against scipy and the beta quantiles, clustered rates against the formula written out."""

import numpy as np
import pandas as pd
import pytest
from scipy.stats import norm, t
from statsmodels.stats.proportion import proportion_confint

from faultlab.errors import ConfigError
from faultlab.inference.intervals import bootstrap_medians, clustered_rate


@pytest.mark.parametrize("n", [1, 2, 7])
def test_bootstrap_medians_are_the_medians_of_the_resamples_drawn(n):
    x = np.random.default_rng(5).lognormal(size=n)
    got = bootstrap_medians(x, replicates=50, rng=np.random.default_rng(11))
    draws = np.random.default_rng(11).integers(0, n, size=(50, n))
    expected = [float(np.median([x[i] for i in row])) for row in draws]
    np.testing.assert_array_equal(got, expected)
    assert got.min() >= x.min() and got.max() <= x.max()


def test_clopper_pearson_is_scipys_exact_interval_and_the_beta_quantiles():
    from scipy.stats import beta, binomtest

    from faultlab.inference.intervals import clopper_pearson

    ks, ns = np.array([0, 1, 3, 9, 10, 57, 150]), np.array([9, 9, 10, 9, 200, 150, 150])
    low, high = clopper_pearson(ks, ns)  # vectorised
    for k, n, lo, hi in zip(ks, ns, low, high):
        # scipy solves for the bounds numerically (to about 1e-12): equal at the tables' 10 digits
        ci = binomtest(int(k), int(n)).proportion_ci(confidence_level=0.95, method="exact")
        assert lo == pytest.approx(ci.low, rel=1e-10, abs=1e-15) and hi == pytest.approx(ci.high, rel=1e-10, abs=1e-15)
        # the textbook transcription
        assert lo == pytest.approx(0.0 if k == 0 else beta.ppf(0.025, k, n - k + 1), abs=1e-12)
        assert hi == pytest.approx(1.0 if k == n else beta.ppf(0.975, k + 1, n - k), abs=1e-12)
        assert hi > lo  # never zero-width from a finite sample
        assert clopper_pearson(int(k), int(n)) == (lo, hi)  # scalars in, the same floats out
    assert all(np.isnan(clopper_pearson(0, 0)))
    lo90, hi90 = clopper_pearson(3, 10, alpha=0.1)
    assert lo90 > low[2] and hi90 < high[2]  # a lower confidence level gives a narrower interval


def test_clopper_pearson_refuses_a_level_outside_0_1():
    from faultlab.errors import ConfigError
    from faultlab.inference.intervals import clopper_pearson

    with pytest.raises(ConfigError, match="clopper_pearson: alpha must lie in"):
        clopper_pearson(1, 2, alpha=1.5)


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
