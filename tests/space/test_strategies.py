from itertools import combinations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy import stats

from faultlab.errors import ConfigError
from faultlab.space import (
    VALUE_KEYS,
    base_choice_coverage,
    base_choice_suite,
    build_suite,
    coverage,
    effect_guided_suite,
    min_suite_size,
    space_from_mapping,
    t_wise_coverage,
    t_wise_kind,
    t_wise_strength,
    t_wise_suite,
    table1_space,
)
from faultlab.space.coverage import class_matrix
from faultlab.space import SUITE_KINDS

from tests.space.test_constraints import _forbidden_by_hand
from tests.space.test_covering import brute_force_missing

SPACE = table1_space()
# A test-only constraint (Table I has none): no small map with large steps, no noise-free
# variance with high outlier rates.
CONSTRAINED = space_from_mapping({"constraints": {"forbid": [
    {"map_size": "small", "step_size": "large"},
    {"variance": "none", "outlier_probability": "high"},
]}}, source="c.toml")


def _rows(cases, space):
    m = class_matrix(cases, space)
    assert (m >= 0).all()
    return m


def _values_lie_in_their_classes(cases, space):
    for c in cases:
        assert set(c.values) == set(VALUE_KEYS)
        assert c.classes == space.classify(c.values)


# ---------------------------------------------------------------------------- names
def test_kind_names_carry_the_strength():
    assert [t_wise_strength(k) for k in ("pairwise", "3-wise", "4-wise", "12-wise")] == [2, 3, 4, 12]
    assert [t_wise_strength(k) for k in ("2-wise", "1-wise", "0-wise", "t-wise", "systematic")] == [None] * 5
    assert [t_wise_kind(t) for t in (2, 3, 4)] == ["pairwise", "3-wise", "4-wise"]
    for k in SUITE_KINDS:
        s = t_wise_strength(k)
        assert s is None or t_wise_kind(s) == k


# ---------------------------------------------------------------------- base choice
def test_base_choice_suite_of_table1():
    cases = base_choice_suite(SPACE, rng=np.random.default_rng(0))
    # 1 base case + one case per non-base class: 1 + sum(n_i - 1) = 1 + 32 - 11
    assert len(cases) == 1 + SPACE.n_classes - len(SPACE.parameters) == 22
    _values_lie_in_their_classes(cases, SPACE)
    rows = _rows(cases, SPACE)
    base = np.array([SPACE.base_classes()[p.name] for p in SPACE.parameters])
    np.testing.assert_array_equal(rows[0], base)
    varied = rows[1:] != base
    assert (varied.sum(axis=1) == 1).all()  # exactly one parameter away from the base case
    pairs = {(int(np.flatnonzero(v)[0]), int(r[v][0])) for v, r in zip(varied, rows[1:])}
    assert len(pairs) == 21  # all distinct, all non-base classes
    cov = base_choice_coverage(cases, SPACE)
    assert (cov.covered, cov.total, cov.ratio, cov.base_case) == (21, 21, 1.0, True)
    assert coverage(cases, SPACE).ratio == 1.0  # base choice subsumes each-choice
    assert str(cov).startswith("base-choice coverage: 100 % (21 of 21")


def test_base_choice_with_other_base_classes():
    space = SPACE.with_base({"bias": "high_pos", "map_size": "small"})
    cases = build_suite("base-choice", space, rng=np.random.default_rng(1))
    rows = _rows(cases, space)
    assert rows[0, SPACE.names.index("bias")] == 4 and rows[0, SPACE.names.index("map_size")] == 0
    assert base_choice_coverage(cases, space).ratio == 1.0
    # judged against the default base, the same cases cover only the variations of the two parameters
    other = base_choice_coverage(cases, SPACE)
    assert other.ratio < 1.0 and not other.base_case


def test_base_choice_under_constraints_skips_forbidden_variations():
    space = CONSTRAINED.with_base({"map_size": "small", "variance": "none"})
    cases = base_choice_suite(space, rng=np.random.default_rng(2))
    rows = _rows(cases, space)
    assert space.structure.allowed_rows(rows).all()
    cov = base_choice_coverage(cases, space)
    assert set(cov.excluded) == {("step_size", "large"), ("outlier_probability", "high")}
    assert len(cases) == 22 - 2 and cov.total == 19 and cov.ratio == 1.0
    with pytest.raises(ConfigError, match=r"the base case \(.*\) is forbidden by \[constraints\]"):
        base_choice_suite(CONSTRAINED.with_base({"map_size": "small", "step_size": "large"}),
                          rng=np.random.default_rng(0))


def test_base_choice_coverage_counts_by_hand():
    cases = base_choice_suite(SPACE, rng=np.random.default_rng(3))
    cov = base_choice_coverage(cases[:1] + cases[5:9], SPACE)  # the base case and 4 variations
    assert (cov.covered, cov.total) == (4, 21) and cov.base_case
    assert len(cov.uncovered) == 17
    assert base_choice_coverage([], SPACE).ratio == 0.0


