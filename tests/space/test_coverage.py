import numpy as np
import pytest

from faultlab.space import FIXED_VALUES, CaseSpec, coverage, space_from_mapping, table1_space

SPACE = table1_space()


def _case(**over):
    v = dict(FIXED_VALUES)
    v.update(over)
    return CaseSpec(v)


def test_fixed_case_covers_one_class_per_parameter():
    cov = coverage([_case(), _case()], SPACE)
    assert cov.n_cases == 2
    assert cov.covered == 11 and cov.total == 32
    assert cov.ratio == pytest.approx(11 / 32)
    assert cov.per_parameter["bias"] == pytest.approx(1 / 5)
    assert cov.per_parameter["directionality"] == pytest.approx(1 / 2)
    assert cov["map_size"].counts == (0, 2, 0)
    assert cov["bias"].uncovered == ("high_neg", "low_neg", "low_pos", "high_pos")


def test_coverage_grows_with_new_classes_and_ignores_values_outside():
    cases = [_case(), _case(directionality="loop", map_size=400.0), _case(map_size=1000.0)]
    cov = coverage(cases, SPACE)
    assert cov["directionality"].counts == (2, 1)
    assert cov["map_size"].counts == (0, 1, 1)  # 64 medium, 400 large (closed top), 1000 outside
    assert cov["map_size"].n_outside == 1
    assert cov.covered == 13


def test_recorded_classes_are_not_trusted():
    wrong = CaseSpec(dict(FIXED_VALUES), {"map_size": 2, "bias": 0})
    assert coverage([wrong], SPACE)["map_size"].counts == (0, 1, 0)


def test_empty_suite_and_other_space():
    assert coverage([], SPACE).ratio == 0.0
    space = space_from_mapping({"map_size": {"classes": {"all": [0, 1000]}}}, source="m")
    cov = coverage([_case()], space)
    assert cov["map_size"].ratio == 1.0 and cov.total == 30


def test_table_has_a_row_per_parameter_and_overall():
    df = coverage([_case()], SPACE).table()
    assert list(df["parameter"]) == list(SPACE.names) + ["overall"]
    np.testing.assert_allclose(df["coverage"].iloc[-1], 11 / 32)
    assert df.loc[df.parameter == "bias", "counts"].item() == "high_neg=0 low_neg=0 none=1 low_pos=0 high_pos=0"
    text = str(coverage([_case()], SPACE))
    assert "overall" in text and "34 %" in text
