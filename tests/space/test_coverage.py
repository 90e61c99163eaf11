from itertools import combinations, product

import numpy as np
import pytest

from faultlab.errors import ConfigError
from faultlab.space import (
    FIXED_VALUES,
    CaseSpec,
    base_choice_coverage,
    build_suite,
    coverage,
    space_from_mapping,
    suite_criteria,
    t_wise_coverage,
    table1_space,
)
from faultlab.space.coverage import class_matrix

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


# ------------------------------------------------------------- t-wise and base choice


def _brute_t_wise(rows, sizes, t, forbidden=()):
    allowed = [r for r in product(*(range(k) for k in sizes))
               if not any(all(r[p] in cs for p, cs in c) for c in forbidden)]
    covered = total = 0
    for params in combinations(range(len(sizes)), t):
        need = {tuple(r[p] for p in params) for r in allowed}
        have = {tuple(int(r[p]) for p in params) for r in rows if all(r[p] >= 0 for p in params)}
        total += len(need)
        covered += len(need & have)
    return covered, total


@pytest.mark.parametrize("seed", range(3))
def test_pairwise_coverage_of_random_cases_against_counting(seed):
    space = space_from_mapping({"rotation_error": {"classes": {"none": [0]}}, "bias": {"classes": {
        "none": {"distance": 0, "angle": 0}, "pos": {"distance": [0, 10], "angle": [0, 0.02]}}},
        "constraints": {"forbid": [{"map_size": "small", "landmark_density": ["low", "high"]}]}}, source="m")
    cases = build_suite("random", space, rng=np.random.default_rng(seed), n_cases=7)
    cases.append(_case(map_size=1000.0))  # a value outside every class covers no tuple with map_size
    rows = class_matrix(cases, space)
    assert rows[-1, space.names.index("map_size")] == -1
    for t in (1, 2):
        cov = t_wise_coverage(cases, space, t)
        assert (cov.covered, cov.total) == _brute_t_wise(rows, space.structure.sizes, t, space.structure.forbidden)
    assert t_wise_coverage(cases, space, 2).excluded == 2
    assert t_wise_coverage(cases, space, 1).covered == coverage(cases, space).covered  # t = 1 is class coverage


def test_base_choice_coverage_of_hand_made_cases():
    base = _case()  # the fixed values are the base case
    cases = [base, _case(map_size=4.0), _case(map_size=4.0, bias_distance=-20.0, bias_angle=-0.03),
             _case(directionality="loop"), _case(directionality="loop")]
    cov = base_choice_coverage(cases, SPACE)
    # map_size=small and directionality=loop; the double variation counts for nothing
    assert (cov.covered, cov.total, cov.base_case) == (2, 21, True)
    assert ("map_size", "large") in cov.uncovered and ("map_size", "small") not in cov.uncovered
    assert cov.base["field_of_view"] == "large"
    assert not base_choice_coverage(cases[1:], SPACE).base_case


def test_suite_criteria_name_the_suites_own_measure():
    pw = build_suite("pairwise", SPACE, rng=np.random.default_rng(0))
    assert [str(m).split(":")[0] for m in suite_criteria("pairwise", pw, SPACE)] == ["pairwise coverage"]
    bc = build_suite("base-choice", SPACE, rng=np.random.default_rng(0))
    names = [str(m).split(":")[0] for m in suite_criteria("base-choice", bc, SPACE)]
    assert names == ["base-choice coverage", "pairwise coverage"]
    tw = build_suite("3-wise", SPACE, rng=np.random.default_rng(0))
    m = suite_criteria("3-wise", tw, SPACE)
    assert [x.strength for x in m] == [2, 3] and all(x.ratio == 1.0 for x in m)
    assert str(m[1]) == f"3-wise coverage: 100 % ({m[1].total} of {m[1].total} class 3-tuples)"


def test_t_wise_strength_is_checked():
    with pytest.raises(ConfigError, match="strength between 1 and 11, got 12"):
        t_wise_coverage([_case()], SPACE, 12)
