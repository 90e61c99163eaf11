"""Mapping SALib's unit designs onto the parameter space."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from faultlab.errors import ConfigError
from faultlab.space import FIXED_VALUES, PARAMETER_NAMES, space_from_mapping, table1_space
from faultlab.space.design import design_size, morris_design, sobol_design, unit_to_values

SPACE = table1_space()


@settings(max_examples=200, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=11, max_size=11))
def test_every_unit_point_is_a_case_inside_a_class(u):
    case, repaired = unit_to_values(SPACE, PARAMETER_NAMES, np.array(u))
    assert not repaired
    assert min(case.classes.values()) >= 0
    # variance and bias: both components from the same class, same relative position
    for name in ("variance", "bias"):
        c = SPACE[name].classes[case.classes[name]]
        (dlo, dhi), (alo, ahi) = c.bounds
        if dhi > dlo:
            t = (case.values[f"{name}_distance"] - dlo) / (dhi - dlo)
            assert case.values[f"{name}_angle"] == pytest.approx(alo + t * (ahi - alo))


def test_discrete_and_categorical_factors_cut_the_unit_interval_into_equal_bins():
    def value(name, u):
        pos = PARAMETER_NAMES.index(name)
        x = np.full(11, 0.5)
        x[pos] = u
        return unit_to_values(SPACE, PARAMETER_NAMES, x)[0].values[name]

    assert [value("rotation_error", u) for u in (0.0, 0.3, 0.34, 0.66, 0.67, 1.0)] == \
        [-2 * math.pi, -2 * math.pi, 0.0, 0.0, 2 * math.pi, 2 * math.pi]
    assert [value("inactivity", u) for u in (0.0, 1 / 3, 2 / 3, 1.0)] == [0, 0, 2000, 2000]
    assert [value("directionality", u) for u in (0.2, 0.8)] == ["random", "loop"]
    # equal shares per class: map_size small/medium/large each a third
    assert value("map_size", 0.0) == 4.0 and value("map_size", 1 / 3) == pytest.approx(16.0)
    assert value("map_size", 0.5) == pytest.approx(58.0) and value("map_size", 1.0) == 400.0


def test_point_classes_are_the_ends_of_their_neighbours():
    x = np.full(11, 0.5)
    x[PARAMETER_NAMES.index("variance")] = 0.0
    case, _ = unit_to_values(SPACE, PARAMETER_NAMES, x)
    assert SPACE["variance"].class_names[case.classes["variance"]] == "none"
    assert SPACE["bias"].class_names[case.classes["bias"]] == "none"  # u = 0.5 is (0, 0)


def test_parameters_outside_the_design_keep_the_fixed_values():
    d = morris_design(SPACE, rng=np.random.default_rng(0), trajectories=3, factors=["map_size", "symmetry"])
    assert d.n_points == design_size("morris", n_factors=2, base=3) == 9
    for c in d.cases:
        assert c.values["step_size"] == FIXED_VALUES["step_size"]
        assert c.values["directionality"] == FIXED_VALUES["directionality"]


def test_morris_steps_change_one_factor_at_a_time():
    d = morris_design(SPACE, rng=np.random.default_rng(1), trajectories=4)
    k = len(d.factors) + 1
    for t in range(4):
        block = d.unit[t * k:(t + 1) * k]
        assert (np.count_nonzero(np.diff(block, axis=0), axis=1) == 1).all()


def test_designs_are_reproducible_from_their_generator():
    a = sobol_design(SPACE, rng=np.random.default_rng(3), base=8)
    b = sobol_design(SPACE, rng=np.random.default_rng(3), base=8)
    assert a.n_points == 8 * 13
    np.testing.assert_array_equal(a.unit, b.unit)
    assert [c.values for c in a.cases] == [c.values for c in b.cases]


def test_constraints_are_repaired_to_the_nearest_allowed_class():
    space = space_from_mapping({"constraints": {"forbid": [{"map_size": "small", "step_size": "large"}]}},
                               source="x.toml")
    d = morris_design(space, rng=np.random.default_rng(1), trajectories=10)
    assert d.repaired > 0
    assert not any(c.classes["map_size"] == 0 and c.classes["step_size"] == 2 for c in d.cases)
    # the repair moves step_size (last in parameter order) to medium, its nearest allowed class
    plain = morris_design(table1_space(), rng=np.random.default_rng(1), trajectories=10)
    for a, b in zip(plain.cases, d.cases):
        if a.classes["map_size"] == 0 and a.classes["step_size"] == 2:
            assert b.classes["step_size"] == 1 and b.values["map_size"] == a.values["map_size"]


@pytest.mark.parametrize("call, match", [
    (lambda: morris_design(SPACE, rng=np.random.default_rng(0), trajectories=4, factors=["map_size", "speed"]),
     "unknown parameter 'speed'"),
    (lambda: morris_design(SPACE, rng=np.random.default_rng(0), trajectories=1), "at least 2 trajectories"),
    (lambda: morris_design(SPACE, rng=np.random.default_rng(0), trajectories=4, levels=3), "even integer"),
    (lambda: sobol_design(SPACE, rng=np.random.default_rng(0), base=12), "power of two"),
    (lambda: sobol_design(SPACE, rng=np.random.default_rng(0), base=8, factors=["bias"]), "at least two"),
])
def test_bad_designs_are_one_clear_error(call, match):
    with pytest.raises(ConfigError, match=match):
        call()


@settings(max_examples=100, deadline=None)
@given(st.sampled_from(["map_size", "landmark_density", "step_size", "symmetry", "outlier_probability",
                        "field_of_view", "variance", "bias"]), st.floats(0.0, 1.0), st.floats(0.0, 1.0))
def test_continuous_factors_are_monotone_in_their_unit_coordinate(name, a, b):
    key = SPACE[name].keys[0]
    lo, hi = sorted((a, b))
    x = np.full(11, 0.5)
    pos = PARAMETER_NAMES.index(name)
    x[pos] = lo
    v_lo = unit_to_values(SPACE, PARAMETER_NAMES, x)[0].values[key]
    x[pos] = hi
    v_hi = unit_to_values(SPACE, PARAMETER_NAMES, x)[0].values[key]
    assert v_lo <= v_hi
