"""Rendering of a mutation analysis: Markdown tables and the mutant x suite matrix."""

import numpy as np
import pandas as pd

from faultlab.analysis.mutation import MutationAnalysis, compare_suites, mutation_scores
from faultlab.report.mutation import MATRIX_CLASSES, markdown_table, matrix_figure, score_table, survivor_table


def _analysis() -> MutationAnalysis:
    rows = []
    for m, unit, outs in [("u1:a:1", "u1", ("killed", "survived")), ("u1:a:2", "u1", ("crash", "killed")),
                          ("u2:b:1", "u2", ("survived", "timeout")), ("u2:b:2", "u2", ("equivalent", "equivalent"))]:
        for suite, out in zip(("systematic", "fixed"), outs):
            survival = ("equivalent" if (m, suite) == ("u2:b:1", "systematic") else "inconclusive") \
                if out == "survived" else ""
            rows.append(dict(mutant=m, unit=unit, operator=m.split(":")[1], run=1, suite=suite, outcome=out,
                             survival=survival))
    o = pd.DataFrame(rows)
    return MutationAnalysis(outcomes=o, scores=mutation_scores(o), mcnemar=compare_suites(o, ["systematic", "fixed"]))


def test_markdown_table_has_a_header_a_rule_and_one_line_per_row():
    md = markdown_table(pd.DataFrame({"a": [1, 2], "b": ["x", "y"]}))
    assert md.splitlines() == ["| a | b |", "|---|---|", "| 1 | x |", "| 2 | y |"]


def test_score_table_shows_counts_and_the_interval_in_percent():
    t = score_table(_analysis()).set_index("suite")
    assert t.loc["systematic", "killed / judged"] == "2/3" and t.loc["fixed", "killed / judged"] == "2/3"
    assert t.loc["systematic", "score"] == "66.7 %"
    assert t.loc["systematic", "survived: equivalent / inconclusive"] == "1/0"
    assert t.loc["fixed", "survived: equivalent / inconclusive"] == "0/1"


def test_matrix_cells_carry_each_mutants_outcome_and_screened_mutants_are_not_drawn():
    fig = matrix_figure(_analysis())
    grid = np.asarray(fig.axes[0].images[0].get_array())
    codes = list(MATRIX_CLASSES)
    assert grid.shape == (3, 2)  # the equivalent mutant did not run
    labels = [t.get_text() for t in fig.axes[0].get_xticklabels()]
    assert labels == ["systematic", "fixed"]
    # rows sorted by unit then id: u1:a:1, u1:a:2, u2:b:1
    assert [[codes[int(c)] for c in row] for row in grid] == [["killed", "survived"], ["crash", "killed"],
                                                              ["survived", "timeout"]]


def test_survivor_table_lists_each_survived_pair_with_its_detectable_shift():
    a = _analysis()
    o = a.outcomes.assign(min_p=[0.01, 0.2, 0.02, 0.03, 0.5, 0.04, 1.0, 1.0],
                          min_mde_mm=[10.0, 123.4, 1, 2, 56.6, 3, np.nan, np.nan],
                          max_p_equivalence=[np.nan, 0.3, np.nan, np.nan, 0.01, np.nan, np.nan, np.nan])
    t = survivor_table(MutationAnalysis(outcomes=o, scores=a.scores, mcnemar=a.mcnemar))
    assert list(zip(t["mutant"], t["suite"], t["survival"], t["smallest p"], t["TOST p (largest)"],
                    t["detectable shift mm"])) == [("u1:a:1", "fixed", "inconclusive", "0.2", "0.3", "123"),
                                                   ("u2:b:1", "systematic", "equivalent", "0.5", "0.01", "57")]
