import numpy as np
import pandas as pd
import pytest

from faultlab.errors import ConfigError
from faultlab.space import load_space, read_class_weights, space_from_mapping, table1_space, weights_from_effects
from faultlab.space.settings import weights_frame

SPACE = table1_space()


def test_default_base_classes_are_those_of_the_fixed_values():
    # FIXED_VALUES by hand: random, 0 rad, 0 steps, 64 m^2, 5 lm/m^2, 80 cm, 0 %, 2 %, pi (the
    # closed lower end of "large"), 10 mm / 0.02 rad, no bias
    expected = {"directionality": "random", "rotation_error": "none", "inactivity": "none", "map_size": "medium",
                "landmark_density": "medium", "step_size": "medium", "symmetry": "low",
                "outlier_probability": "low", "field_of_view": "large", "variance": "low", "bias": "none"}
    got = SPACE.base_classes()
    assert {n: SPACE[n].class_names[k] for n, k in got.items()} == expected


def test_space_file_base_and_weights(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('[base]\nmap_size = "small"\n\n[weights]\ninactivity = { none = 1, inactive = 3.5 }\n')
    space = load_space(f)
    assert space.base == (("map_size", "small"),)
    assert space.base_classes()["map_size"] == 0 and space.base_classes()["step_size"] == 1
    w = space.class_weights()
    np.testing.assert_array_equal(w["inactivity"], [1.0, 3.5])
    np.testing.assert_array_equal(w["bias"], np.ones(5))  # not listed: equal weights
    assert SPACE.class_weights() is None
    assert space_from_mapping(space.to_dict(), source=str(f)) == space


@pytest.mark.parametrize("mapping, message", [
    ({"base": {"map_size": "tiny"}}, "x.toml: [base].map_size: unknown class 'tiny' (classes: small, medium, large)"),
    ({"base": {"size": "small"}}, "x.toml: [base].size: unknown parameter"),
    ({"base": "small"}, "x.toml: [base]: expected a table"),
    ({"weights": {"inactivity": {"none": 1}}}, "x.toml: [weights].inactivity: no weight for class 'inactive'"),
    ({"weights": {"inactivity": {"none": 1, "inactive": -1}}},
     "x.toml: [weights].inactivity.inactive: a weight must be a finite number >= 0, got -1"),
    ({"weights": {"inactivity": {"none": 1, "inactive": True}}},
     "x.toml: [weights].inactivity.inactive: a weight must be a finite number >= 0, got True"),
    ({"weights": {"inactivity": {"none": 0, "inactive": 0}}}, "x.toml: [weights].inactivity: every weight is zero"),
    ({"weights": {"inactivity": {"none": 1, "inactive": 1, "often": 2}}},
     "x.toml: [weights].inactivity.often: unknown class"),
    ({"weights": {"inactivity": [1, 2]}}, "x.toml: [weights].inactivity: expected a table class = weight"),
    ({"colours": {}}, "x.toml: [colours]: unknown parameter"),
])
def test_malformed_base_and_weights_name_file_and_key(mapping, message):
    with pytest.raises(ConfigError) as err:
        space_from_mapping(mapping, source="x.toml")
    assert str(err.value).startswith(message)


def test_base_class_is_required_where_the_fixed_value_is_outside_every_class():
    space = space_from_mapping({"map_size": {"classes": {"small": [4, 16], "large": [100, 400]}}}, source="x.toml")
    with pytest.raises(ConfigError, match=r"x.toml: no base class for map_size: the fixed value 64.0 m\^2 lies in "
                                          r"no class; name one in \[base\]"):
        space.base_classes()
    assert space.with_base({"map_size": "large"}).base_classes()["map_size"] == 1


def test_weights_csv_round_trip_and_errors(tmp_path):
    f = tmp_path / "w.csv"
    weights_frame({"map_size": {"small": 0.5, "medium": 0.25, "large": 0.25}}).to_csv(f, index=False)
    got = read_class_weights(f)
    assert got == {"map_size": {"small": 0.5, "medium": 0.25, "large": 0.25}}
    np.testing.assert_array_equal(SPACE.with_weights(got, source=str(f)).class_weights()["map_size"], [0.5, 0.25, 0.25])
    bad = tmp_path / "bad.csv"
    bad.write_text("parameter,class,w\nmap_size,small,1\n")
    with pytest.raises(ConfigError, match="bad.csv: class-weights file lacks the column 'weight'"):
        read_class_weights(bad)
    bad.write_text("parameter,class,weight\nmap_size,small,1\nmap_size,small,2\n")
    with pytest.raises(ConfigError, match="bad.csv: line 3: a second weight for map_size = 'small'"):
        read_class_weights(bad)
    bad.write_text("parameter,class,weight\nmap_size,small,x\n")
    with pytest.raises(ConfigError, match="bad.csv: line 2: weight 'x' is not a number"):
        read_class_weights(bad)
    with pytest.raises(ConfigError, match="missing.csv: class-weights file cannot be read"):
        read_class_weights(tmp_path / "missing.csv")
    bad.write_text("parameter,class,weight\nmap_size,small,1\nmap_size,tiny,1\n")
    with pytest.raises(ConfigError, match=r"bad.csv: map_size.tiny: unknown class"):
        SPACE.with_weights(read_class_weights(bad), source=str(bad))


def test_weights_from_rates_are_proportional_with_a_floor():
    rates = pd.DataFrame({"parameter": ["inactivity", "inactivity", "map_size", "map_size", "map_size"],
                          "class": ["none", "inactive", "small", "medium", "large"],
                          "detection_rate": [0.2, 0.6, 0.0, 0.0, 0.0]})
    w = weights_from_effects(rates, floor=0.1)
    # inactivity: shares 0.25 / 0.75 -> (1 - 2 * 0.1) * share + 0.1 = 0.3 / 0.7
    np.testing.assert_allclose(w["weight"].iloc[:2], [0.3, 0.7])
    # map_size: all rates zero -> equal weights
    np.testing.assert_allclose(w["weight"].iloc[2:], [1 / 3] * 3)
    assert list(w.columns) == ["parameter", "class", "weight"]
    no_floor = weights_from_effects(rates.iloc[:2], floor=0.0)
    np.testing.assert_allclose(no_floor["weight"], [0.25, 0.75])


def test_weights_from_odds_ratios_and_their_use():
    ors = pd.DataFrame({"parameter": ["bias"] * 5, "class": list(SPACE["bias"].class_names),
                        "odds_ratio": [4.0, 2.0, 1.0, 2.0, 1.0]})
    w = weights_from_effects(ors, floor=0.02)
    share = np.array([4, 2, 1, 2, 1]) / 10
    np.testing.assert_allclose(w["weight"], (1 - 5 * 0.02) * share + 0.02)
    assert w["weight"].min() >= 0.02
    mapping = {p: dict(zip(g["class"], g["weight"])) for p, g in w.groupby("parameter")}
    np.testing.assert_allclose(SPACE.with_weights(mapping).class_weights()["bias"], w["weight"])


@pytest.mark.parametrize("frame, message", [
    (pd.DataFrame({"parameter": ["a"], "class": ["b"]}), "exactly one of the columns"),
    (pd.DataFrame({"parameter": ["a"], "class": ["b"], "detection_rate": [0.5], "odds_ratio": [1.0]}),
     "exactly one of the columns"),
    (pd.DataFrame({"parameter": ["a"], "class": ["b"], "detection_rate": [1.5]}), r"detection_rate = 1.5 is not in \[0, 1\]"),
    (pd.DataFrame({"parameter": ["a"], "class": ["b"], "odds_ratio": [0.0]}), r"odds_ratio = 0.0 is not in \(0, inf\)"),
    (pd.DataFrame({"class": ["b"], "odds_ratio": [1.0]}), "lacks the column 'parameter'"),
    (pd.DataFrame({"parameter": ["a", "a"], "class": ["b", "b"], "odds_ratio": [1.0, 2.0]}), "appears twice"),
    (pd.DataFrame({"parameter": ["a", "a", "a"], "class": ["b", "c", "d"], "odds_ratio": [1.0, 2.0, 1.0]}),
     "floor 0.4 is too large for a"),
])
def test_malformed_effect_tables(frame, message):
    with pytest.raises(ConfigError, match=message):
        weights_from_effects(frame, floor=0.4 if "floor" in message else 0.05)