# -------------------------------------------------------------------------- t-wise
@pytest.mark.parametrize("kind, t", [("pairwise", 2), ("3-wise", 3)])
def test_t_wise_suites_of_table1_cover_every_t_tuple(kind, t):
    cases = build_suite(kind, SPACE, rng=np.random.default_rng(4))
    assert len(cases) == min_suite_size(kind, SPACE)
    _values_lie_in_their_classes(cases, SPACE)
    rows = _rows(cases, SPACE)
    cov = t_wise_coverage(cases, SPACE, t)
    sizes = [p.n_classes for p in SPACE.parameters]
    total = sum(int(np.prod([sizes[i] for i in c])) for c in combinations(range(11), t))
    assert (cov.covered, cov.total, cov.ratio) == (total, total, 1.0)
    # an independent count with Python sets
    for c in combinations(range(11), t):
        assert len({tuple(r[list(c)]) for r in rows}) == int(np.prod([sizes[i] for i in c]))


def test_pairwise_suite_under_constraints_against_brute_force():
    cases = build_suite("pairwise", CONSTRAINED, rng=np.random.default_rng(5))
    rows = _rows(cases, CONSTRAINED)
    s = CONSTRAINED.structure
    assert not any(_forbidden_by_hand(tuple(r), s.forbidden) for r in rows)
    cov = t_wise_coverage(cases, CONSTRAINED, 2)
    # the two forbidden pairs are the only class pairs that cannot occur
    assert (cov.ratio, cov.excluded, cov.total) == (1.0, 2, 462 - 2)
    assert "2 excluded by constraints" in str(cov)


@st.composite
def small_spaces(draw):
    """Table I with 2-5 parameters of 2-4 classes varied (the others collapsed to one class)."""
    names = draw(st.lists(st.sampled_from(["map_size", "landmark_density", "step_size", "symmetry",
                                           "outlier_probability"]), min_size=2, max_size=5, unique=True))
    bounds = {"map_size": (4, 400), "landmark_density": (1, 15), "step_size": (25, 200), "symmetry": (0, 90),
              "outlier_probability": (0, 15)}
    mapping = {}
    for name in ("map_size", "landmark_density", "step_size", "symmetry", "outlier_probability"):
        lo, hi = bounds[name]
        k = draw(st.integers(2, 4)) if name in names else 1
        edges = np.linspace(lo, hi, k + 1)
        mapping[name] = {"classes": {f"c{i}": [float(edges[i]), float(edges[i + 1])] for i in range(k)}}
    for name, one in (("directionality", ["random"]), ("rotation_error", {"none": [0]}),
                      ("inactivity", {"none": [0]}), ("field_of_view", {"all": ["pi/2", "2pi"]}),
                      ("variance", {"low": {"distance": [0, 20], "angle": [0, 0.04]}}),
                      ("bias", {"none": {"distance": 0, "angle": 0}})):
        mapping[name] = {"classes": one}
    return space_from_mapping(mapping, source="hypothesis")


@settings(max_examples=15, deadline=None)
@given(space=small_spaces(), seed=st.integers(0, 2**32 - 1))
def test_pairwise_coverage_is_complete_for_any_small_space(space, seed):
    cases = t_wise_suite(space, rng=np.random.default_rng(seed), strength=2)
    rows = _rows(cases, space)
    assert brute_force_missing(space.structure.sizes, (), rows, 2) == []
    assert t_wise_coverage(cases, space, 2).ratio == 1.0
    _values_lie_in_their_classes(cases, space)


def test_t_wise_suites_are_deterministic_and_vary_with_the_rng():
    a = build_suite("pairwise", SPACE, rng=np.random.default_rng(7))
    b = build_suite("pairwise", SPACE, rng=np.random.default_rng(7))
    c = build_suite("pairwise", SPACE, rng=np.random.default_rng(8))
    assert [x.to_dict() for x in a] == [x.to_dict() for x in b]
    assert len(a) == len(c)  # the size depends on the space only
    assert {tuple(r) for r in _rows(a, SPACE)} != {tuple(r) for r in _rows(c, SPACE)}  # relabelled classes


def test_constrained_parameters_keep_their_labels():
    # relabelling a constrained parameter could turn an allowed row into a forbidden one
    for seed in range(5):
        rows = _rows(build_suite("pairwise", CONSTRAINED, rng=np.random.default_rng(seed)), CONSTRAINED)
        assert CONSTRAINED.structure.allowed_rows(rows).all()


