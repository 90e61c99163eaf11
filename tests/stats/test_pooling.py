"""Suite-level pooling: the pooled sign-flip test, the combination with the per-case minimum, planted effects."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from faultlab.errors import ConfigError
from faultlab.stats.pooling import case_log_ratio_means, pooled_pvalues, pooling_power, suite_decisions
from faultlab.inference.exact import sign_flip_pvalues


def _brute_two_sided(x) -> float:
    signs = np.array(list(itertools.product((1, -1), repeat=len(x))))
    sums = signs @ np.asarray(x)
    s = float(np.sum(x))
    return min(1.0, 2 * min(np.mean(sums >= s - 1e-12), np.mean(sums <= s + 1e-12)))


def test_pooled_p_is_the_exact_sign_flip_test_over_case_means():
    rng = np.random.default_rng(0)
    means = rng.normal(0.2, 1.0, (5, 8))
    p, se = pooled_pvalues(means)
    assert se == 0.0
    for row, pv in zip(means, p):
        assert pv == pytest.approx(_brute_two_sided(row), abs=1e-12)


def test_beyond_the_enumerable_cases_a_seeded_monte_carlo_states_its_error():
    x = np.r_[np.full(11, 0.5), np.full(10, -0.1)]  # 21 cases
    with pytest.raises(ConfigError, match="rng"):
        pooled_pvalues(x)
    p1, se = pooled_pvalues(x, rng=np.random.default_rng(3), resamples=20000)
    p2, _ = pooled_pvalues(x, rng=np.random.default_rng(3), resamples=20000)
    assert p1 == p2 and se > 0
    # exact value by meet in the middle: all 2^10 x 2^11 sign patterns of the two halves
    a = np.array(list(itertools.product((1, -1), repeat=10))) @ x[:10]
    b = np.sort(np.array(list(itertools.product((1, -1), repeat=11))) @ x[10:])
    s = x.sum()
    ge = sum(b.size - np.searchsorted(b, s - v - 1e-12) for v in a)
    le = sum(np.searchsorted(b, s - v + 1e-12, side="right") for v in a)
    exact = min(1.0, 2 * min(ge, le) / 2 ** 21)
    assert abs(p1[0] - exact) <= 4 * se + 1e-4


def test_case_log_ratio_means_skip_unusable_pairs():
    f = np.array([[2.0, 4.0, np.nan], [1.0, 1.0, 1.0]])
    b = np.array([[1.0, 2.0, 1.0], [1.0, np.nan, 1.0]])
    np.testing.assert_allclose(case_log_ratio_means(f, b), [np.log(2.0), 0.0])
    assert np.isnan(case_log_ratio_means([[np.nan]], [[1.0]])[0])


def test_the_combination_splits_alpha_between_the_two_tests():
    n, alpha = 4, 0.05
    at = alpha / 2 / n
    p = np.array([[at, 1, 1, 1], [at * 1.01, 1, 1, 1], [1, 1, 1, 1], [1, 1, 1, 1]])
    pooled = np.array([1.0, 1.0, alpha / 2, alpha / 2 * 1.01])
    d = suite_decisions(p, pooled, np.zeros_like(p, bool), alpha=alpha)
    assert d["detected"].tolist() == [True, False, True, False]
    assert d["by_case"].tolist() == [True, False, False, False] and d["by_pool"].tolist() == [False, False, True, False]
    alone = suite_decisions(p, pooled, np.zeros_like(p, bool), alpha=alpha, combination="min")
    assert alone["detected"].tolist() == [True, True, False, False]
    crash = np.zeros_like(p, bool)
    crash[2, 1] = True
    assert suite_decisions(p, np.ones(4), crash, alpha=alpha)["detected"].tolist() == [True, False, True, False]


def _suite(shifts, k=11, seed=0):
    """Baseline errors of a few hundred mm and a faulty error multiplied by exp(shift + noise), per case."""
    rng = np.random.default_rng(seed)
    base = rng.uniform(50.0, 5000.0, (len(shifts), 1)) * np.exp(rng.normal(0, 0.05, (len(shifts), k)))
    faulty = base * np.exp(np.asarray(shifts)[:, None] + rng.normal(0.0, 1.0, (len(shifts), k)))
    lr = np.log(faulty / base)
    return sign_flip_pvalues(lr, alternative="two-sided"), case_log_ratio_means(faulty, base)


def test_a_planted_diffuse_effect_is_detected_by_the_pooled_test_not_by_the_per_case_minimum():
    p, means = _suite(np.full(12, 0.6), seed=1)
    pooled, _ = pooled_pvalues(means[None, :])
    d = suite_decisions(p[None, :], pooled, np.zeros((1, 12), bool)).iloc[0]
    assert d["detected"] and d["by_pool"] and not d["by_case"]


def test_a_planted_concentrated_effect_is_detected_by_the_per_case_minimum_not_by_the_pooled_test():
    p, means = _suite(np.r_[4.0, np.zeros(11)], seed=2)
    pooled, _ = pooled_pvalues(means[None, :])
    d = suite_decisions(p[None, :], pooled, np.zeros((1, 12), bool)).iloc[0]
    assert d["detected"] and d["by_case"] and not d["by_pool"]


def test_power_simulation_keeps_the_level_and_each_test_wins_on_its_own_kind_of_effect():
    # 8 cases: the pooled test's floor 2^-7 is below alpha / 2 (with 5 cases, 2^-4 > 0.05, it never rejects)
    sim = pooling_power(n_cases=8, k=10, draws=400, diffuse=(0.4,), concentrated=(2.5,)).set_index(
        ["effect", "combination"])["power"]
    for c in ("both", "min", "pooled"):  # family-wise false alarms at most alpha (+ 3 Monte Carlo SE)
        assert sim[("null", c)] <= 0.05 + 3 * np.sqrt(0.05 * 0.95 / 400)
    assert sim[("diffuse", "pooled")] > sim[("diffuse", "both")] > sim[("diffuse", "min")]
    assert sim[("concentrated", "min")] > sim[("concentrated", "both")] > sim[("concentrated", "pooled")]
    assert pooling_power(n_cases=5, k=9, draws=50, diffuse=(2.0,), concentrated=()).set_index(
        ["effect", "combination"])["power"][("diffuse", "pooled")] == 0.0


def _runner_results(errors: dict, k: int = 11, n: int = 12, seed: int = 3):
    """Runner-shaped results of one suite run: ``errors[fault](case, baseline) -> faulty errors or "crash"``."""
    import pandas as pd

    rng = np.random.default_rng(seed)
    rows = []
    for case in range(n):
        base = 1000.0 + 200.0 * rng.random(k)
        rows += [dict(run=1, suite="random", case=case, rep=r, variant="baseline", status="ok", rms_mm=base[r],
                      emd_mm=1.0, runtime_s=0.1) for r in range(k)]
        for fault, f in errors.items():
            e = f(case, base)
            rows += [dict(run=1, suite="random", case=case, rep=r, variant=fault,
                          status="crash" if isinstance(e, str) else "ok",
                          rms_mm=np.nan if isinstance(e, str) else e[r], emd_mm=1.0, runtime_s=0.1) for r in range(k)]
    return pd.DataFrame(rows)


def test_suite_verdicts_pool_a_diffuse_effect_and_keep_a_concentrated_one_and_a_crash():
    from faultlab.stats.pooling import suite_verdicts

    noise = np.random.default_rng(9)
    diffuse_factors = np.exp(noise.normal(0.12, 0.3, (12, 11)))   # every case ~13 % worse, noisy
    res = _runner_results({
        "diffuse": lambda c, b: b * diffuse_factors[c],
        "concentrated": lambda c, b: b * (1.5 if c == 0 else 1.0),
        "crashes": lambda c, b: "crash" if c == 5 else b,
    })
    table = suite_verdicts(res).set_index("fault")
    # independent reference: the textbook two-sided sign-flip p over the case means of log(faulty / baseline)
    base = res[res["variant"] == "baseline"].sort_values(["case", "rep"])["rms_mm"].to_numpy().reshape(12, 11)
    means = np.log(diffuse_factors).mean(axis=1)
    assert np.allclose(np.log(res[res["variant"] == "diffuse"].sort_values(["case", "rep"])["rms_mm"].to_numpy()
                              .reshape(12, 11) / base).mean(axis=1), means)
    assert table.loc["diffuse", "pooled_p"] == pytest.approx(_brute_two_sided(means))
    assert table.loc["diffuse", "pooled_p"] <= 0.025 and table.loc["diffuse", "min_p"] > 0.05 / 12
    assert table.loc["diffuse", "detected_combined"] and not table.loc["diffuse", "detected_min"]
    # one case 50 % worse in all 11 repetitions: p = 2^-10 <= 0.025 / 12; the other 11 cases have mean 0
    assert table.loc["concentrated", "min_p"] == pytest.approx(2.0 ** -10)
    assert table.loc["concentrated", "detected_min"] and table.loc["concentrated", "by_case"]
    assert not table.loc["concentrated", "by_pool"]
    assert table.loc["crashes", "n_crashed"] == 1 and table.loc["crashes", "n_tested"] == 11
    assert table.loc["crashes", "detected_min"] and table.loc["crashes", "detected_combined"]
    assert not table.loc["crashes", "by_case"] and not table.loc["crashes", "by_pool"]
