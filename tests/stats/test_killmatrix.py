"""The kill matrix and suites drawn from it, against brute force, statsmodels and scipy."""

from __future__ import annotations

import dataclasses
import itertools

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import hypergeom
from statsmodels.stats.multitest import multipletests

from faultlab.errors import ConfigError, ResultsError
from faultlab.metrics.detection import DetectionRule
from faultlab.stats.cases import detectable_difference
from faultlab.stats.killmatrix import (DETECTION_COMPARISON_COLUMNS, KillMatrix, StudySpec, SuiteDraws,
                                       bootstrap_probabilities, compare_detection, compare_mean_detection,
                                       compare_scores,
                                       detection_probability, detection_table, draw_suites, evaluate_suites,
                                       combined_detects, judge_suite, kill_matrix, score_table, strong_cases,
                                       study_spec,
                                       suite_detects, suite_kills, suite_rejections)
from faultlab.inference.exact import min_pairs
from tests.stats.synthetic import paired_frame

ALPHA = 0.05


def hand_matrix() -> KillMatrix:
    """Two pools (6 and 5 cases) x 3 variants, p values chosen around alpha / n for n = 1..4."""
    nan = np.nan
    p = np.array([
        # fault_a  fault_b  mutant:x
        [0.004, 0.30, 0.02],
        [0.40, 0.011, nan],      # mutant crashed here
        [0.02, 0.90, 0.60],
        [nan, nan, nan],         # baseline failed: cannot judge
        [0.70, 0.013, 0.0039],
        [0.06, 0.50, 0.30],
        # second pool
        [0.001, 0.20, 0.80],
        [0.30, 0.30, 0.30],
        [0.024, 0.026, 0.012],
        [0.90, 0.005, nan],      # mutant crashed
        [0.50, 0.70, 0.70],
    ])
    crash = np.zeros(p.shape, bool)
    crash[1, 2] = crash[9, 2] = True
    judged = np.ones(p.shape, bool)
    judged[3] = False
    paper = p < 0.015
    cases = pd.DataFrame({"strategy": ["systematic"] * 6 + ["random"] * 5,
                          "run": 1, "case": list(range(1, 7)) + list(range(1, 6))})
    return KillMatrix(cases=cases, variants=("fault_a", "fault_b", "mutant:x"), p=p, crash=crash,
                      timeout=np.zeros(p.shape, bool), judged=judged,
                      paper=paper, mean_diff_mm=np.where(np.isnan(p), np.nan, 100.0),
                      direction=np.full(p.shape, "worse", dtype=object),
                      mean_log_ratio=np.where(np.isnan(p), np.nan, 0.1))


def textbook_holm(p, alpha) -> list[bool]:
    """Holm (1979), step by step: the i-th smallest p value (0-based) is compared with alpha / (m - i)
    until the first one that is larger; NaN counts as 1."""
    p = [1.0 if np.isnan(x) else float(x) for x in p]
    m = len(p)
    reject = [False] * m
    for i, j in enumerate(sorted(range(m), key=lambda k: p[k])):
        if p[j] > alpha / (m - i):
            break
        reject[j] = True
    return reject


def brute_force_detects(p_cases, crash_cases, alpha) -> bool:
    """A suite detects: some case crashed, or Holm over all its cases rejects one."""
    return bool(np.any(crash_cases)) or any(textbook_holm(p_cases, alpha))


@pytest.mark.parametrize("n", [1, 2, 3, 4])
def test_suite_evaluation_matches_brute_force_over_every_subset(n):
    km = hand_matrix()
    ev = evaluate_suites(km, [n], draws=400, bootstrap=50, seed=3, mutants=["mutant:x"])
    for strategy in km.strategies:
        rows = km.rows(strategy)
        subsets = list(itertools.combinations(rows, n))
        for j in range(len(km.variants)):
            share = np.mean([brute_force_detects(km.p[list(s), j], km.crash[list(s), j], ALPHA) for s in subsets])
            # the exact probability is the share of all C(N, n) suites that detect
            assert ev.exact[(strategy, n)][j] == pytest.approx(share, abs=1e-12)
            # the drawn suites estimate it (binomial Monte Carlo error, 400 draws: 5 SE < 0.13)
            assert abs(ev.detects[(strategy, n)][:, j].mean() - share) <= 5 * np.sqrt(share * (1 - share) / 400) + 1e-12


def test_every_drawn_suite_is_judged_as_brute_force_judges_it():
    km = hand_matrix()
    rows = km.rows("systematic")
    idx = draw_suites(rows.size, 3, 50, rng=np.random.default_rng(5))
    det = suite_detects(np.moveaxis(km.p[rows][idx], 1, -1), np.moveaxis(km.crash[rows][idx], 1, -1), alpha=ALPHA)
    for d, suite in enumerate(idx):
        for j in range(3):
            assert det[d, j] == brute_force_detects(km.p[rows][suite, j], km.crash[rows][suite, j], ALPHA)


