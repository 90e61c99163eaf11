import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from faultlab.errors import ConfigError
from faultlab.space import (
    FIXED_VALUES,
    PARAMETER_NAMES,
    Kind,
    ParameterSpace,
    load_space,
    space_from_mapping,
    table1_space,
)

REPO = Path(__file__).resolve().parents[2]
SPACE = table1_space()

# Table I, written out by hand: class names and default ranges per parameter.
TABLE1_COUNTS = {"directionality": 2, "rotation_error": 3, "inactivity": 2, "map_size": 3,
                 "landmark_density": 3, "step_size": 3, "symmetry": 3, "outlier_probability": 3,
                 "field_of_view": 2, "variance": 3, "bias": 5}


def test_table1_has_the_papers_rows():
    assert SPACE.names == PARAMETER_NAMES
    assert {p.name: p.n_classes for p in SPACE} == TABLE1_COUNTS
    assert SPACE.n_classes == 32 and SPACE.min_cases == 5
    assert SPACE["map_size"].classes[2].bounds == ((100.0, 400.0),)
    assert SPACE["field_of_view"].classes[0].bounds == ((math.pi / 2, math.pi),)
    assert SPACE["variance"].classes[2].bounds == ((20.0, 100.0), (0.04, 0.2))
    assert SPACE["bias"].classes[0].bounds == ((-25.0, -10.0), (-0.05, -0.02))
    assert SPACE["rotation_error"].classes[2].values == (-2 * math.pi,)
    assert SPACE["inactivity"].classes[1].values == (2000,)
    assert SPACE["outlier_probability"].classes[0].is_point
    assert SPACE["variance"].keys == ("variance_distance", "variance_angle")
    assert SPACE["variance"].units == ("mm", "rad")


@pytest.mark.parametrize("name, value, expected", [
    ("map_size", 4.0, 0), ("map_size", 16.0, 1), ("map_size", 15.999, 0), ("map_size", 400.0, 2),
    ("map_size", 3.99, -1), ("map_size", 400.01, -1),
    ("outlier_probability", 0.0, 0), ("outlier_probability", 1e-9, 1), ("outlier_probability", 5.0, 2),
    ("outlier_probability", 15.0, 2), ("outlier_probability", -1.0, -1),
    ("field_of_view", math.pi / 2, 0), ("field_of_view", math.pi, 1), ("field_of_view", 2 * math.pi, 1),
    ("field_of_view", 1.0, -1),
    ("symmetry", 0.0, 0), ("symmetry", 10.0, 1), ("symmetry", 90.0, 2), ("symmetry", 95.0, -1),
    ("rotation_error", 0.0, 0), ("rotation_error", 2 * math.pi, 1), ("rotation_error", -math.tau, 2),
    ("rotation_error", math.pi, -1),
    ("inactivity", 0, 0), ("inactivity", 2000, 1), ("inactivity", 10, -1),
    ("directionality", "random", 0), ("directionality", "loop", 1), ("directionality", "spiral", -1),
])
def test_classify_single_component(name, value, expected):
    assert SPACE[name].classify({SPACE[name].keys[0]: value}) == expected


@pytest.mark.parametrize("d, a, expected", [
    (0.0, 0.0, 2), (-25.0, -0.05, 0), (-10.0, -0.02, 1), (-0.1, -0.001, 1), (0.1, 0.001, 3),
    (10.0, 0.02, 4), (25.0, 0.05, 4), (5.0, -0.01, -1), (0.0, 0.01, 3), (30.0, 0.03, -1),
])
def test_classify_bias_needs_both_components_in_one_class(d, a, expected):
    assert SPACE["bias"].classify({"bias_distance": d, "bias_angle": a}) == expected


def test_fixed_values_fall_in_the_expected_classes():
    # hand-classified: 64 m^2 medium, 5 lm/m^2 medium, 80 cm medium, 0 % low, 2 % low, pi large,
    # (10 mm, 0.02 rad) low variance, zero bias "none"
    assert SPACE.classify(FIXED_VALUES) == {
        "directionality": 0, "rotation_error": 0, "inactivity": 0, "map_size": 1, "landmark_density": 1,
        "step_size": 1, "symmetry": 0, "outlier_probability": 1, "field_of_view": 1, "variance": 1, "bias": 2}


