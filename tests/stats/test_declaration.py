"""Declared analyses: validation of the [declaration] table, what it declares, and its record."""

from __future__ import annotations

import pytest

from faultlab.errors import ConfigError
from faultlab.stats.declaration import Declaration, declaration_from

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
