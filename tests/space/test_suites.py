import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from faultlab.errors import ConfigError
from faultlab.space import SUITE_KINDS
from faultlab.space import (
    FIXED_VALUES,
    PARAMETER_NAMES,
    VALUE_KEYS,
    build_suite,
    coverage,
    min_suite_size,
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
    with pytest.raises(ConfigError, match="unknown suite strategy 'exhaustive'"):
        build_suite("exhaustive", SPACE, rng=np.random.default_rng(0))


# ------------------------------------------------------------------ every kind, constraints
CONSTRAINED = space_from_mapping({"constraints": {"forbid": [
    {"map_size": "small", "step_size": "large"},       # test-only: Table I has no constraint
    {"map_size": "small", "step_size": "medium"},
]}}, source="c.toml")


def _legacy_systematic(space, rng, n):
    """The systematic suite as Sec. VI describes it, transcribed without constraints."""
    counts = {p.name: np.zeros(p.n_classes, dtype=np.int64) for p in space.parameters}
    out = []
    for _ in range(n):
        done = all(bool(np.all(c > 0)) for c in counts.values())
        values, classes = {}, {}
        for p in space.parameters:
            cnt = counts[p.name]
            cand = np.flatnonzero(cnt == cnt.min()) if done else np.flatnonzero(cnt == 0)
            if cand.size == 0:
                cand = np.arange(p.n_classes)
            k = int(cand[rng.integers(cand.size)])
            values.update(p.draw(k, rng))
            classes[p.name] = k
            cnt[k] += 1
        out.append((values, classes))
    return out


@pytest.mark.parametrize("seed, n", [(0, 5), (1, 5), (2, 9), (3, 14)])
def test_systematic_suite_draws_as_sec_vi_describes(seed, n):
    got = build_suite("systematic", SPACE, rng=np.random.default_rng(seed), n_cases=n)
    want = _legacy_systematic(SPACE, np.random.default_rng(seed), n)
    assert [(c.values, c.classes) for c in got] == want


# Table I with fewer classes, so that even the 4-wise suite builds in a fraction of a second
REDUCED = space_from_mapping({
    "rotation_error": {"classes": {"none": [0]}}, "inactivity": {"classes": {"none": [0]}},
    "field_of_view": {"classes": {"all": ["pi/2", "2pi"]}},
    "symmetry": {"classes": {"low": [0, 10], "high": [10, 90]}},
    "variance": {"classes": {"low": {"distance": [0, 20], "angle": [0, 0.04]}}},
}, source="reduced")


@pytest.mark.parametrize("kind", SUITE_KINDS)
def test_every_kind_builds_a_deterministic_suite_of_classified_values(kind):
    space = REDUCED.with_weights({"bias": {"high_neg": 1, "low_neg": 1, "none": 4, "low_pos": 1, "high_pos": 1}})
    a = build_suite(kind, space, rng=np.random.default_rng(21))
    b = build_suite(kind, space, rng=np.random.default_rng(21))
    assert [c.to_dict() for c in a] == [c.to_dict() for c in b]
    assert len(a) == (min_suite_size(kind, space) or space.min_cases)
    for c in a:
        assert c.classes == space.classify(c.values)


@pytest.mark.parametrize("kind", [k for k in SUITE_KINDS if k not in ("fixed", "3-wise", "4-wise")])
def test_every_builder_honours_constraints(kind):
    space = CONSTRAINED.with_weights({"map_size": {"small": 5, "medium": 1, "large": 1}})
    n = max(min_suite_size(kind, space) or 0, 60)
    cases = build_suite(kind, space, rng=np.random.default_rng(3), n_cases=n)
    rows = np.array([[c.classes[p] for p in PARAMETER_NAMES] for c in cases])
    assert space.structure.allowed_rows(rows).all()
    i, j = PARAMETER_NAMES.index("map_size"), PARAMETER_NAMES.index("step_size")
    small = rows[:, i] == 0
    assert small.any() and (rows[small, j] == 0).all()
    if kind not in ("random",):
        assert coverage(cases, space).ratio == 1.0


def test_random_suite_under_constraints_is_the_conditional_distribution():
    cases = build_suite("random", CONSTRAINED, rng=np.random.default_rng(8), n_cases=800)
    i, j = PARAMETER_NAMES.index("map_size"), PARAMETER_NAMES.index("step_size")
    pi, pj = SPACE["map_size"].random_weights(), SPACE["step_size"].random_weights()
    joint = np.outer(pi, pj)
    joint[0, 1:] = 0.0  # the forbidden cells
    joint /= joint.sum()
    obs = np.zeros((3, 3))
    for c in cases:
        obs[c.classes["map_size"], c.classes["step_size"]] += 1
    keep = joint > 0
    assert obs[~keep].sum() == 0
    assert stats.chisquare(obs[keep], f_exp=joint[keep] * len(cases)).pvalue > 1e-3


def test_fixed_suite_refuses_a_forbidden_fixed_case():
    space = space_from_mapping({"constraints": {"forbid": [{"map_size": "medium", "step_size": "medium"}]}},
                               source="c.toml")
    with pytest.raises(ConfigError, match=r"c.toml: \[constraints\] forbid the fixed suite's case"):
        build_suite("fixed", space, rng=np.random.default_rng(0))
