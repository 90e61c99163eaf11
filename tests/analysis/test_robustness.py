"""The robustness analysis against planted effects and textbook formulas."""

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from faultlab.analysis.robustness import FLOOR_MM, case_log_ratios, degradation, parameter_effects, rep_log_ratios
from faultlab.vocabulary import BASELINE


def _results(ratio_of_case, *, n_cases=8, k=5, seed=0, noise=0.0):
    """Synthetic store rows: faulty = baseline * ratio_of_case(c, x_c) * exp(noise), same rep pairs."""
    rng = np.random.default_rng(seed)
    rows = []
    for c in range(1, n_cases + 1):
        x = float(c)  # a Table I value that grows with the case
        for rep in range(k):
            base = float(rng.uniform(50, 500))
            faulty = base * ratio_of_case(c, x) * math.exp(rng.normal(0, noise)) if noise else base * ratio_of_case(c, x)
            for variant, value in ((BASELINE, base), ("obs_delay", faulty)):
                rows.append(dict(run=1, suite="random", case=c, variant=variant, rep=rep, status="ok",
                                 rms_mm=value, emd_mm=value, map_size=x, step_size=7.0))
    return pd.DataFrame(rows)


def test_a_constant_planted_ratio_is_recovered_in_every_case():
    res = _results(lambda c, x: 2.0)
    cases = case_log_ratios(res)
    np.testing.assert_allclose(cases["log_ratio"], math.log(2.0))
    assert (cases["n_pairs"] == 5).all()
    np.testing.assert_allclose(rep_log_ratios(res)["log_ratio"], math.log(2.0))


def test_a_failed_job_drops_only_its_pair():
    res = _results(lambda c, x: 2.0)
    i = res.index[(res["variant"] == "obs_delay") & (res["case"] == 3) & (res["rep"] == 1)][0]
    res.loc[i, ["status", "rms_mm"]] = ["crash", np.nan]
    cases = case_log_ratios(res).set_index("case")
    assert cases.loc[3, "n_pairs"] == 4 and cases.loc[2, "n_pairs"] == 5


def test_degradation_is_the_geometric_mean_with_the_textbook_t_interval():
    x = np.log([1.2, 1.9, 1.4, 2.6, 0.9, 1.7])
    ratio, low, high = degradation(x, alpha=0.1)
    m, s, n = x.mean(), x.std(ddof=1), x.size
    half = stats.t.ppf(0.95, n - 1) * s / math.sqrt(n)
    assert ratio == pytest.approx(math.exp(m))
    assert (low, high) == pytest.approx((math.exp(m - half), math.exp(m + half)))
    assert math.isnan(degradation(x[:1])[1])  # one case: no interval, never a zero-width one


def test_parameter_effects_recover_a_planted_slope():
    b = 0.3  # log ratio grows by b per case, x_c = c
    res = _results(lambda c, x: math.exp(0.1 + b * x), n_cases=10, noise=0.05, seed=3)
    effects = parameter_effects(rep_log_ratios(res)).set_index("parameter")
    sd = np.std(np.repeat(np.arange(1, 11), 5).astype(float))
    row = effects.loc["map_size"]
    assert row["low"] < b * sd < row["high"]  # slope per standard deviation of the parameter
    # a permutation test over the 10 cases (9999 random orderings): a perfect ordering gets the smallest p it can
    assert row["p"] == pytest.approx(2 / 10000) and row["p_min"] == pytest.approx(2 / 10000) and row["n_cases"] == 10
    assert math.isnan(effects.loc["step_size", "slope"])  # constant over the cases: no slope
    assert math.isnan(effects.loc["inactivity", "slope"])  # absent


def test_parameter_effects_on_four_cases_give_the_exact_permutation_p_never_zero():
    """Four clusters: the cluster-robust z test's p was ~0; over the 4! orderings of the cases the planted,
    perfectly ordered slope is the most extreme of 2 (itself and its mirror), so p = 2/24 exactly."""
    res = _results(lambda c, x: math.exp(0.3 * x), n_cases=4, noise=0.001, seed=1)
    row = parameter_effects(rep_log_ratios(res), rng=np.random.default_rng(0)).set_index("parameter").loc["map_size"]
    assert row["p"] == pytest.approx(2 / 24) and row["p_min"] == pytest.approx(2 / 24)
    assert row["low"] < row["slope"] < row["high"]
    # the same ordering found by brute force over the permutations of the case values
    import itertools
    cases = case_log_ratios(res)
    y = cases.groupby("case")["log_ratio"].mean().to_numpy()
    x = np.arange(1.0, 5.0)
    slope = lambda xs: np.polyfit(xs, y, 1)[0]
    observed = abs(slope(x))
    p = np.mean([abs(slope(np.array(perm))) >= observed - 1e-12 for perm in itertools.permutations(x)])
    assert row["p"] == pytest.approx(p)


def test_parameter_effects_need_three_cases():
    res = _results(lambda c, x: math.exp(x), n_cases=2)
    assert parameter_effects(rep_log_ratios(res))["slope"].isna().all()


def test_errors_below_the_floor_count_as_the_floor():
    res = _results(lambda c, x: 2.0, n_cases=3)
    base = res["variant"] == BASELINE
    res.loc[base & (res["case"] == 1), "rms_mm"] = 1e-13
    res.loc[~base & (res["case"] == 1), "rms_mm"] = 50.0
    cases = case_log_ratios(res).set_index("case")
    assert cases.loc[1, "log_ratio"] == pytest.approx(math.log(50.0 / FLOOR_MM))
    assert cases.loc[2, "log_ratio"] == pytest.approx(math.log(2.0))