@pytest.mark.parametrize("kind, minimum", [("pairwise", None), ("3-wise", None), ("base-choice", 22)])
def test_sizes_below_the_minimum_are_refused_and_above_it_filled(kind, minimum):
    need = min_suite_size(kind, SPACE)
    assert minimum is None or need == minimum
    with pytest.raises(ConfigError, match=f"a {kind} suite needs at least {need} cases for Table I, got n_cases={need - 1}"):
        build_suite(kind, SPACE, rng=np.random.default_rng(0), n_cases=need - 1)
    more = build_suite(kind, SPACE, rng=np.random.default_rng(0), n_cases=need + 10)
    assert len(more) == need + 10
    _values_lie_in_their_classes(more, SPACE)
    t = t_wise_strength(kind) or 1
    if kind == "base-choice":
        assert base_choice_coverage(more, SPACE).ratio == 1.0
    assert t_wise_coverage(more, SPACE, t).ratio == 1.0 if t > 1 else True
    # the extra cases raise the coverage of the next strength
    assert t_wise_coverage(more, SPACE, t + 1).covered > t_wise_coverage(more[:need], SPACE, t + 1).covered


def test_t_wise_strength_is_checked():
    with pytest.raises(ConfigError, match="strength between 2 and 11"):
        t_wise_suite(SPACE, rng=np.random.default_rng(0), strength=12)


# -------------------------------------------------------------------- effect-guided
WEIGHTS = {"map_size": {"small": 6.0, "medium": 3.0, "large": 1.0},
           "bias": {"high_neg": 0.0, "low_neg": 1.0, "none": 1.0, "low_pos": 1.0, "high_pos": 2.0}}


def test_weights_shift_class_frequencies_as_intended():
    n = 1500
    cases = effect_guided_suite(SPACE, rng=np.random.default_rng(11), n_cases=n, weights=WEIGHTS)
    rows = _rows(cases, SPACE)
    assert coverage(cases[:5], SPACE).ratio == 1.0  # each-choice first
    later = rows[5:]  # after every class is covered: classes drawn independently by weight
    j = SPACE.names.index("map_size")
    counts = np.bincount(later[:, j], minlength=3)
    assert stats.chisquare(counts, f_exp=np.array([0.6, 0.3, 0.1]) * len(later)).pvalue > 1e-3
    assert stats.chisquare(counts).pvalue < 1e-12  # far from equal frequencies
    jb = SPACE.names.index("bias")
    cb = np.bincount(later[:, jb], minlength=5)
    assert cb[0] == 0  # weight zero: only the covering case
    assert stats.chisquare(cb[1:], f_exp=np.array([1, 1, 1, 2]) / 5 * len(later)).pvalue > 1e-3
    jd = SPACE.names.index("landmark_density")  # no weights: equal frequencies
    assert stats.chisquare(np.bincount(later[:, jd], minlength=3)).pvalue > 1e-3


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n=st.integers(5, 12))
def test_effect_guided_covers_every_class_when_the_size_allows(seed, n):
    cases = effect_guided_suite(SPACE, rng=np.random.default_rng(seed), n_cases=n, weights=WEIGHTS)
    assert len(cases) == n and coverage(cases, SPACE).ratio == 1.0
    _values_lie_in_their_classes(cases, SPACE)


def test_effect_guided_below_the_class_count_prefers_heavy_classes():
    # 2 cases cannot cover map_size's 3 classes; the first class is drawn by weight among all three
    w = {"map_size": {"small": 1.0, "medium": 0.0, "large": 0.0}}
    for seed in range(10):
        cases = effect_guided_suite(SPACE, rng=np.random.default_rng(seed), n_cases=2, weights=w)
        first = _rows(cases, SPACE)[:, SPACE.names.index("map_size")]
        assert first[0] == 0 and first[1] in (1, 2)


def test_effect_guided_weights_from_the_space_a_csv_or_nowhere(tmp_path):
    f = tmp_path / "w.csv"
    f.write_text("parameter,class,weight\nmap_size,small,6\nmap_size,medium,3\nmap_size,large,1\n")
    space = SPACE.with_weights({"map_size": {"small": 6, "medium": 3, "large": 1}})
    a = build_suite("effect-guided", space, rng=np.random.default_rng(3), n_cases=30)
    b = effect_guided_suite(SPACE, rng=np.random.default_rng(3), n_cases=30, weights=f)
    assert [x.to_dict() for x in a] == [x.to_dict() for x in b]
    with pytest.raises(ConfigError, match="Table I: an effect-guided suite needs class weights"):
        build_suite("effect-guided", SPACE, rng=np.random.default_rng(0))


def test_effect_guided_respects_constraints():
    space = CONSTRAINED.with_weights({"map_size": {"small": 10, "medium": 1, "large": 1},
                                      "step_size": {"small": 1, "medium": 1, "large": 10}})
    cases = build_suite("effect-guided", space, rng=np.random.default_rng(4), n_cases=200)
    rows = _rows(cases, space)
    assert space.structure.allowed_rows(rows).all()
    assert coverage(cases, space).ratio == 1.0
