import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.errors import ConfigError
from faultlab.space import (
    FIXED_VALUES,
    PARAMETER_NAMES,
    VALUE_KEYS,
    build_suite,
    coverage,
    space_from_mapping,
    table1_space,
)

SPACE = table1_space()


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**63 - 1))
def test_systematic_suite_covers_table1_with_five_cases(seed):
    cases = build_suite("systematic", SPACE, rng=np.random.default_rng(seed))
    assert len(cases) == 5
    cov = coverage(cases, SPACE)
    assert cov.ratio == 1.0 and cov.covered == 32
    # bias has 5 classes: each exactly once
    assert cov["bias"].counts == (1, 1, 1, 1, 1)
    for c in cases:
        assert set(c.values) == set(VALUE_KEYS)
        assert c.classes == SPACE.classify(c.values)  # the recorded class is where the value lies


def test_no_proper_prefix_of_the_systematic_suite_covers_everything():
    cases = build_suite("systematic", SPACE, rng=np.random.default_rng(1))
    assert coverage(cases[:4], SPACE).ratio < 1.0


@pytest.mark.parametrize("seed", range(5))
def test_extra_systematic_cases_fill_least_covered_classes_first(seed):
    cases = build_suite("systematic", SPACE, rng=np.random.default_rng(seed), n_cases=10)
    cov = coverage(cases, SPACE)
    assert cov["bias"].counts == (2, 2, 2, 2, 2)
    # after 5 covering cases the worst imbalance is (4, 1) or (3, 1, 1); 5 least-covered-first
    # additions always rebalance to max - min <= 1
    for p in cov.parameters:
        assert max(p.counts) - min(p.counts) <= 1, p


def test_systematic_suite_size_follows_the_space():
    space = space_from_mapping({"bias": {"classes": {"none": {"distance": 0, "angle": 0},
                                                      "pos": {"distance": [0, 5], "angle": [0, 0.01]}}}},
                               source="m")
    assert space.min_cases == 3
    cases = build_suite("systematic", space, rng=np.random.default_rng(0))
    assert len(cases) == 3 and coverage(cases, space).ratio == 1.0


def test_too_few_systematic_cases_is_a_config_error():
    with pytest.raises(ConfigError, match="at least 5 cases"):
        build_suite("systematic", SPACE, rng=np.random.default_rng(0), n_cases=4)


@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**63 - 1), n=st.integers(1, 12))
def test_random_suite_values_lie_in_the_domain(seed, n):
    cases = build_suite("random", SPACE, rng=np.random.default_rng(seed), n_cases=n)
    assert len(cases) == n
    for c in cases:
        cls = SPACE.classify(c.values)
        assert all(k >= 0 for k in cls.values())
        assert c.classes == cls


def test_random_suite_default_size_and_class_frequencies():
    assert len(build_suite("random", SPACE, rng=np.random.default_rng(0))) == 5
    cases = build_suite("random", SPACE, rng=np.random.default_rng(5), n_cases=1500)
    counts = np.array(coverage(cases, SPACE)["outlier_probability"].counts) / 1500
    np.testing.assert_allclose(counts, [1 / 3, 2 / 9, 4 / 9], atol=0.04)
    small = np.mean([c.values["map_size"] < 16 for c in cases])
    assert abs(small - 12 / 396) < 0.02


def test_fixed_suite():
    cases = build_suite("fixed", SPACE, rng=np.random.default_rng(0), n_cases=3)
    assert len(cases) == 3
    for c in cases:
        assert c.values == FIXED_VALUES
        assert c.classes["map_size"] == 1 and c.classes["bias"] == 2 and set(c.classes) == set(PARAMETER_NAMES)


def test_same_seed_same_suite_and_rng_required():
    a = build_suite("systematic", SPACE, rng=np.random.default_rng(9))
    b = build_suite("systematic", SPACE, rng=np.random.default_rng(9))
    assert [c.to_dict() for c in a] == [c.to_dict() for c in b]
    c = build_suite("systematic", SPACE, rng=np.random.default_rng(10))
    assert [x.to_dict() for x in a] != [x.to_dict() for x in c]
    with pytest.raises(TypeError, match="Generator"):
        build_suite("random", SPACE, rng=42)


def test_unknown_kind():
    with pytest.raises(ConfigError, match="unknown suite kind 'exhaustive'"):
        build_suite("exhaustive", SPACE, rng=np.random.default_rng(0))
