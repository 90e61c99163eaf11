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


# --------------------------------------------------------------------------- verdicts that can be reached


def _protocol(factor, *, runs=3, k=10, noise=0.3, seed=11, deterministic=False):
    """Runner-shaped results of the paper's protocol (``runs`` x three 5-case suites, K repetitions) with one
    planted fault that multiplies the error by ``factor(run, suite, case, rep)`` -- a user's "fault"
    whose effect we know; the baseline varies over repetitions unless ``deterministic``."""
    import pandas as pd

    rng = np.random.default_rng(seed)
    rows = []
    for run in range(1, runs + 1):
        for suite in ("systematic", "random", "fixed"):
            for case in range(1, 6):
                level = 500.0 * np.exp(rng.normal(0, 0.5))
                base = (np.full(k, level) if deterministic else level * np.exp(rng.normal(0, noise, k)))
                rows += [dict(run=run, suite=suite, case=case, rep=r, variant="baseline", status="ok",
                              rms_mm=base[r], emd_mm=1.0, runtime_s=0.1) for r in range(k)]
                faulty = base * np.array([factor(run, suite, case, r) for r in range(k)])
                rows += [dict(run=run, suite=suite, case=case, rep=r, variant="user/fault", status="ok",
                              rms_mm=faulty[r], emd_mm=1.0, runtime_s=0.1) for r in range(k)]
    return pd.DataFrame(rows)


def test_a_suite_of_five_cases_pooled_cannot_judge_and_says_so():
    """Five cases: the pooled two-sided sign-flip test reaches at best 2^-4 = 0.0625 > alpha / 2 -- its
    verdict is "cannot judge" with that floor, never "not detected"; six cases still cannot (0.03125)."""
    from faultlab.stats.pooling import suite_verdicts

    res = _protocol(lambda *a: 1.0, runs=1)
    table = suite_verdicts(res)
    assert len(table) == 3 and (table["n_tested"] == 5).all()
    assert (table["pooled_p_min"] == 2.0 ** -4).all() and (table["pooled_verdict"] == "cannot_judge").all()
    # the per-case route (K = 10: 2^-9 <= 0.05 / 10) can still reach its level, so the combined verdict is judged
    assert (table["case_p_min"] == 2.0 ** -9).all() and (table["verdict"] == "not_detected").all()
    few = suite_verdicts(_protocol(lambda *a: 1.0, runs=1, k=6))  # K = 6: 2^-5 > 0.05 / 10 per case
    assert (few["verdict"] == "cannot_judge").all() and (few["pooled_verdict"] == "cannot_judge").all()


def test_a_deterministic_suite_detects_by_the_exact_difference():
    from faultlab.stats.pooling import suite_verdicts

    res = _protocol(lambda run, suite, case, rep: 1.0 if case != 3 else 1.01, runs=1, deterministic=True)
    table = suite_verdicts(res)
    assert (table["n_exact"] == 5).all() and table["min_p"].isna().all()
    assert table["detected_min"].all() and table["detected_combined"].all() and (table["verdict"] == "detected").all()


def _brute_interval(x, alpha=0.05):
    """Hartigan's subset-mean bounds by brute force: m-th smallest / largest of every non-empty subset mean."""
    n = len(x)
    means = sorted(np.mean([x[i] for i in range(n) if mask >> i & 1]) for mask in range(1, 2 ** n))
    m = int(alpha / 2 * 2 ** n)
    return means[m - 1], means[-m]


