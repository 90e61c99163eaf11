"""The suite-strategy registry: every name dispatches to its builder, built-in or declared by a distribution
(faultlab.space.registry)."""

import numpy as np
import pytest

from faultlab.errors import ConfigError
from faultlab.plugins import PluginLoad
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
from faultlab.space import registry
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
    found = registry.load_strategy_plugins(warn=False)
    monkeypatch.setattr(registry, "load_strategy_plugins",
                        lambda **kw: PluginLoad(items=found.items + (strategy,), errors=found.errors))
    return strategy


def test_the_shipped_strategies_are_registered_under_their_names():
    assert SUITE_KINDS == ("systematic", "random", "fixed", "base-choice", "pairwise", "3-wise", "4-wise",
                           "effect-guided")
    assert all(name == s.name and s.strength == t_wise_strength(name) for name, s in STRATEGIES.items())


def test_unknown_kinds_are_refused_naming_the_known_ones():
    with pytest.raises(ConfigError, match="unknown suite strategy 'corner'. Known strategies: systematic, random, fixed"):
        build_suite("corner", SPACE, rng=np.random.default_rng(0))
    with pytest.raises(ConfigError, match="unknown suite strategy '5-wise'"):
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


@pytest.mark.slow
def test_a_strategy_from_an_installed_distribution_runs_in_parallel_workers(tmp_path):
    """The example plugin's ``smallest-first`` suite, drawn by ``faultlab run --jobs 2`` from the installed
    command: every job runs, and the suite's cases come smallest map first."""
    import subprocess

    from faultlab.runner import load_results
    from tests.runner.suts import write_experiment
    from tests.slam.test_registry import _installed_command

    assert "smallest-first" in suite_kinds(), \
        "install the example distribution: pip install -e examples/faultlab-example-plugin"
    toml = write_experiment(tmp_path / "smallest.toml", runs=1, repetitions=2, suites={"smallest-first": 4},
                            variants=["baseline"], slam={"name": "dead_reckoning"})
    done = subprocess.run([_installed_command(), "run", str(toml), "--out", str(tmp_path / "out"), "--jobs", "2",
                           "--backend", "loky", "--no-progress"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    rows = load_results(tmp_path / "out")
    assert len(rows) == 8 and (rows["status"] == "ok").all(), rows[["case", "rep", "status"]]
    sizes = rows[rows["rep"] == 0].sort_values("case")["map_size"].to_numpy()
    assert (np.diff(sizes) >= 0).all()