@settings(max_examples=60, deadline=None)
@given(name=st.sampled_from(PARAMETER_NAMES), data=st.data(), seed=st.integers(0, 2**32 - 1))
def test_a_drawn_value_lies_in_its_class(name, data, seed):
    p = SPACE[name]
    k = data.draw(st.integers(0, p.n_classes - 1))
    values = p.draw(k, np.random.default_rng(seed))
    assert set(values) == set(p.keys)
    assert p.classify(values) == k
    c = p.classes[k]
    if p.kind is Kind.CONTINUOUS:
        for key, (lo, hi) in zip(p.keys, c.bounds):
            assert lo <= values[key] <= hi
    else:
        assert values[p.keys[0]] in c.values


def test_random_weights_hand_computed():
    np.testing.assert_allclose(SPACE["outlier_probability"].random_weights(), [1 / 3, 2 / 9, 4 / 9])
    np.testing.assert_allclose(SPACE["map_size"].random_weights(), np.array([12, 84, 300]) / 396)
    np.testing.assert_allclose(SPACE["bias"].random_weights(),
                               [0.8 * 15 / 50, 0.8 * 10 / 50, 0.2, 0.8 * 10 / 50, 0.8 * 15 / 50])
    np.testing.assert_allclose(SPACE["rotation_error"].random_weights(), [1 / 3] * 3)
    np.testing.assert_allclose(SPACE["directionality"].random_weights(), [0.5, 0.5])


def test_class_choice_plus_draw_is_uniform_over_the_domain():
    # Random suite semantics: class by random_weights, then uniform inside -> uniform on [4, 400].
    p = SPACE["map_size"]
    rng = np.random.default_rng(11)
    w = p.random_weights()
    x = np.array([p.draw(int(rng.choice(3, p=w)), rng)["map_size"] for _ in range(3000)])
    assert stats.kstest(x, stats.uniform(loc=4, scale=396).cdf).pvalue > 0.01
    # and not uniform over the class index (which would put 1/3 of the mass in [4, 16])
    assert np.mean(x < 16) < 0.06


def test_to_dict_round_trips():
    again = space_from_mapping(SPACE.to_dict(), source="round trip")
    assert again.parameters == SPACE.parameters
    assert again.source == "round trip"


def test_override_file_equals_table1():
    assert load_space(REPO / "experiments" / "space_table1.toml").parameters == SPACE.parameters


def test_partial_override_replaces_only_the_given_parameter(tmp_path):
    f = tmp_path / "small.toml"
    f.write_text('[map_size]\nclasses = { tiny = [1, 4], small = [4, 16] }\n'
                 '[rotation_error]\nclasses = { none = 0, positive = ["2pi", "4pi"] }\n')
    space = load_space(f)
    assert space["map_size"].class_names == ("tiny", "small")
    assert space["map_size"].classes[0].bounds == ((1.0, 4.0),)
    assert space["rotation_error"].classes[1].values == (2 * math.pi, 4 * math.pi)
    for name in PARAMETER_NAMES:
        if name not in ("map_size", "rotation_error"):
            assert space[name] == SPACE[name]
    assert space.min_cases == 5 and space.n_classes == 32 - 3 + 2 - 1
    assert str(f) in space.source


def test_pi_expressions():
    m = {"field_of_view": {"classes": {"a": ["pi/4", "0.5pi"], "b": ["0.5*pi", "pi"], "c": ["-2pi", "-pi"]}}}
    with pytest.raises(ConfigError, match=r"\[field_of_view\]\.classes\.c"):  # -2pi is below 0 rad
        space_from_mapping(m, source="m")
    m["field_of_view"]["classes"].pop("c")
    fov = space_from_mapping(m, source="m")["field_of_view"]
    assert fov.classes[0].bounds == ((math.pi / 4, math.pi / 2),)
    assert fov.classes[1].bounds == ((math.pi / 2, math.pi),)