def test_any_suite_of_pool_cases_is_judged_as_brute_force_judges_it():
    km = hand_matrix()
    for suite in ([0], [2, 5], [0, 2, 3, 5], [6, 8, 9], list(range(11))):
        table = judge_suite(km, suite)
        for j, v in enumerate(km.variants):
            row = table[table["variant"] == v].iloc[0]
            assert row["detected"] == brute_force_detects(km.p[suite, j], km.crash[suite, j], ALPHA)
            assert row["rejecting"] == sum(textbook_holm(km.p[suite, j], ALPHA))
            assert row["paper"] == km.paper[suite, j].any()
    with pytest.raises(ConfigError, match="distinct"):
        judge_suite(km, [1, 1])


@settings(max_examples=150, deadline=None)
@given(st.lists(st.one_of(st.floats(0, 1), st.just(float("nan"))), min_size=1, max_size=12),
       st.sampled_from([0.01, 0.05, 0.1]))
def test_holm_and_bonferroni_match_the_textbook_and_agree_on_some_rejection(p, alpha):
    p = np.array(p)
    filled = np.where(np.isnan(p), 1.0, p)
    holm = suite_rejections(p, alpha=alpha, method="holm")
    bonf = suite_rejections(p, alpha=alpha, method="bonferroni")
    assert holm.tolist() == textbook_holm(p, alpha)
    assert bonf.tolist() == (filled <= alpha / filled.size).tolist()
    assert holm.any() == bonf.any() == (filled.min() <= alpha / filled.size)
    assert holm.sum() >= bonf.sum()  # Holm is uniformly more powerful case by case


@pytest.mark.parametrize("seed", range(5))
def test_holm_and_bonferroni_match_statsmodels(seed):
    rng = np.random.default_rng(seed)
    p = rng.random((4, 7)) ** 3   # many small p values
    for method in ("holm", "bonferroni"):
        expected = np.array([multipletests(row, alpha=0.05, method=method)[0] for row in p])
        np.testing.assert_array_equal(suite_rejections(p, alpha=0.05, method=method), expected)


def test_holm_rejects_more_cases_than_bonferroni_on_a_hand_example():
    p = np.array([0.01, 0.015, 0.03, 0.5])  # Holm: <= 0.0125, <= 0.0167, 0.03 > 0.025 stops; Bonferroni: 0.0125
    assert suite_rejections(p, alpha=ALPHA, method="holm").tolist() == [True, True, False, False]
    assert suite_rejections(p, alpha=ALPHA, method="bonferroni").tolist() == [True, False, False, False]
    with pytest.raises(ConfigError, match="multiplicity"):
        suite_rejections(p, method="hochberg")


@pytest.mark.parametrize("n_pool,h,n", [(10, 0, 3), (10, 1, 3), (10, 4, 5), (22, 7, 12), (12, 12, 1), (8, 5, 8)])
def test_detection_probability_is_the_hypergeometric_chance_of_at_least_one(n_pool, h, n):
    assert detection_probability(h, n_pool, n) == pytest.approx(1 - hypergeom.pmf(0, n_pool, h, n), abs=1e-12)


def test_strong_cases_are_crashes_or_p_at_most_alpha_over_n():
    km = hand_matrix()
    s2 = strong_cases(km, 2, alpha=ALPHA)
    assert s2[0, 0] and s2[2, 0] and not s2[5, 0]          # 0.004, 0.02 <= 0.025 < 0.06
    assert not strong_cases(km, 4, alpha=ALPHA)[2, 0]     # 0.02 > 0.0125
    assert s2[1, 2] and s2[9, 2]                          # crashes
    assert not s2[3].any()                                # cannot judge
    np.testing.assert_array_equal(strong_cases(km, 2, paper=True), km.paper)


def test_draw_suites_draws_distinct_cases_uniformly():
    idx = draw_suites(6, 3, 6000, rng=np.random.default_rng(1))
    assert idx.shape == (6000, 3)
    assert all(len(set(r)) == 3 for r in idx.tolist())
    counts = np.bincount(idx.ravel(), minlength=6) / idx.size
    np.testing.assert_allclose(counts, 1 / 6, atol=0.01)
    with pytest.raises(ConfigError, match="pool of 6"):
        draw_suites(6, 7, 1, rng=np.random.default_rng(1))


def test_bootstrap_is_certain_when_every_or_no_case_is_strong():
    rng = np.random.default_rng(0)
    strong = np.column_stack([np.ones(7, bool), np.zeros(7, bool)])
    b = bootstrap_probabilities(strong, 3, 20, rng=rng)
    assert b.shape == (20, 2) and (b[:, 0] == 1).all() and (b[:, 1] == 0).all()


def test_same_seed_same_suites_and_intervals_other_seed_other_suites():
    km = hand_matrix()
    kw = dict(draws=300, bootstrap=200, mutants=["mutant:x"])
    a = evaluate_suites(km, [1, 2, 4], seed=11, **kw)
    b = evaluate_suites(km, [1, 2, 4], seed=11, **kw)
    c = evaluate_suites(km, [1, 2, 4], seed=12, **kw)
    for key in a.detects:
        np.testing.assert_array_equal(a.detects[key], b.detects[key])
        np.testing.assert_array_equal(a.boot[key], b.boot[key])
    pd.testing.assert_frame_equal(detection_table(a, km.variants), detection_table(b, km.variants))
    assert any(not np.array_equal(a.boot[k], c.boot[k]) for k in a.boot)
    # adding a size changes no other size's draws (one stream per strategy and size)
    d = evaluate_suites(km, [2], seed=11, **kw)
    for s in km.strategies:
        np.testing.assert_array_equal(d.detects[(s, 2)], a.detects[(s, 2)])
        np.testing.assert_array_equal(d.boot[(s, 2)], a.boot[(s, 2)])


