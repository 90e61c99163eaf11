"""Repetitions against cases at a fixed budget, on planted pools whose answer is known analytically."""

import numpy as np
import pandas as pd
import pytest
from scipy.stats import binomtest, hypergeom

from faultlab.analysis.allocation import allocation_study, allocation_summary, allocations, suite_pooled_pvalues
from faultlab.errors import ConfigError
from faultlab.inference.exact import sign_flip_pvalues

POOL, K, AFFECTED = 18, 12, 4


def _results(variants: dict, *, k: int = K, n: int = POOL, seed: int = 0) -> pd.DataFrame:
    """Runner-shaped results of one random pool; ``variants[name](case, baseline errors) -> variant errors``."""
    rng = np.random.default_rng(seed)
    rows = []
    for case in range(n):
        base = 1000.0 + 100.0 * rng.random(k)
        for variant, f in {"baseline": lambda c, b: b, **variants}.items():
            errors = f(case, base)
            rows += [dict(run=1, suite="random", case=case, rep=r, variant=variant, status="ok", rms_mm=errors[r],
                          emd_mm=1.0, runtime_s=0.1) for r in range(k)]
    return pd.DataFrame(rows)


# concentrated: the map error doubles in every repetition of 4 of the 18 cases, nothing changes elsewhere;
# diffuse: +5 % in every repetition of every case
PLANTED = {"concentrated": lambda c, b: b * (2.0 if c < AFFECTED else 1.0), "diffuse": lambda c, b: b * 1.05}


@pytest.fixture(scope="module")
def table():
    return allocation_study(_results(PLANTED), budget=72, ks=[6, 9, 12], draws=1000, seed=3)


def test_allocations_keep_the_budget_and_refuse_what_it_cannot_buy():
    assert allocations(72, [12, 6, 9], 18) == [(6, 12), (9, 8), (12, 6)]
    with pytest.raises(ConfigError, match="does not divide"):
        allocations(72, [7], 18)
    with pytest.raises(ConfigError, match="more than the pool"):
        allocations(72, [3], 18)


def test_concentrated_effect_follows_the_hypergeometric_law_where_a_case_can_reject(table):
    rows = table[table["variant"] == "concentrated"].set_index("k")
    # K = 6 (n = 12): the smallest two-sided p, 2^-5, is above 0.05 / 12 -- no case can reject
    assert not rows.loc[6, "reachable"] and rows.loc[6, "rate_by_case"] == 0.0
    for k, n in ((9, 8), (12, 6)):   # 2^-8 <= 0.05 / 8 and 2^-11 <= 0.05 / 6: the 4 doubled cases are strong
        assert rows.loc[k, "reachable"] and rows.loc[k, "strong_cases"] == AFFECTED
        expected = hypergeom(POOL, AFFECTED, n).sf(0)
        assert rows.loc[k, "rate_by_case_exact"] == pytest.approx(expected)
        assert abs(rows.loc[k, "rate_by_case"] - expected) < 4 * np.sqrt(expected * (1 - expected) / 1000)
        ci = binomtest(AFFECTED, POOL).proportion_ci(method="exact")
        assert (rows.loc[k, "case_low"], rows.loc[k, "case_high"]) == pytest.approx((ci.low, ci.high))
    # more cases at K = 9 beat more repetitions at K = 12 for a concentrated effect (analytic)
    assert rows.loc[9, "rate_by_case_exact"] > rows.loc[12, "rate_by_case_exact"]


def test_diffuse_effect_is_pooled_only_from_enough_cases(table):
    rows = table[table["variant"] == "diffuse"].set_index("k")
    # every case mean is positive: the pooled two-sided p of n cases is 2^-(n-1)
    assert rows.loc[6, "rate_by_pool"] == 1.0 and rows.loc[6, "rate_combined"] == 1.0   # 2^-11 <= 0.025
    assert rows.loc[12, "rate_by_pool"] == 1.0                                           # 2^-5 <= 0.05
    # combined at K = 9, n = 8: the per-case level 0.025 / 8 is below 2^-8, the pooled 2^-7 is below 0.025
    assert rows.loc[9, "rate_combined"] == 1.0
    assert rows.loc[6, "rate_by_case"] == 0.0   # no single case can show it at K = 6


def test_summary_shows_a_difference_only_when_the_exact_intervals_are_disjoint(table):
    summary = allocation_summary(table).set_index("variant")
    diffuse = table[(table["variant"] == "diffuse")].set_index("k")
    assert summary.loc["diffuse", "best_k"] in (9, 12) and summary.loc["diffuse", "worst_k"] == 6
    disjoint = diffuse.loc[summary.loc["diffuse", "best_k"], "by_case_low"] > diffuse.loc[6, "by_case_high"]
    assert (summary.loc["diffuse", "answer"] != "not shown") == disjoint
    assert summary.loc["concentrated", "answer"] == "not shown"   # 4 of 18 cases: intervals overlap


def test_suite_pooled_pvalues_leave_out_untested_cases():
    rng = np.random.default_rng(0)
    means = rng.normal(size=(5, 6))
    tested = np.ones((5, 6), bool)
    tested[2, 3] = False
    tested[4] = False
    p = suite_pooled_pvalues(means, tested, rng=rng)
    for i in (0, 1, 3):
        assert p[i] == pytest.approx(float(sign_flip_pvalues(means[i], alternative="two-sided")))
    assert p[2] == pytest.approx(float(sign_flip_pvalues(np.delete(means[2], 3), alternative="two-sided")))
    assert np.isnan(p[4])


def test_subsampled_repetitions_are_the_first_k():
    res = _results(PLANTED)
    full = allocation_study(res, budget=36, ks=[12], draws=50, seed=1)
    # rewriting repetitions 9-11 changes nothing judged on the first 9
    changed = res.copy()
    late = (changed["variant"] == "concentrated") & (changed["rep"] >= 9)
    changed.loc[late, "rms_mm"] = 1.0
    a = allocation_study(res, budget=36, ks=[9], draws=50, seed=1)
    b = allocation_study(changed, budget=36, ks=[9], draws=50, seed=1)
    pd.testing.assert_frame_equal(a, b)
    assert not full.empty
