"""Mutation analysis: scores with exact intervals, McNemar."""


import numpy as np
import pandas as pd
import pytest
from scipy.stats import beta, binomtest

from faultlab.analysis.mutation import OBSERVED_EQUIVALENT, compare_suites, mutant_outcomes, mutation_scores
from faultlab.inference.intervals import clopper_pearson
from tests.stats.synthetic import paired_frame


def _outcomes(table: dict) -> pd.DataFrame:
    rows = [dict(mutant=m, unit=u, operator=o, run=1, suite=s, outcome=out, survival="")
            for (m, u, o), per_suite in table.items() for s, out in per_suite.items()]
    return pd.DataFrame(rows)


def test_scores_count_crash_and_timeout_as_kills_and_leave_out_unjudged_mutants():
    o = _outcomes({("m1", "u1", "arith"): {"fixed": "killed", "random": "killed"},
                   ("m2", "u1", "arith"): {"fixed": "survived", "random": "crash"},
                   ("m3", "u2", "index"): {"fixed": "timeout", "random": "survived"},
                   ("m4", "u2", "index"): {"fixed": "cannot_judge", "random": "survived"},
                   ("m5", "u2", "index"): {"fixed": "equivalent", "random": "equivalent"}})
    s = mutation_scores(o).set_index(["suite", "by", "group"])
    assert tuple(s.loc[("fixed", "all", "all"), ["killed", "judged"]]) == (2, 3)   # m1, m3 of m1-m3
    assert tuple(s.loc[("random", "all", "all"), ["killed", "judged"]]) == (2, 4)  # m1, m2 of m1-m4
    assert tuple(s.loc[("random", "unit", "u2"), ["killed", "judged"]]) == (0, 2)
    assert s.loc[("fixed", "operator", "index"), "score"] == 1.0
    assert s.loc[("random", "all", "all"), "ci_low"] == pytest.approx(beta.ppf(0.025, 2, 3))


def test_mcnemar_exact_equals_the_binomial_test_on_the_discordant_pairs():
    rng = np.random.default_rng(5)
    table = {}
    for i in range(60):
        a, b = rng.random() < 0.7, rng.random() < 0.4
        table[(f"m{i}", "u", "o")] = {"systematic": "killed" if a else "survived",
                                      "fixed": "killed" if b else "survived"}
    o = _outcomes(table)
    row = compare_suites(o, ["systematic", "fixed"]).iloc[0]
    ka = o[o.suite == "systematic"].set_index("mutant")["outcome"] == "killed"
    kb = o[o.suite == "fixed"].set_index("mutant")["outcome"] == "killed"
    a_only, b_only = int((ka & ~kb).sum()), int((~ka & kb).sum())
    assert (row["a_only"], row["b_only"], row["n"]) == (a_only, b_only, 60)
    assert row["p"] == pytest.approx(binomtest(a_only, a_only + b_only, 0.5).pvalue, rel=1e-12)



def _paired(n_both, a_only, b_only, neither):
    table, i = {}, 0
    for count, (a, b) in ((n_both, ("killed", "killed")), (a_only, ("killed", "survived")),
                          (b_only, ("survived", "killed")), (neither, ("survived", "survived"))):
        for _ in range(count):
            table[(f"m{i}", "u", "o")] = {"systematic": a, "fixed": b}
            i += 1
    return _outcomes(table)


def test_the_score_difference_interval_is_the_bonferroni_pair_of_exact_intervals_and_covers():
    a_only, b_only, n = 30, 5, 200
    row = compare_suites(_paired(150, a_only, b_only, n - 150 - a_only - b_only), ["systematic", "fixed"]).iloc[0]
    assert row["diff"] == pytest.approx((a_only - b_only) / n)
    # Clopper-Pearson bounds from the beta quantiles, each share at 1 - 0.05 / 2
    a_lo, a_hi = beta.ppf(0.0125, a_only, n - a_only + 1), beta.ppf(0.9875, a_only + 1, n - a_only)
    b_lo, b_hi = beta.ppf(0.0125, b_only, n - b_only + 1), beta.ppf(0.9875, b_only + 1, n - b_only)
    assert (row["ci_low"], row["ci_high"]) == (pytest.approx(a_lo - b_hi), pytest.approx(a_hi - b_lo))
    assert row["ci_low"] > 0 and row["p"] < 0.05               # McNemar rejects as well
    assert row["diff"] < row["equivalent_within"] < row["ci_high"]   # TOST at 5 %: the narrower 90 % interval
    # coverage of the true difference on simulated mutant samples (multinomial discordance), at least 95 %
    rng = np.random.default_rng(11)
    probs = np.array([0.7, 0.12, 0.05, 0.13])                 # both, a only, b only, neither
    covered = 0
    for counts in rng.multinomial(120, probs, size=200):
        r = compare_suites(_paired(*counts), ["systematic", "fixed"]).iloc[0]
        covered += r["ci_low"] <= probs[1] - probs[2] <= r["ci_high"]
    assert covered >= 0.95 * 200 - 3


