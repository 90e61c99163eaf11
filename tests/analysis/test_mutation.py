"""Mutation analysis: scores with exact intervals, McNemar."""

import numpy as np
import pandas as pd
import pytest
from scipy.stats import beta, binomtest

from faultlab.analysis.mutation import clopper_pearson, compare_suites, mutation_scores


def test_clopper_pearson_matches_the_beta_quantiles():
    for k, n in [(0, 10), (3, 10), (10, 10), (57, 150)]:
        lo, hi = clopper_pearson(k, n)
        assert lo == pytest.approx(0.0 if k == 0 else beta.ppf(0.025, k, n - k + 1), abs=1e-12)
        assert hi == pytest.approx(1.0 if k == n else beta.ppf(0.975, k + 1, n - k), abs=1e-12)


def _outcomes(table: dict) -> pd.DataFrame:
    rows = [dict(mutant=m, unit=u, operator=o, run=1, suite=s, outcome=out)
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