def test_scores_and_comparisons_are_consistent_with_the_drawn_suites():
    km = hand_matrix()
    ev = evaluate_suites(km, [1, 3], draws=500, bootstrap=300, seed=2, mutants=["mutant:x"])
    scores = score_table(ev)
    det = detection_table(ev, km.variants)
    for _, r in scores.iterrows():
        # one mutant: the score is its detection rate
        rate = det[(det["variant"] == "mutant:x") & (det["strategy"] == r["strategy"]) & (det["size"] == r["size"])]
        assert r["score"] == pytest.approx(float(rate["rate"].iloc[0]))
        assert r["ci_low"] <= r["ci_high"]
    # the point of the exact interval: n generated cases, from the pool's strong cases, inside its own interval
    h, n_pool = det["strong_cases"].to_numpy(float), det["pool"].to_numpy(float)
    np.testing.assert_allclose(det["rate_generated"], 1 - (1 - h / n_pool) ** det["size"].to_numpy(float))
    assert ((det["ci_low"] <= det["rate_generated"]) & (det["rate_generated"] <= det["ci_high"])).all()
    assert (det["ci_low"] < det["ci_high"]).all()
    comp = compare_scores(ev)
    assert set(comp["size"]) == {1, 3} and (comp["p_holm"] >= comp["p_boot"] - 1e-12).all()
    row = comp[comp["size"] == 1].iloc[0]
    assert row["diff"] == pytest.approx(row["score_a"] - row["score_b"])
    assert 0 <= row["mcnemar_p_median"] <= 1


def _results(diffs: dict, *, k: int = 6) -> pd.DataFrame:
    """Runner-shaped results: baseline error 1000 mm, variant = baseline + diff per repetition (or a crash)."""
    rows = []
    for (suite, case), per_variant in diffs.items():
        for rep in range(k):
            rows.append(dict(run=1, suite=suite, case=case, rep=rep, variant="baseline", status="ok",
                             rms_mm=1000.0 + rep, emd_mm=1.0, runtime_s=0.1))
            for variant, d in per_variant.items():
                if d == "crash":
                    rows.append(dict(run=1, suite=suite, case=case, rep=rep, variant=variant, status="crash",
                                     rms_mm=np.nan, emd_mm=np.nan, runtime_s=0.1))
                else:
                    rows.append(dict(run=1, suite=suite, case=case, rep=rep, variant=variant, status="ok",
                                     rms_mm=1000.0 + rep + d[rep], emd_mm=1.0, runtime_s=0.1))
    return pd.DataFrame(rows)


def _sign_flip_p(d, two_sided=True) -> float:
    """Textbook enumeration of the 2^K sign patterns: share with mean >= the observed mean
    (two-sided: twice the smaller tail, at most 1)."""
    d = np.asarray(d, float)
    signs = np.array(list(itertools.product([1, -1], repeat=d.size)))
    means = (signs * d).mean(axis=1)
    greater = float(np.mean(means >= d.mean() - 1e-9))
    less = float(np.mean(means <= d.mean() + 1e-9))
    return min(1.0, 2 * min(greater, less)) if two_sided else greater


def test_kill_matrix_holds_the_exact_p_value_crash_and_paper_flag_of_every_case():
    up = [400, 500, 450, 600, 700, 300]        # every repetition worse by > 250 mm and >= 25 %
    mixed = [5, -3, 8, 2, -1, 4]
    res = _results({("random", 1): {"f": up, "g": mixed}, ("random", 2): {"f": mixed, "g": "crash"},
                    ("pairwise", 1): {"f": [0] * 6, "g": "crash"}})
    timed_out = (res["suite"] == "pairwise") & (res["variant"] == "g") & (res["rep"] == 2)
    res.loc[timed_out, "status"] = "timeout"
    km = kill_matrix(res, rule=DetectionRule())
    assert km.strategies == ("random", "pairwise") or set(km.strategies) == {"random", "pairwise"}
    frame = km.to_frame().set_index(["strategy", "case", "variant"])
    assert frame.loc[("random", 1, "f"), "p"] == pytest.approx(_sign_flip_p(up))
    assert frame.loc[("random", 1, "g"), "p"] == pytest.approx(_sign_flip_p(mixed))
    assert frame.loc[("pairwise", 1, "f"), "p"] == 1.0
    assert frame.loc[("random", 1, "f"), "direction"] == "worse" and frame.loc[("pairwise", 1, "f"), "direction"] == "none"
    one = kill_matrix(res, rule=DetectionRule(direction="worse")).to_frame().set_index(["strategy", "case", "variant"])
    assert one.loc[("random", 1, "f"), "p"] == pytest.approx(_sign_flip_p(up, two_sided=False))
    assert bool(frame.loc[("random", 2, "g"), "crash"]) and np.isnan(frame.loc[("random", 2, "g"), "p"])
    assert bool(frame.loc[("random", 1, "f"), "paper"]) and not bool(frame.loc[("random", 1, "g"), "paper"])
    assert frame["judged"].all()
    # a timeout is kept apart from crashes: it detects only with timeouts_detect
    assert bool(frame.loc[("pairwise", 1, "g"), "timeout"]) and not bool(frame.loc[("pairwise", 1, "g"), "crash"])
    j, row = km.variants.index("g"), int(np.flatnonzero((km.cases["strategy"] == "pairwise").to_numpy())[0])
    assert not strong_cases(km, 1)[row, j] and strong_cases(km, 1, timeouts_detect=True)[row, j]
    back = KillMatrix.from_frame(km.to_frame())
    np.testing.assert_array_equal(back.p, km.p)
    np.testing.assert_array_equal(back.crash, km.crash)
    np.testing.assert_array_equal(back.direction, km.direction)
    with pytest.raises(ResultsError, match="cases x"):
        KillMatrix.from_frame(km.to_frame().iloc[1:])