def test_without_a_discordant_mutant_the_interval_is_the_exact_bound_not_zero_width():
    row = compare_suites(_paired(180, 0, 0, 20), ["systematic", "fixed"]).iloc[0]
    bound95 = beta.ppf(1 - 0.025 / 2, 1, 200)   # Clopper-Pearson upper bound of 0 of 200 at 1 - 0.05 / 2
    bound90 = beta.ppf(1 - 0.05 / 2, 1, 200)
    assert row["diff"] == 0 and row["p"] == 1
    assert (row["ci_low"], row["ci_high"]) == (pytest.approx(-bound95), pytest.approx(bound95))
    assert row["equivalent_within"] == pytest.approx(bound90) and 0 < bound90 < bound95


def test_several_runs_of_a_mutant_leave_the_interval_unjudged():
    o = _paired(10, 3, 1, 6)
    o = pd.concat([o, o.assign(run=2)], ignore_index=True)
    row = compare_suites(o, ["systematic", "fixed"]).iloc[0]
    assert row["n"] == 40 and np.isnan(row["ci_low"]) and np.isnan(row["equivalent_within"])


def test_survivors_split_into_equivalent_and_inconclusive_and_identical_maps_leave_the_denominator():
    k = 8
    rng = np.random.default_rng(1)
    parts = []
    for case in (1, 2):
        parts.append(paired_frame({"mutant:same": np.zeros(k), "mutant:tiny": rng.normal(0.0, 0.3, k),
                             "mutant:noisy": rng.normal(0.0, 30.0, k), "mutant:kill": np.full(k, 40.0)},
                            k, case=case))
    df = pd.concat(parts, ignore_index=True)
    sel = {"alpha": 0.05, "direction": "either", "run": ["same", "tiny", "noisy", "kill"], "screened": {},
           "unit": {}, "operator": {}, "represented_by": {}}
    o = mutant_outcomes(df, sel).set_index("mutant")
    assert o.loc["same", "outcome"] == OBSERVED_EQUIVALENT
    # baseline errors ~105 mm: margin 10.5 mm; noise 0.3 mm -> TOST succeeds on both cases; 30 mm -> it cannot
    assert (o.loc["tiny", "outcome"], o.loc["tiny", "survival"]) == ("survived", "equivalent")
    assert (o.loc["noisy", "outcome"], o.loc["noisy", "survival"]) == ("survived", "inconclusive")
    assert o.loc["kill", "outcome"] == "killed" and o.loc["kill", "direction"] == "worse"
    assert o.loc["kill", "median_diff_mm"] == pytest.approx(40.0)
    s = mutation_scores(o.reset_index()).set_index(["suite", "by", "group"]).loc[("fixed", "all", "all")]
    assert (s["killed"], s["judged"], s["equivalent_observed"]) == (1, 3, 1)
    assert (s["survived_equivalent"], s["survived_inconclusive"]) == (1, 1)


def test_a_pair_stopped_early_is_not_killed_on_its_case_and_its_detectable_shift_uses_the_pairs_it_used():
    from faultlab.stats.verdict import case_verdicts
    k = 10
    rng = np.random.default_rng(4)
    noise = rng.normal(0.0, 5.0, k)
    df = paired_frame({"mutant:noisy": noise, "mutant:kill": np.full(k, 40.0)}, k)
    # the noisy mutant stopped for futility after 5 repetitions: its rows 5..9 were never run
    df = df[~((df["variant"] == "mutant:noisy") & (df["rep"] >= 5))].reset_index(drop=True)
    sel = {"alpha": 0.05, "direction": "either", "run": ["noisy", "kill"], "screened": {}, "unit": {},
           "operator": {}, "represented_by": {}}
    stops = [{"run": 1, "suite": "fixed", "case": 1, "variant": "mutant:noisy", "repetitions": 5, "reason": "futile"}]
    o = mutant_outcomes(df, sel, stops=stops).set_index("mutant")
    # without the stop record 5 pairs are too few for a two-sided test at 0.05 (cannot_judge, unscored)
    assert mutant_outcomes(df, sel).set_index("mutant").loc["noisy", "outcome"] == "cannot_judge"
    assert o.loc["noisy", "outcome"] == "survived"
    assert (o.loc["noisy", "reps_used"], o.loc["noisy", "n_stopped"]) == ("5", 1)
    assert (o.loc["kill", "outcome"], o.loc["kill", "reps_used"], o.loc["kill", "n_stopped"]) == ("killed", "10", 0)
    # the smallest detectable shift of the 5 pairs it used at the per-case level: none (2 * 2^-5 > 0.05)
    ref = case_verdicts(df, alpha=0.05, direction="either").set_index("fault").loc["mutant:noisy", "mde_mm"]
    assert o.loc["noisy", "min_mde_mm"] == ref == np.inf