MALFORMED = [
    ("[map_sise]\nclasses = { small = [4, 16] }\n", r"\[map_sise\]: unknown parameter"),
    ("[map_size]\nclasses = { small = [20, 16] }\n",
     r"\[map_size\]\.classes\.small: lower bound 20 > upper bound 16"),
    ("[map_size]\nclasses = { small = [4, 20], medium = [16, 100] }\n",
     r"\[map_size\]\.classes: classes 'small' and 'medium' overlap"),
    ("[map_size]\nclasses = {}\n", r"\[map_size\]\.classes: no classes"),
    ("[rotation_error]\nclasses = { none = [] }\n", r"\[rotation_error\]\.classes\.none: empty class"),
    ("[directionality]\nclasses = []\n", r"\[directionality\]\.classes: no classes"),
    ('[map_size]\nclasses = { small = [4, "big"] }\n', r"\[map_size\]\.classes\.small: expected a number"),
    ("[map_size]\nclasses = { small = [4, true] }\n", r"\[map_size\]\.classes\.small: expected a number"),
    ("[map_size]\nclasses = [4, 16]\n", r"\[map_size\]\.classes: expected a table"),
    ("[map_size]\nclasses = { small = [4, 16, 20] }\n", r"\[map_size\]\.classes\.small: expected \[lower, upper\]"),
    ("[map_size]\nclass = { small = [4, 16] }\n", r"\[map_size\]\.class: unknown key"),
    ("[symmetry]\nclasses = { high = [60, 120] }\n", r"\[symmetry\]\.classes\.high: value 120 % is outside"),
    ("[inactivity]\nclasses = { none = [0], idle = [2000.5] }\n",
     r"\[inactivity\]\.classes\.idle: expected whole numbers"),
    ("[rotation_error]\nclasses = { none = [0], odd = [3.0] }\n", r"\[rotation_error\]\.classes\.odd: .*multiple of 2 pi"),
    ("[rotation_error]\nclasses = { a = [0], b = [0.0] }\n", r"\[rotation_error\]\.classes: classes 'a' and 'b' overlap"),
    ('[directionality]\nclasses = ["random", "zigzag"]\n', r"\[directionality\]\.classes: unknown label 'zigzag'"),
    ("[variance.classes]\nlow = { distance = [0, 20] }\n", r"\[variance\]\.classes\.low: missing component 'angle'"),
    ("[variance.classes]\nlow = { distance = [0, 20], angle = [0, 0.04], speed = 1 }\n",
     r"\[variance\]\.classes\.low\.speed: unknown component"),
    ("[variance.classes]\nlow = { distance = [0, 20], angle = [0.05, 0.04] }\n",
     r"\[variance\]\.classes\.low\.angle: lower bound 0.05 > upper bound 0.04"),
    ("[bias.classes]\na = { distance = [-10, 5], angle = [-0.02, 0.01] }\nb = { distance = [0, 10], angle = [0, 0.02] }\n",
     r"\[bias\]\.classes: classes 'a' and 'b' overlap"),
    ("[map_size\nclasses = 1\n", r"not valid TOML"),
]


@pytest.mark.parametrize("text, message", MALFORMED)
def test_malformed_override_names_file_and_key(tmp_path, text, message):
    f = tmp_path / "bad.toml"
    f.write_text(text)
    with pytest.raises(ConfigError, match=message) as err:
        load_space(f)
    assert str(err.value).startswith(f"{f}: ")
    assert "\n" not in str(err.value)


def test_missing_file_is_a_config_error(tmp_path):
    with pytest.raises(ConfigError, match="parameter-space file cannot be read"):
        load_space(tmp_path / "nope.toml")


def test_space_from_mapping_names_its_source():
    with pytest.raises(ConfigError, match=r"^exp\.toml \[space\]: \[map_size\]\.classes\.small: lower bound"):
        space_from_mapping({"map_size": {"classes": {"small": [5, 1]}}}, source="exp.toml [space]")


def test_shared_endpoints_and_point_classes_are_allowed():
    space = space_from_mapping({"step_size": {"classes": {"zero": 0, "a": [0, 50], "b": [50, 50], "c": [50, 80]}}},
                               source="m")
    p = space["step_size"]
    assert [p.classify({"step_size": x}) for x in (0.0, 10.0, 50.0, 80.0, 81.0)] == [0, 1, 2, 3, -1]


def test_space_needs_all_parameters_in_order():
    with pytest.raises(ConfigError, match="needs the parameters"):
        ParameterSpace(SPACE.parameters[::-1])