def test_a_mutant_that_only_improves_the_map_is_killed_by_the_two_sided_rule():
    """Every repetition better by 200-300 mm: the two-sided rule kills, the paper's one-sided one does not."""
    better = [-200, -250, -300, -220, -280, -260, -240, -210, -230]
    res = _results({("random", 1): {"mutant:x": better, "f": [3, -2, 4, -1, 2, -3, 1, -4, 5]}}, k=9)
    km = kill_matrix(res, rule=DetectionRule())
    j = km.variants.index("mutant:x")
    assert km.p[0, j] == pytest.approx(_sign_flip_p(better)) == 2.0 ** -8
    assert km.direction[0, j] == "better"
    assert judge_suite(km, [0]).set_index("variant").loc["mutant:x", "detected"]
    one = kill_matrix(res, rule=DetectionRule(direction="worse"))
    assert one.p[0, j] == 1.0 and not judge_suite(one, [0]).set_index("variant").loc["mutant:x", "detected"]


def test_exact_detection_interval_is_clopper_pearson_mapped_to_n_cases_and_never_zero_width():
    from scipy.stats import beta

    from faultlab.stats.killmatrix import exact_detection_interval

    lo, hi = exact_detection_interval([0, 16, 5], 16, 1)
    assert lo[0] == 0.0 and hi[0] == pytest.approx(beta.ppf(0.975, 1, 16))      # 0/16: up to 21 % per case
    assert hi[1] == 1.0 and lo[1] == pytest.approx(beta.ppf(0.025, 16, 1))
    assert np.all(hi > lo)
    lo5, hi5 = exact_detection_interval([5], 16, 5)
    assert lo5[0] == pytest.approx(1 - (1 - beta.ppf(0.025, 5, 12)) ** 5)
    assert hi5[0] == pytest.approx(1 - (1 - beta.ppf(0.975, 6, 11)) ** 5)


def test_an_exact_detection_interval_keeps_its_width_where_the_lower_bound_rounds_to_one():
    """165 of 165 strong cases and suites of 10: the mapped Clopper-Pearson lower bound is 1 - 3e-17, which a
    double (and a table) shows as 1; it is rounded outwards to what a written table resolves."""
    from decimal import Decimal

    from scipy.stats import beta

    from faultlab.precision import FLOAT_FORMAT
    from faultlab.stats.killmatrix import exact_detection_interval

    exact = 1 - (1 - Decimal(beta.ppf(0.025, 165, 1))) ** 10     # the bound in exact decimal arithmetic
    assert Decimal(1) - exact < Decimal("1e-16") and float(exact) == 1.0
    lo, hi = exact_detection_interval([165, 30], 165, 10)
    assert hi[0] == 1.0 and lo[0] < 1.0 and FLOAT_FORMAT % lo[0] != FLOAT_FORMAT % hi[0]
    assert Decimal(lo[0]) <= exact                                  # still a valid (conservative) lower bound
    assert lo[1] == pytest.approx(1 - (1 - beta.ppf(0.025, 30, 136)) ** 10, rel=1e-12)  # an ordinary bound unchanged


def test_smallest_showable_difference_is_the_exact_mcnemar_floor():
    from statsmodels.stats.contingency_tables import mcnemar

    from faultlab.stats.killmatrix import smallest_showable_difference

    for m in (10, 150):
        d = round(smallest_showable_difference(m) * m)
        assert mcnemar([[0, d], [0, m - d]], exact=True).pvalue <= 0.05
        assert mcnemar([[0, d - 1], [0, m - d + 1]], exact=True).pvalue > 0.05


def test_judge_suite_pools_a_diffuse_effect_the_per_case_minimum_misses():
    """12 cases, every one 15-25 % worse in most repetitions but none significantly so at 0.05 / 12."""
    rng = np.random.default_rng(8)
    diffs = {("random", c): {"diffuse": list(1000.0 * (np.exp(rng.normal(0.2, 0.35, 9)) - 1)),
                             "none": list(rng.normal(0.0, 30.0, 9))} for c in range(1, 13)}
    km = kill_matrix(_results(diffs, k=9), rule=DetectionRule())
    j = judge_suite(km, np.arange(12)).set_index("variant")
    means = km.mean_log_ratio[:, km.variants.index("diffuse")]
    assert j.loc["diffuse", "pooled_p"] == pytest.approx(_sign_flip_p(means))  # exact, over the case means
    assert not j.loc["diffuse", "detected"] and j.loc["diffuse", "detected_pooled"]
    assert j.loc["diffuse", "by_pool"] and not j.loc["diffuse", "by_case"]
    assert not j.loc["none", "detected_pooled"]