def test_a_planted_fifteen_percent_improvement_is_a_campaign_level_change_no_suite_can_show():
    """The paper's protocol (3 runs x three 5-case suites, K = 10) with a fault that lowers the error by
    15 % on every case, noisily per repetition: no 5-case suite can show it pooled (each says cannot
    judge), the campaign-level verdict over the 45 cases shows it as a change, direction better, with
    its factor and interval, the test, sidedness, level and family named."""
    from faultlab.stats.pooling import campaign_verdicts, suite_verdicts

    noise = np.random.default_rng(4)
    keys = itertools.product(range(1, 4), ("systematic", "random", "fixed"), range(1, 6), range(10))
    shake = {key: np.exp(noise.normal(0, 0.5)) for key in keys}
    res = _protocol(lambda run, suite, case, rep: 0.85 * shake[(run, suite, case, rep)])
    suites = suite_verdicts(res)
    assert len(suites) == 9 and (suites["pooled_verdict"] == "cannot_judge").all()
    assert not suites["by_pool"].any()  # no outcome of five case means reaches 0.025
    assert suites["detected_combined"].sum() <= 2  # only where all K repetitions of one case happen to agree
    row = campaign_verdicts(res).set_index("fault").loc["user/fault"]
    assert row["verdict"] == "detected" and row["direction"] == "better"
    assert row["test"] == "sign-flip over case means" and row["alternative"] == "two-sided"
    assert row["alpha"] == 0.05 and row["family"] == "faults" and row["n_tested"] == 45 and row["n_draws"] == 9
    # independent reference: the case means of log(faulty / baseline) and their t interval
    from statsmodels.stats.weightstats import DescrStatsW

    base = res[res["variant"] == "baseline"]["rms_mm"].to_numpy().reshape(45, 10)
    faulty = res[res["variant"] == "user/fault"]["rms_mm"].to_numpy().reshape(45, 10)
    means = np.log(faulty / base).mean(axis=1)
    assert row["mean_log_ratio"] == pytest.approx(means.mean()) and row["ratio"] == pytest.approx(np.exp(means.mean()))
    assert row["ratio_low"] < 0.85 < row["ratio_high"] < 1.0
    t_low, t_high = DescrStatsW(means).tconfint_mean(alpha=0.05)
    assert row["mean_log_ratio_low"] == pytest.approx(t_low, abs=0.02)
    assert row["mean_log_ratio_high"] == pytest.approx(t_high, abs=0.02)
    assert 0 < row["p"] <= 0.05 and row["mc_se"] > 0  # 45 cases: Monte Carlo over sign patterns, its error stated


def test_campaign_verdicts_are_the_exact_test_and_interval_over_case_means_and_cannot_judge_too_few():
    from faultlab.stats.pooling import campaign_verdicts

    noise = np.random.default_rng(8)
    shake = noise.normal(0, 0.3, (3, 5, 10))
    suites = {"systematic": 0, "random": 1, "fixed": 2}
    res = _protocol(lambda run, suite, case, rep: 0.8 * np.exp(shake[suites[suite], case - 1, rep]), runs=1)
    row = campaign_verdicts(res).iloc[0]
    base = res[res["variant"] == "baseline"]["rms_mm"].to_numpy().reshape(15, 10)
    faulty = res[res["variant"] == "user/fault"]["rms_mm"].to_numpy().reshape(15, 10)
    means = np.log(faulty / base).mean(axis=1)
    assert row["p"] == pytest.approx(_brute_two_sided(means)) and row["mc_se"] == 0
    low, high = _brute_interval(means)
    assert (row["mean_log_ratio_low"], row["mean_log_ratio_high"]) == pytest.approx((low, high))
    assert row["p_min"] == 2.0 ** -14 and row["verdict"] == ("detected" if row["p"] <= 0.05 else "not_detected")
    one_suite = res[res["suite"] == "systematic"]
    few = campaign_verdicts(one_suite).iloc[0]
    assert few["verdict"] == "cannot_judge" and few["p_min"] == 2.0 ** -4
    assert np.isnan(few["ratio_low"]) and np.isnan(few["ratio_high"]) and few["direction"] == "better"


def test_campaign_verdicts_holm_over_the_faults_and_keep_the_a_a_control_apart():
    import pandas as pd

    from faultlab.stats.pooling import campaign_verdicts

    res = _protocol(lambda *a: 1.0, runs=1)
    other = res[res["variant"] == "user/fault"].assign(variant="user/other")
    replica = res[res["variant"] == "user/fault"].assign(variant="baseline_replica")
    table = campaign_verdicts(pd.concat([res, other, replica], ignore_index=True)).set_index("fault")
    assert table.loc["baseline_replica", "family"] == "control"
    assert table.loc["baseline_replica", "p_holm"] == table.loc["baseline_replica", "p"]
    p = table.loc["user/fault", "p"]
    assert table.loc["user/fault", "p_holm"] == pytest.approx(min(1.0, 2 * p))
