"""Mutation campaign and analysis: statistical kills, early stopping, resume, scores, McNemar."""

import math

import numpy as np
import pandas as pd
import pytest
from scipy.stats import beta, binomtest

from faultlab.analysis.mutation import (OBSERVED_EQUIVALENT, analyse_mutation, clopper_pearson, compare_suites,
                                        load_mutation_experiment, mutant_outcomes, mutation_scores, run_mutation,
                                        suite_kills)
from faultlab.stats.verdict import min_pairs
from faultlab.errors import ConfigError
from faultlab.runner.store import load_results

SIGN_FLIP = "motion_model:arithmetic:9"  # turns the wrong way: the map is ruined
EQUIVALENT = "motion_model:index:3"      # screened equivalent: never runs


def _frame(diffs: dict, k: int, *, status: dict | None = None, case: int = 1) -> pd.DataFrame:
    rng = np.random.default_rng(0)
    base = 100 + rng.random(k) * 10
    rows = [dict(run=1, suite="fixed", case=case, variant="baseline", rep=r, status="ok", rms_mm=base[r],
                 emd_mm=base[r]) for r in range(k)]
    for v, d in diffs.items():
        for r in range(k):
            st = (status or {}).get(v, "ok")
            rows.append(dict(run=1, suite="fixed", case=case, variant=v, rep=r, status=st,
                             rms_mm=base[r] + d[r] if st == "ok" else math.nan, emd_mm=math.nan))
    return pd.DataFrame(rows)


def test_case_kill_classes_follow_the_exact_paired_test_at_the_case_level():
    k = 7  # one-sided 2^-7 = 0.0078 <= 0.01 (the paper's notion, labelled "worse")
    df = _frame({"mutant:a": np.full(k, 50.0), "mutant:b": np.array([50.0] * 6 + [-5.0]),
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


def test_a_mutant_that_only_improves_the_map_is_killed_by_the_two_sided_rule():
    k = min_pairs(0.01, alternative="two-sided")
    assert k == 8
    df = _frame({"mutant:better": np.full(k, -50.0), "mutant:worse": np.full(k, 50.0)}, k)
    two = suite_kills(df, case_alpha=0.01).set_index("fault")
    assert two.loc["mutant:better", "kill"] == "killed" and two.loc["mutant:better", "direction"] == "better"
    assert two.loc["mutant:worse", "kill"] == "killed" and two.loc["mutant:worse", "direction"] == "worse"
    assert two.loc["mutant:better", "p"] == 2.0 ** -7
    one = suite_kills(df, case_alpha=0.01, direction="worse").set_index("fault")
    assert one.loc["mutant:better", "kill"] == "" and one.loc["mutant:worse", "kill"] == "killed"


def test_survivors_split_into_equivalent_and_inconclusive_and_identical_maps_leave_the_denominator():
    k = 8
    rng = np.random.default_rng(1)
    parts = []
    for case in (1, 2):
        parts.append(_frame({"mutant:same": np.zeros(k), "mutant:tiny": rng.normal(0.0, 0.3, k),
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


def test_clopper_pearson_matches_the_beta_quantiles():
    for k, n in [(0, 10), (3, 10), (10, 10), (57, 150)]:
        lo, hi = clopper_pearson(k, n)
        assert lo == pytest.approx(0.0 if k == 0 else beta.ppf(0.025, k, n - k + 1), abs=1e-12)
        assert hi == pytest.approx(1.0 if k == n else beta.ppf(0.975, k + 1, n - k), abs=1e-12)


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


TINY = """
seed = 3
runs = 1
n_steps = 30
repetitions = 7
timeout_s = 60.0
[suites]
random = 2
fixed = 1
[slam]
name = "fastslam"
particles = 5
[mutation]
ids = ["{kill}", "{eq}"]
"""


def test_too_few_repetitions_for_the_per_case_level_is_refused(tmp_path):
    f = tmp_path / "m.toml"
    f.write_text(TINY.format(kill=SIGN_FLIP, eq=EQUIVALENT))
    # random = 2 cases: a case is judged at 0.025, which the two-sided test reaches from K = 7
    with pytest.raises(ConfigError, match="K = 7"):
        load_mutation_experiment(f, repetitions=6)


@pytest.mark.slow
def test_a_killed_mutant_stops_early_an_equivalent_one_never_runs_and_a_rerun_resumes(tmp_path):
    f = tmp_path / "m.toml"
    f.write_text(TINY.format(kill=SIGN_FLIP, eq=EQUIVALENT))
    mexp = load_mutation_experiment(f)
    assert mexp.selection.run == (SIGN_FLIP,) and mexp.selection.screened == {EQUIVALENT: "equivalent"}
    first = run_mutation(mexp, tmp_path / "out", jobs=2, progress=False)
    df = load_results(tmp_path / "out")
    assert not df["variant"].str.contains(EQUIVALENT).any()
    mutant = df[df["variant"] == f"mutant:{SIGN_FLIP}"]
    # killed on case 1 of the random suite: case 2 never runs (nor its baseline: nothing is left to judge)
    assert set(zip(mutant["suite"], mutant["case"])) == {("random", 1), ("fixed", 1)}
    assert len(df) == 2 * 2 * 7 and first.n_skipped_early == 2 * 7
    a = analyse_mutation(tmp_path / "out")
    o = a.outcomes.set_index(["mutant", "suite"])
    assert o.loc[(SIGN_FLIP, "random"), "outcome"] in ("killed", "crash")
    assert o.loc[(SIGN_FLIP, "random"), "killing_case"] == 1
    assert o.loc[(EQUIVALENT, "fixed"), "outcome"] == "equivalent"
    again = run_mutation(mexp, tmp_path / "out", jobs=2, progress=False)
    assert again.n_new == 0 and len(load_results(tmp_path / "out")) == len(df)
    a.save(tmp_path / "saved")
    back = type(a).load(tmp_path / "saved")
    pd.testing.assert_frame_equal(back.scores, a.scores, check_dtype=False)


def test_the_shipped_mutation_experiment_has_the_fewest_repetitions_its_two_sided_kills_need():
    mexp = load_mutation_experiment("mutation")
    assert mexp.direction == "either"
    n = max(s.n_cases for s in mexp.experiment.suites)
    assert mexp.experiment.repetitions == min_pairs(mexp.alpha / n, alternative="two-sided")
