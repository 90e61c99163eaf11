"""Case-level verdicts, rates, suite comparisons, A/A false alarms and the comparison with the paper."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy.stats import boschloo_exact, norm
from statsmodels.stats.multitest import multipletests

from faultlab.metrics.detection import DetectionRule
from faultlab.inference.exact import detectable_shift_factor
from faultlab.stats.cases import (
    AGREEMENT_MARGIN,
    case_rates,
    compare_suites_by_case,
    compare_with_paper,
    detectable_difference,
    gee_suite_test,
    holm_within,
    replica_false_alarms,
    rule_verdicts,
)
from faultlab.stats.detection import outcomes
from faultlab.vocabulary import REPLICA
from tests.stats.synthetic import frame, job

STAT = DetectionRule(rule="statistical", alpha=0.05, family="fault")


def campaign(k: int, *, faults=("naive_resampling",), runs=3, seed=1, shift=None) -> pd.DataFrame:
    """Runs x (systematic, random) x 4 cases x K reps; the fault adds ``shift[suite]`` mm on average."""
    rng = np.random.default_rng(seed)
    shift = shift or {"systematic": 0.0, "random": 400.0}
    rows = []
    for run in range(1, runs + 1):
        for suite in ("systematic", "random"):
            for case in range(1, 5):
                base_level = rng.uniform(100, 300)
                for rep in range(k):
                    b = base_level + rng.normal(0, 20)
                    rows.append(job(run, suite, case, "baseline", rep, b))
                    for f in faults:
                        rows.append(job(run, suite, case, f, rep, b + shift[suite] + rng.normal(0, 20)))
    return frame(rows)


def test_holm_within_adjusts_each_family_alone():
    p = np.array([0.01, 0.04, 0.03, np.nan, 0.02])
    fam = np.array(["a", "a", "b", "b", "b"])
    out = holm_within(p, fam)
    np.testing.assert_allclose(out[:2], multipletests(p[:2], method="holm")[1])
    np.testing.assert_allclose(out[[2, 4]], multipletests(p[[2, 4]], method="holm")[1])
    assert np.isnan(out[3])


def test_adding_an_unrelated_variant_changes_no_verdict_of_another_fault():
    one = campaign(6, faults=("naive_resampling",), seed=3)
    two = campaign(6, faults=("naive_resampling", "motion_sign_error"), seed=3)
    # the same draws for the shared fault: rebuild the naive rows of `two` from `one`
    two = pd.concat([one, two[two["variant"] == "motion_sign_error"]], ignore_index=True)
    v1 = rule_verdicts(one, outcomes(one), rule=STAT)
    v2 = rule_verdicts(two, outcomes(two), rule=STAT)
    v2 = v2[v2["fault"] == "naive_resampling"].reset_index(drop=True)
    pd.testing.assert_frame_equal(v1, v2)
    # under a campaign-wide family the same addition would have changed the adjusted p values
    whole = holm_within(np.r_[v1["p"], v1["p"]], np.zeros(2 * len(v1)))
    assert not np.allclose(whole[:len(v1)], v1["p_holm"])


def test_statistical_verdict_is_the_exact_test_after_holm_within_the_fault():
    res = campaign(6)
    v = rule_verdicts(res, outcomes(res), rule=STAT)
    p = v["p"].to_numpy()
    np.testing.assert_allclose(v["p_holm"], multipletests(p, method="holm")[1])
    assert ((v["p_holm"] <= 0.05) == (v["verdict"] == "detected")).all()
    # every random case has all 6 differences positive: two-sided p = 2 * 2^-6 each, Holm over 24 cases
    rnd = v[v["suite"] == "random"]
    assert np.allclose(rnd["p"], 2.0 ** -5) and (rnd["direction"] == "worse").all()
    assert (rnd["verdict"] == "not_detected").all()  # 24 * 2^-5 > 0.05: K = 6 is too few for this family
    # the smallest detectable shift is that of the decision: two-sided, Holm's first step 0.05 / 24,
    # which K = 6 cannot reach (2^-5 > 0.05 / 24): nothing is detectable
    assert np.isinf(v["mde_mm"]).all()
    wide = rule_verdicts(res, outcomes(res), rule=DetectionRule(rule="statistical", family="case"))
    sd = res[res["variant"] == "baseline"].groupby(["suite", "run", "case"])["rms_mm"].std()
    expect = detectable_shift_factor(6, alternative="two-sided") * np.sqrt(2.0) * sd.to_numpy()
    np.testing.assert_allclose(wide.sort_values(["suite", "run", "case"])["mde_mm"], expect)
    # the paper's one-sided notion, labelled
    one = rule_verdicts(res, outcomes(res), rule=DetectionRule(rule="statistical", direction="worse"))
    assert np.allclose(one[one["suite"] == "random"]["p"], 2.0 ** -6) and (one["alternative"] == "greater").all()


def test_paper_rule_case_is_detected_by_strict_majority_and_cannot_judge_is_apart():
    rows = []
    # case 1: 2 of 3 reps detect; case 2: 1 of 2 judged (tie: not detected); case 3: baseline always fails
    for rep, (f, b) in enumerate([(900, 100), (900, 100), (100, 100)]):
        rows += [job(1, "fixed", 1, "baseline", rep, b), job(1, "fixed", 1, "naive_resampling", rep, f)]
    for rep, (f, b) in enumerate([(900, 100), (100, 100), (100, 100)]):
        rows += [job(1, "fixed", 2, "baseline", rep, b, status="crash" if rep == 2 else "ok"),
                 job(1, "fixed", 2, "naive_resampling", rep, f)]
    for rep in range(3):
        rows += [job(1, "fixed", 3, "baseline", rep, float("nan"), status="crash"),
                 job(1, "fixed", 3, "naive_resampling", rep, 100.0)]
    res = frame(rows)
    v = rule_verdicts(res, outcomes(res), rule=DetectionRule()).set_index("case")
    assert v.loc[1, "verdict"] == "detected" and v.loc[1, "share"] == pytest.approx(2 / 3)
    assert v.loc[2, "verdict"] == "not_detected" and v.loc[2, "n_judged"] == 2
    assert v.loc[3, "verdict"] == "cannot_judge"
    rates = case_rates(v.reset_index())
    assert (rates.loc[0, "n_cases"], rates.loc[0, "n"], rates.loc[0, "k"], rates.loc[0, "n_cannot_judge"]) == (3, 2, 1, 1)


def _duplicate_reps(res: pd.DataFrame, times: int) -> pd.DataFrame:
    k = res["rep"].max() + 1
    return pd.concat([res.assign(rep=res["rep"] + i * k) for i in range(times)], ignore_index=True)


@pytest.mark.parametrize("rule", [DetectionRule(), pytest.param(DetectionRule(rule="statistical", family="case"),
                                                                 marks=pytest.mark.slow)])
def test_repeating_the_same_cases_does_not_shrink_the_suite_comparison_p(rule):
    base = campaign(1 if not rule.statistical else 5, seed=7, shift={"systematic": 150.0, "random": 400.0})
    cmps = []
    times_list = (1, 2) if rule.statistical else (1, 4)
    for times in times_list:
        res = _duplicate_reps(base, times)
        cmps.append(compare_suites_by_case(rule_verdicts(res, outcomes(res, rule=rule), rule=rule)))
    # the paper rule's majority is unchanged by duplicates; the statistical rule's p values only fall with
    # more pairs, but the comparison counts cases, so its n never grows with K
    if not rule.statistical:
        np.testing.assert_array_equal(cmps[0]["p"].to_numpy(), cmps[1]["p"].to_numpy())
    assert (cmps[1]["n_a"] == 12).all() and (cmps[1]["n_b"] == 12).all()


def test_gee_independence_matches_a_hand_computed_sandwich():
    # 4 clusters (runs), cases of two suites in each, outcomes correlated within a run
    y = np.array([1, 1, 0, 1, 0, 0, 1, 0, 1, 1, 1, 0, 0, 0, 0, 1, 0, 1, 1, 0])
    x = np.array([1, 1, 1, 0, 0, 1, 1, 0, 0, 0, 1, 1, 1, 0, 0, 1, 1, 1, 0, 0])
    g = np.repeat([1, 2, 3, 4], 5)
    coef, se, p = gee_suite_test(y, x, g, working="independence")
    # independence GEE = logistic MLE: the log odds ratio of the pooled 2 x 2 table
    ka, na, kb, nb = y[x == 1].sum(), (x == 1).sum(), y[x == 0].sum(), (x == 0).sum()
    assert coef == pytest.approx(math.log(ka / (na - ka) / (kb / (nb - kb))))
    # sandwich A^-1 B A^-1 with B summed over clusters
    X = np.c_[np.ones_like(x), x].astype(float)
    mu = np.where(x == 1, ka / na, kb / nb)
    A = (X * (mu * (1 - mu))[:, None]).T @ X
    U = np.array([X[g == c].T @ (y[g == c] - mu[g == c]) for c in np.unique(g)])
    Ai = np.linalg.inv(A)
    V = Ai @ (U.T @ U) @ Ai
    assert se == pytest.approx(math.sqrt(V[1, 1]), rel=1e-6)
    assert p == pytest.approx(2 * norm.sf(abs(coef) / se), rel=1e-6)
    ex = gee_suite_test(y, x, g)
    assert ex is not None and 0 < ex[2] < 1


def test_separation_falls_back_to_the_cluster_bootstrap_and_degenerate_tables_leave_holm():
    rows = []
    for run in (1, 2, 3):
        for case in range(1, 5):
            for suite, det, also in (("systematic", False, False), ("random", True, True), ("fixed", False, False)):
                rows.append({"suite": suite, "run": run, "case": case, "fault": "f", "rule": "paper",
                             "verdict": "detected" if det else "not_detected"})
    v = pd.DataFrame(rows)
    cmp = compare_suites_by_case(v).set_index(["suite_a", "suite_b"])
    assert cmp.loc[("systematic", "fixed"), "method"] == "degenerate"
    assert np.isnan(cmp.loc[("systematic", "fixed"), "p"]) and np.isnan(cmp.loc[("systematic", "fixed"), "p_holm"])
    sep = cmp.loc[("systematic", "random")]
    assert sep["method"] == "cluster_bootstrap" and sep["p"] < 0.05
    # Holm over the two informative comparisons only
    informative = cmp[cmp["method"] != "degenerate"]
    np.testing.assert_allclose(informative["p_holm"], multipletests(informative["p"], method="holm")[1])


def test_paper_comparison_verdicts_on_constructed_counts():
    paper = pd.DataFrame({"suite": ["a", "b", "c"], "fault": ["f"] * 3, "paper_k": [15, 4, 2], "paper_n": [15] * 3})
    this = pd.DataFrame({"suite": ["a", "b", "c"], "fault": ["f"] * 3, "k": [10, 40, 2], "n": [150, 150, 15]})
    out = compare_with_paper(paper, this).set_index("suite")
    assert out.loc["a", "verdict"] == "differs"  # 15/15 vs 10/150
    assert out.loc["a", "p"] == pytest.approx(boschloo_exact([[15, 0], [10, 140]]).pvalue)
    # 4/15 vs 40/150: the same rate; but 15 cases cannot detect differences below the margin
    assert out.loc["b", "p"] > 0.05 and out.loc["b", "detectable_difference"] > AGREEMENT_MARGIN
    assert out.loc["b", "verdict"] == "inconclusive"
    # with large samples on both sides the same rates agree
    big = compare_with_paper(paper.assign(paper_k=[150, 40, 20], paper_n=150), this.assign(k=[150, 40, 20], n=150))
    assert (big["verdict"] == "agrees").all()


def test_detectable_difference_has_the_stated_power():
    from statsmodels.stats.power import NormalIndPower
    from statsmodels.stats.proportion import proportion_effectsize

    d = detectable_difference(0.3, 40, 60)
    power = [NormalIndPower().power(abs(proportion_effectsize(0.3 + s * d, 0.3)), nobs1=40, ratio=1.5, alpha=0.05)
             for s in (-1, 1)]
    assert max(power) == pytest.approx(0.8, abs=1e-4)  # the nearer direction reaches 80 %, the other is beyond
    assert detectable_difference(0.5, 1, 1) == math.inf


def test_replica_false_alarms_count_aa_pairs_and_cluster_by_case():
    rng = np.random.default_rng(5)
    rows = []
    for case in range(1, 7):
        for rep in range(6):
            b = rng.normal(200, 30)
            rows += [job(1, "random", case, "baseline", rep, b),
                     job(1, "random", case, REPLICA, rep, b + (400.0 if case == 1 and rep < 3 else rng.normal(0, 30)))]
    res = frame(rows)
    fa = replica_false_alarms(res, outcomes(res), rule=DetectionRule()).set_index(["rule", "suite"])
    paper = fa.loc[("paper", "all")]
    assert (paper["n_pairs"], paper["flagged"], paper["n_cases"]) == (36, 3, 6)
    assert paper["high"] > 3 / 36 and paper["design_effect"] > 1
    stat = fa.loc[("statistical", "all")]
    assert stat["n_pairs"] == 6 and stat["flagged"] <= 1