def test_judge_suite_pools_every_variant_as_the_pooled_test_of_its_own_case_means():
    # variants with different numbers of tested cases (a case without a usable pair is left out)
    # are judged together by size; each pooled p is the test of that variant's case means alone
    from faultlab.stats.pooling import pooled_pvalues

    rng = np.random.default_rng(9)
    diffs = {("random", c): {f"v{i}": list(rng.normal(40.0 * i, 30.0, 6)) for i in range(4)} for c in range(1, 9)}
    for c, v in ((2, "v2"), (5, "v2"), (6, "v3")):
        diffs[("random", c)][v] = "crash"                        # no usable pair: the case is untested
    km = kill_matrix(_results(diffs, k=6), rule=DetectionRule())
    j = judge_suite(km, np.arange(8)).set_index("variant")
    sizes = {}
    for v in ("v0", "v1", "v2", "v3"):
        means = km.mean_log_ratio[:, km.variants.index(v)]
        means = means[~np.isnan(means) & ~np.isnan(km.p[:, km.variants.index(v)])]
        sizes[v] = means.size
        assert j.loc[v, "pooled_p"] == pooled_pvalues(means[None, :])[0][0], v
    assert sizes == {"v0": 8, "v1": 8, "v2": 6, "v3": 7}

# -- the per-case kill of a mutation campaign, the [study] table --------------------------------



def test_case_kill_classes_follow_the_exact_paired_test_at_the_case_level():
    k = 7  # 2^-7 = 0.0078 <= 0.01
    df = paired_frame({"mutant:a": np.full(k, 50.0), "mutant:b": np.array([50.0] * 6 + [-5.0]),
                 "mutant:c": np.zeros(k), "mutant:d": np.zeros(k), "mutant:e": np.zeros(k)},
                k, status={"mutant:d": "crash", "mutant:e": "timeout"})
    kills = suite_kills(df, case_alpha=0.01, direction="worse").set_index("fault")["kill"]
    # b: sum 295; only b itself and the all-positive pattern (305) reach it: p = 2/128 = 0.0156 > 0.01
    assert kills.to_dict() == {"mutant:a": "killed", "mutant:b": "", "mutant:c": "", "mutant:d": "crash",
                               "mutant:e": "timeout"}
    assert suite_kills(df, case_alpha=0.02, direction="worse").set_index("fault")["kill"]["mutant:b"] == "killed"
    # two-sided (the default) at 0.01 needs K = 8: with K = 7 no case can be judged
    two = suite_kills(df, case_alpha=0.01).set_index("fault")
    assert two.loc["mutant:a", "kill"] == "" and two.loc["mutant:a", "reason"] == "too_few_pairs"


def test_a_mutant_that_only_improves_is_killed_by_the_two_sided_case_rule():
    k = min_pairs(0.01, alternative="two-sided")
    assert k == 8
    df = paired_frame({"mutant:better": np.full(k, -50.0), "mutant:worse": np.full(k, 50.0)}, k)
    two = suite_kills(df, case_alpha=0.01).set_index("fault")
    assert two.loc["mutant:better", "kill"] == "killed" and two.loc["mutant:better", "direction"] == "better"
    assert two.loc["mutant:worse", "kill"] == "killed" and two.loc["mutant:worse", "direction"] == "worse"
    assert two.loc["mutant:better", "p"] == 2.0 ** -7
    one = suite_kills(df, case_alpha=0.01, direction="worse").set_index("fault")
    assert one.loc["mutant:better", "kill"] == "" and one.loc["mutant:worse", "kill"] == "killed"


def test_study_spec_defaults_and_types():
    assert study_spec({}, source="x") == StudySpec()
    with pytest.raises(ConfigError, match="x: study.alpha must lie in"):
        study_spec({"alpha": 1.5}, source="x")
    with pytest.raises(ConfigError, match="study.timeouts_detect must be true or false"):
        study_spec({"timeouts_detect": "no"}, source="x")


def _pooled_matrix() -> KillMatrix:
    """hand_matrix with case mean log ratios of both signs, mostly positive (NaN where not tested)."""
    km = hand_matrix()
    rng = np.random.default_rng(11)
    means = np.where(np.isnan(km.p), np.nan, rng.normal(0.3, 0.4, km.p.shape))
    return dataclasses.replace(km, mean_log_ratio=means)


def brute_force_combined(p_cases, crash_cases, means, alpha) -> bool:
    """Crash, or some case's p <= alpha / (2 n), or the textbook sign-flip p over the tested cases'
    means <= alpha / 2."""
    n = len(p_cases)
    if np.any(crash_cases) or np.nanmin(np.where(np.isnan(p_cases), 1.0, p_cases)) <= alpha / 2 / n:
        return True
    tested = ~np.isnan(means) & ~np.isnan(p_cases)
    return bool(tested.any()) and _sign_flip_p(np.asarray(means)[tested]) <= alpha / 2


