"""The suite-strategy registry: every name dispatches to its builder, and a new strategy is one entry
(faultlab.space.registry)."""

import numpy as np
import pytest

from faultlab.errors import ConfigError
from faultlab.runner.experiment import parse_experiment
from faultlab.space import (
    STRATEGIES,
    SUITE_KINDS,
    SuiteStrategy,
    build_suite,
    min_suite_size,
    suite_criteria,
    suite_kinds,
    t_wise_strength,
    table1_space,
)
from faultlab.space.choice import cases_from_classes
from faultlab.space.coverage import class_matrix
from faultlab.space.strategies import base_choice_rows

SPACE = table1_space()


def _base_only(space, *, rng, n_cases=None):
    """Every case in the base classes of base choice (values still drawn inside the classes)."""
    base = base_choice_rows(space)[0][:1]
    n = space.min_cases if n_cases is None else int(n_cases)
    return cases_from_classes(space, np.repeat(base, n, axis=0), rng=rng)


@pytest.fixture
def base_only(monkeypatch):
    strategy = SuiteStrategy("base-only", "every case in the base classes", _base_only)
    monkeypatch.setitem(STRATEGIES, strategy.name, strategy)
    return strategy


def test_the_shipped_strategies_are_registered_under_their_names():
    assert SUITE_KINDS == ("systematic", "random", "fixed", "base-choice", "pairwise", "3-wise", "4-wise",
                           "effect-guided")
    assert all(name == s.name and s.strength == t_wise_strength(name) for name, s in STRATEGIES.items())


def test_unknown_kinds_are_refused_naming_the_known_ones():
    with pytest.raises(ConfigError, match="unknown suite kind 'corner'.*systematic, random, fixed"):
        build_suite("corner", SPACE, rng=np.random.default_rng(0))
    with pytest.raises(ConfigError, match="unknown suite kind '5-wise'"):
        min_suite_size("5-wise", SPACE)


def test_a_registered_strategy_builds_through_the_normal_entry_points(base_only):
    assert suite_kinds()[-1] == "base-only"
    cases = build_suite("base-only", SPACE, rng=np.random.default_rng(3), n_cases=4)
    base = base_choice_rows(SPACE)[0][0]
    np.testing.assert_array_equal(class_matrix(cases, SPACE), np.tile(base, (4, 1)))
    assert len(build_suite("base-only", SPACE, rng=np.random.default_rng(3))) == SPACE.min_cases
    # same generator seed, same suite
    again = build_suite("base-only", SPACE, rng=np.random.default_rng(3), n_cases=4)
    assert [c.values for c in again] == [c.values for c in cases]
    assert min_suite_size("base-only", SPACE) is None
    # the default criteria: pairwise coverage, the common yardstick
    assert [str(m).split(":")[0] for m in suite_criteria("base-only", cases, SPACE)] == ["pairwise coverage"]
    # an experiment file may name it
    exp = parse_experiment({"seed": 1, "suites": {"base-only": 2}}, source="test.toml")
    assert [(s.kind, s.n_cases) for s in exp.suites] == [("base-only", 2)]


def test_without_the_registration_the_experiment_is_refused():
    with pytest.raises(ConfigError, match="base-only"):
        parse_experiment({"seed": 1, "suites": {"base-only": 2}}, source="test.toml")
