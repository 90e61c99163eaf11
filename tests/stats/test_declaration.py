"""Declared analyses: validation of the [declaration] table, what it declares, and its record."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats
from statsmodels.stats.multitest import multipletests
from statsmodels.stats.weightstats import ttost_paired

from faultlab.errors import ConfigError
from faultlab.stats.declaration import Declaration, declaration_from, declared_table, label_rows

TABLE = {"alpha": 0.05, "sidedness": "two-sided", "family": "holm", "unit": "run",
         "analyses": [{"table": "detection_means", "strategy_a": "systematic", "strategy_b": "random"},
                      {"table": "detection_means", "strategy_a": "systematic", "strategy_b": "random",
                       "test": "equivalence", "margin": 0.05},
                      {"table": "detection_comparisons", "variant": "naive_resampling"}]}


def test_a_declaration_reads_back_from_its_record_and_says_what_it_declares():
    d = declaration_from(TABLE, source="s.toml", recorded="before the run")
    assert d.confirmatory and d.unit == "run" and len(d.analyses) == 3
    assert declaration_from(d.to_dict(), source="store") == d  # the stored record is the declaration
    assert d.declares("detection_means", "random", "systematic")  # either order
    assert not d.declares("detection_means", "systematic", "pairwise")
    assert d.declares("detection_comparisons", "pairwise", "random", variant="naive_resampling")  # every pair
    assert not d.declares("detection_comparisons", "pairwise", "random", variant="paper_aliasing")
    assert not d.declares("comparisons", "systematic", "random", size=5)
    assert d.margin_declared("detection_means") and not d.margin_declared("detection_comparisons")
    assert d.analyses[1].describe() == "detection_means: systematic - random, equivalence within ±0.05"


def test_a_table_cannot_claim_it_was_declared_before_the_run():
    # without a recorded time from `study run`, a declaration is one added after the run
    assert not declaration_from(TABLE, source="s.toml").confirmatory
    assert not declaration_from(TABLE, source="s.toml", recorded="after the run").confirmatory


@pytest.mark.parametrize("change, match", [
    ({"analyses": []}, "analyses must be a non-empty list"),
    ({"alpha": 1.5}, "alpha must lie in"),
    ({"unit": "pool"}, "unit must be one of"),
    ({"sidedness": "up"}, "sidedness must be one of"),
    ({"family": "none"}, "family is \"none\" but 3 analyses"),
    ({"margins": 0.05}, "margins is not a known key"),
    ({"analyses": [{"table": "detection_means", "test": "equivalence"}]}, r"analyses\[0\].margin is required"),
    ({"analyses": [{"table": "detection_means", "margin": 0.05}]}, "belongs to an equivalence test"),
    ({"analyses": [{"table": "detection_means", "test": "equivalence", "margin": 0}]}, "margin"),
    ({"analyses": [{"table": "kill_matrix"}]}, "table must be one of"),
    ({"analyses": [{"table": "detection_means", "strategy_a": "systematic"}]}, "two different strategies"),
    ({"analyses": [{"table": "detection_means", "variant": "naive_resampling"}]}, "detection_comparisons table only"),
    ({"analyses": [{"table": "detection_means", "size": 5}]}, "comparisons table only"),
])
def test_a_malformed_declaration_is_one_error_naming_the_key(change, match):
    with pytest.raises(ConfigError, match=match):
        declaration_from(TABLE | change, source="s.toml")


def test_the_default_declaration_fields():
    d = Declaration(analyses=())
    assert (d.alpha, d.sidedness, d.family, d.unit, d.confirmatory) == (0.05, "two-sided", "holm", "run", True)


def _scores(shift: float, runs: int = 6, rng=None):
    rng = rng or np.random.default_rng(0)
    run_effect = rng.normal(0, 0.1, runs)
    rows = []
    for r in range(runs):
        for s, d in (("systematic", shift), ("random", 0.0)):
            for _ in range(5):
                rows.append((s, r + 1, float(np.clip(0.5 + run_effect[r] + d + rng.normal(0, 0.05), 0, 1))))
    strategy, run, score = map(np.array, zip(*rows))
    return score, strategy, run


def test_the_declared_analyses_are_the_paired_t_test_and_tost_over_runs_holm_over_the_family():
    d = declaration_from(TABLE, source="s.toml", recorded="before the run")
    score, strategy, run = _scores(0.03)
    t = declared_table(d, score=score, strategy=strategy, run=run)
    means = pd.DataFrame({"s": strategy, "r": run, "x": score}).groupby(["r", "s"])["x"].mean().unstack()
    diff = means["systematic"] - means["random"]
    ref = stats.ttest_1samp(diff, 0)
    first, second, third = t.iloc[0], t.iloc[1], t.iloc[2]
    assert first["estimate"] == pytest.approx(diff.mean()) and first["p"] == pytest.approx(ref.pvalue)
    assert (first["estimate_low"], first["estimate_high"]) == pytest.approx(tuple(ref.confidence_interval(0.95)))
    assert second["p"] == pytest.approx(ttost_paired(means["systematic"].to_numpy(), means["random"].to_numpy(),
                                                     -0.05, 0.05)[0])
    assert second["level"] == 0.9 and first["runs"] == 6 and first["status"] == "confirmatory"
    holm = multipletests([first["p"], second["p"]], method="holm")[1]
    assert [first["p_family"], second["p_family"]] == pytest.approx(holm.tolist())
    assert first["decision"] == ("shown: systematic > random" if holm[0] <= 0.05 else "no difference shown")
    assert second["decision"] == ("shown within ±5 pp" if holm[1] <= 0.05 else "not shown within ±5 pp")
    assert np.isnan(third["p"]) and third["decision"] == "see detection_comparisons.csv (rows marked confirmatory)"
    # a large planted difference is shown, and not within the margin
    t = declared_table(d, score=_scores(0.3)[0], strategy=strategy, run=run)
    assert t["decision"].tolist()[:2] == ["shown: systematic > random", "not shown within ±5 pp"]


def test_the_case_as_declared_unit_is_welch_and_rows_are_labelled_by_the_declaration():
    d = declaration_from(TABLE | {"unit": "case"}, source="s.toml")
    score, strategy, run = _scores(0.03)
    t = declared_table(d, score=score, strategy=strategy, run=run)
    ref = stats.ttest_ind(score[strategy == "systematic"], score[strategy == "random"], equal_var=False)
    assert t.iloc[0]["p"] == pytest.approx(ref.pvalue) and np.isnan(t.iloc[0]["runs"])
    assert (t["status"] == "declared after the run").all()
    frame = pd.DataFrame({"strategy_a": ["systematic", "random", "pairwise"],
                          "strategy_b": ["random", "pairwise", "systematic"]})
    assert label_rows(frame, d, "detection_means")["analysis"].tolist() == [
        "declared after the run", "exploratory", "exploratory"]
    assert label_rows(frame, None, "detection_means")["analysis"].tolist() == ["exploratory"] * 3
    assert declared_table(None, score=score, strategy=strategy, run=run).empty