def test_combined_decision_of_drawn_suites_matches_brute_force_and_judge_suite():
    km = _pooled_matrix()
    rows = km.rows("systematic")
    idx = draw_suites(rows.size, 5, 60, rng=np.random.default_rng(2))
    det = combined_detects(np.moveaxis(km.p[rows][idx], 1, -1), np.moveaxis(km.crash[rows][idx], 1, -1),
                           np.moveaxis(km.mean_log_ratio[rows][idx], 1, -1), alpha=ALPHA)
    assert det.shape == (60, 3)
    seen = set()
    for d, suite in enumerate(idx):
        judged = judge_suite(km, rows[suite]).set_index("variant")
        for j, v in enumerate(km.variants):
            expected = brute_force_combined(km.p[rows][suite, j], km.crash[rows][suite, j],
                                            km.mean_log_ratio[rows][suite, j], ALPHA)
            assert det[d, j] == expected == judged.loc[v, "detected_pooled"]
            seen.add(expected)
    assert seen == {True, False}   # the hand matrix exercises both decisions


def test_detection_table_reports_the_combined_rate_beside_the_per_case_minimum():
    km = _pooled_matrix()
    ev = evaluate_suites(km, [2, 4], draws=200, bootstrap=20, seed=4, mutants=["mutant:x"])
    table = detection_table(ev, km.variants).set_index(["variant", "strategy", "size"])
    for (strategy, n), det in ev.detects.items():
        for j, v in enumerate(km.variants):
            combined = ev.detects_pooled[(strategy, n)][:, j]
            assert table.loc[(v, strategy, n), "rate_combined"] == pytest.approx(combined.mean())
            assert table.loc[(v, strategy, n), "rate"] == pytest.approx(det[:, j].mean())


def test_a_kill_matrix_without_case_means_has_no_combined_rate():
    km = hand_matrix()
    km = dataclasses.replace(km, mean_log_ratio=np.full(km.p.shape, np.nan))
    ev = evaluate_suites(km, [2], draws=20, bootstrap=5, seed=4)
    assert ev.detects_pooled == {}
    assert detection_table(ev, km.variants)["rate_combined"].isna().all()


def test_whole_suites_judge_each_runs_suite_by_textbook_holm_and_count_suites_as_units():
    import dataclasses

    from scipy.stats import binomtest

    from faultlab.stats.killmatrix import whole_suite_table, whole_suites

    km = hand_matrix()
    # the systematic pool as two runs of 3 cases each: two whole generated suites
    km = dataclasses.replace(km, cases=km.cases.assign(run=[1, 1, 1, 2, 2, 2] + [1] * 5))
    whole = whole_suites(km, ["systematic"], alpha=ALPHA)
    assert len(whole) == 2 * 3 and set(whole["size"]) == {3}
    for run, rows in ((1, [0, 1, 2]), (2, [3, 4, 5])):
        for j, v in enumerate(km.variants):
            got = whole[(whole["run"] == run) & (whole["variant"] == v)].iloc[0]
            assert bool(got["detected"]) == brute_force_detects(km.p[rows, j], km.crash[rows, j], ALPHA)
            assert bool(got["paper"]) == bool(km.paper[rows, j].any())
    table = whole_suite_table(whole, mutants=["mutant:x"], alpha=ALPHA)
    for _, r in table[table["variant"] != "mutation score"].iterrows():
        k = int(whole[whole["variant"] == r["variant"]]["detected"].sum())
        ci = binomtest(k, 2).proportion_ci(0.95, method="exact")
        assert (r["detected"], r["suites"], r["rate"]) == (k, 2, k / 2)
        assert (r["ci_low"], r["ci_high"]) == pytest.approx((ci.low, ci.high))
        assert r["ci_low"] < r["ci_high"]                      # never a zero-width interval from 2 suites
    score = table[table["variant"] == "mutation score"].iloc[0]
    assert score["rate"] == pytest.approx(whole[whole["variant"] == "mutant:x"]["detected"].mean())
    # a score's range over suites is no interval: its own columns, and no ci_low/ci_high
    per_suite = whole[whole["variant"] == "mutant:x"].groupby("run")["detected"].mean()
    assert (score["range_min"], score["range_max"]) == (per_suite.min(), per_suite.max())
    assert np.isnan(score["ci_low"]) and np.isnan(score["ci_high"])
    assert table[table["variant"] != "mutation score"][["range_min", "range_max"]].isna().all().all()
    with pytest.raises(ConfigError, match="study.whole"):
        whole_suites(km, ["pairwise"])


def test_a_whole_suite_of_more_cases_than_the_exact_pooled_test_enumerates_is_judged_reproducibly():
    from statsmodels.stats.multitest import multipletests

    from faultlab.stats.killmatrix import whole_suites
    from faultlab.inference.exact import MAX_EXACT_PAIRS

    n = MAX_EXACT_PAIRS + 2                     # a whole base-choice suite of Table I: 22 cases
    rng = np.random.default_rng(5)
    p = rng.uniform(0.01, 1.0, (n, 2))          # no case strong at alpha / n = 0.0023 ...
    p[3, 0] = 0.05 / n / 2                      # ... but one of fault_a's
    means = rng.normal(0.0, 0.3, (n, 2))
    km = KillMatrix(cases=pd.DataFrame({"strategy": "base-choice", "run": 1, "case": range(1, n + 1)}),
                    variants=("fault_a", "fault_b"), p=p, crash=np.zeros(p.shape, bool),
                    timeout=np.zeros(p.shape, bool), judged=np.ones(p.shape, bool), paper=p < 0.01,
                    mean_diff_mm=np.full(p.shape, 10.0), direction=np.full(p.shape, "worse", dtype=object),
                    mean_log_ratio=means)
    whole = whole_suites(km, ["base-choice"], alpha=ALPHA, seed=3)
    assert set(whole["size"]) == {n}
    for j, v in enumerate(km.variants):          # the suite rule: Holm over the n cases (statsmodels)
        holm = multipletests(p[:, j], alpha=ALPHA, method="holm")[0].any()
        assert bool(whole.loc[whole["variant"] == v, "detected"].iloc[0]) == holm
    assert whole["detected"].tolist() == [True, False]
    pd.testing.assert_frame_equal(whole, whole_suites(km, ["base-choice"], alpha=ALPHA, seed=3))


def test_study_spec_reads_whole_suites():
    assert study_spec({"whole": ["pairwise"]}, source="f.toml").whole == ("pairwise",)
    assert study_spec({}, source="f.toml").whole == ()
    for bad in ("pairwise", ["pairwise", "pairwise"], [1]):
        with pytest.raises(ConfigError, match="whole"):
            study_spec({"whole": bad}, source="f.toml")


def _draws_of_counts(pools: dict, strong: dict) -> SuiteDraws:
    """Suite draws holding only what compare_detection reads: pool sizes and size-1 strong counts."""
    variants = tuple(next(iter(strong.values())).keys())
    return SuiteDraws(variants=variants, detects={}, detects_paper={}, exact={}, boot={},
                      mutant_boot=np.empty((0, 0), dtype=np.int64), mutants=(), pool_sizes=pools,
                      n_strong={(s, 1): np.array([strong[s][v] for v in variants]) for s in pools})


def test_detection_comparison_counts_the_cases_that_alone_detect():
    km = hand_matrix()
    ev = evaluate_suites(km, [1, 3], draws=200, bootstrap=50, seed=2, mutants=["mutant:x"])
    comp = compare_detection(ev, ["fault_a", "fault_b"])
    assert list(comp.columns) == list(DETECTION_COMPARISON_COLUMNS) and len(comp) == 2
    for _, r in comp.iterrows():
        j = km.variants.index(r["variant"])
        for side in ("a", "b"):
            rows = (km.cases["strategy"] == r[f"strategy_{side}"]).to_numpy()
            # brute force: a case of a one-case suite detects when it crashes or its p <= alpha
            want = int((km.crash[rows, j] | (np.nan_to_num(km.p[rows, j], nan=1.0) <= ALPHA)).sum())
            assert r[f"detect_{side}"] == want and r[f"pool_{side}"] == rows.sum()
        assert r["diff"] == pytest.approx(r["rate_a"] - r["rate_b"])


@pytest.mark.filterwarnings("ignore::RuntimeWarning")  # statsmodels' ratio and odds ratio of 0 % rates
@settings(max_examples=150, deadline=None)
@given(st.integers(5, 250), st.integers(5, 250), st.data())
def test_detection_comparison_interval_test_and_equivalence_margin_agree(na, nb, data):
    """statsmodels' own TOST is the reference for the margin; the interval and the test are dual."""
    from statsmodels.stats.proportion import tost_proportions_2indep

    ka, kb = data.draw(st.integers(0, na)), data.draw(st.integers(0, nb))
    ev = _draws_of_counts({"a": na, "b": nb}, {"a": {"f": ka}, "b": {"f": kb}})
    r = compare_detection(ev, ["f"]).iloc[0]
    assert r["ci_low"] < r["diff"] < r["ci_high"] or r["ci_low"] < r["ci_high"]  # never of zero width
    assert r["ci_high"] - r["ci_low"] > 0
    if abs(r["p"] - ALPHA) > 1e-6:
        assert (r["p"] <= ALPHA) == (r["ci_low"] > 0 or r["ci_high"] < 0)
    d = r["equivalence_margin"]
    tost = tost_proportions_2indep(ka, na, kb, nb, -d, d, method="agresti-caffo").pvalue
    assert tost == pytest.approx(ALPHA, abs=1e-6)
    assert r["mdd80"] == detectable_difference((ka / na + kb / nb) / 2, na, nb, alpha=ALPHA)  # one pair


def test_detection_comparison_finds_a_planted_difference_and_keeps_its_level_on_a_a_pools():
    """Binomial pools: 30 points apart the test shows it; equal rates it rejects at about alpha (A/A)."""
    rng = np.random.default_rng(20261126)
    n, sims = 165, 400
    shown = aa = 0
    for _ in range(sims):
        planted = _draws_of_counts({"a": n, "b": n}, {"a": {"f": rng.binomial(n, 0.65)},
                                                     "b": {"f": rng.binomial(n, 0.35)}})
        shown += bool(compare_detection(planted, ["f"])["shown"].iloc[0])
        same = _draws_of_counts({"a": n, "b": n}, {"a": {"f": rng.binomial(n, 0.3)}, "b": {"f": rng.binomial(n, 0.3)}})
        aa += bool(compare_detection(same, ["f"])["p"].iloc[0] <= ALPHA)
    assert shown / sims > 0.99
    # false alarms: at most alpha plus three binomial standard errors of 400 A/A runs
    assert aa / sims <= ALPHA + 3 * np.sqrt(ALPHA * (1 - ALPHA) / sims)


def test_detection_comparison_holm_is_within_a_fault_and_over_the_study():
    pools = {"a": 100, "b": 100, "c": 100}
    strong = {"a": {"f": 80, "g": 50}, "b": {"f": 50, "g": 50}, "c": {"f": 60, "g": 45}}
    comp = compare_detection(_draws_of_counts(pools, strong), ["f", "g"])
    for v, part in comp.groupby("variant"):
        want = multipletests(part["p"], method="holm")[1]
        np.testing.assert_allclose(part["p_holm"], want)
    np.testing.assert_allclose(comp["p_holm_study"], multipletests(comp["p"], method="holm")[1])
    assert (comp["shown"] == (comp["p_holm"] <= ALPHA)).all()
    assert comp.loc[(comp["variant"] == "f") & (comp["strategy_a"] == "a") & (comp["strategy_b"] == "b"), "shown"].item()


def _score_matrix(scores: dict, n_variants: int, rng) -> KillMatrix:
    """A kill matrix whose pool cases detect (p = 0.001) exactly round(score * n_variants) of the variants."""
    rows, strategies = [], []
    for s, case_scores in scores.items():
        for x in case_scores:
            k = int(round(x * n_variants))
            p = np.full(n_variants, 0.5)
            p[rng.permutation(n_variants)[:k]] = 0.001
            rows.append(p)
            strategies.append(s)
    p = np.array(rows)
    shape = p.shape
    cases = pd.DataFrame({"strategy": strategies, "run": 1, "case": range(len(strategies))})
    return KillMatrix(cases=cases, variants=tuple(f"f{j}" for j in range(n_variants)), p=p,
                      crash=np.zeros(shape, bool), timeout=np.zeros(shape, bool), judged=np.ones(shape, bool),
                      paper=np.zeros(shape, bool), mean_diff_mm=np.ones(shape),
                      direction=np.full(shape, "worse", dtype=object), mean_log_ratio=np.zeros(shape))


def test_mean_detection_is_the_average_of_the_per_fault_differences_with_welchs_interval():
    from statsmodels.stats.weightstats import CompareMeans, DescrStatsW, ttost_ind

    km = hand_matrix()
    faults = ["fault_a", "fault_b"]
    mean = compare_mean_detection(km, faults).iloc[0]
    ev = evaluate_suites(km, [1], draws=50, bootstrap=20, seed=1, mutants=["mutant:x"])
    per_fault = compare_detection(ev, faults)
    assert mean["diff"] == pytest.approx(per_fault["diff"].mean())  # the same quantity, two routes
    # Welch against statsmodels, on the per-case shares counted by hand
    strong = np.nan_to_num(km.p[:, :2], nan=1.0) <= ALPHA
    share = strong.mean(axis=1)
    a, b = share[:6], share[6:]
    cm = CompareMeans(DescrStatsW(a), DescrStatsW(b))
    lo, hi = cm.tconfint_diff(alpha=ALPHA, usevar="unequal")
    assert (mean["ci_low"], mean["ci_high"]) == pytest.approx((lo, hi))
    assert mean["p"] == pytest.approx(cm.ttest_ind(usevar="unequal")[1])
    d = mean["equivalence_margin"]
    assert ttost_ind(a, b, -d, d, usevar="unequal")[0] == pytest.approx(ALPHA, abs=1e-9)


def test_mean_detection_shows_a_planted_difference_and_cannot_judge_constant_pools():
    rng = np.random.default_rng(20261126)
    n = 165
    planted = _score_matrix({"a": rng.binomial(17, 0.6, n) / 17, "b": rng.binomial(17, 0.5, n) / 17}, 17, rng)
    row = compare_mean_detection(planted, list(planted.variants)).iloc[0]
    assert row["shown"] and row["ci_low"] > 0 and row["ci_low"] < 0.1 < row["ci_high"]
    flat = _score_matrix({"a": np.full(5, 0.5), "b": np.full(5, 0.5)}, 4, rng)
    row = compare_mean_detection(flat, list(flat.variants)).iloc[0]
    assert row["diff"] == 0 and np.isnan(row["p"]) and np.isnan(row["ci_low"]) and not row["shown"]


def test_mean_detection_keeps_its_level_on_a_a_pools():
    """False alarms of the averaged comparison on pools drawn from one strategy, counted against a bound."""
    rng = np.random.default_rng(7)
    sims, alarms = 300, 0
    for _ in range(sims):
        km = _score_matrix({"a": rng.binomial(17, 0.4, 60) / 17, "b": rng.binomial(17, 0.4, 60) / 17}, 17, rng)
        alarms += bool(compare_mean_detection(km, list(km.variants))["p"].iloc[0] <= ALPHA)
    assert alarms / sims <= ALPHA + 3 * np.sqrt(ALPHA * (1 - ALPHA) / sims)
