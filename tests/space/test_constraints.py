from itertools import combinations, product

import numpy as np
import pytest
from covertable.evaluate import evaluate
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.errors import ConfigError
from faultlab.space import ClassStructure, Constraint, load_space, space_from_mapping, table1_space

# A test-only constraint: Table I has none (the generator produces every combination of its classes).
SMALL_LARGE = {"forbid": [{"map_size": "small", "step_size": "large"}]}


def _forbidden_by_hand(row, forbidden):
    """Direct reading of the format: a row is forbidden if some entry matches on every parameter."""
    return any(all(row[p] in cs for p, cs in c) for c in forbidden)


@st.composite
def structures(draw, max_params=5, max_classes=4, max_constraints=3):
    sizes = tuple(draw(st.lists(st.integers(2, max_classes), min_size=2, max_size=max_params)))
    forbidden = []
    for _ in range(draw(st.integers(0, max_constraints))):
        params = draw(st.lists(st.integers(0, len(sizes) - 1), min_size=2, max_size=min(3, len(sizes)),
                               unique=True))
        forbidden.append(tuple((p, frozenset(draw(st.lists(st.integers(0, sizes[p] - 1), min_size=1,
                                                            max_size=sizes[p] - 1, unique=True))))
                               for p in sorted(params)))
    return ClassStructure(sizes, tuple(forbidden))


@settings(max_examples=60, deadline=None)
@given(s=structures())
def test_allowed_feasible_and_tuples_agree_with_brute_force(s):
    full = [r for r in product(*(range(k) for k in s.sizes))]
    allowed = [r for r in full if not _forbidden_by_hand(r, s.forbidden)]
    np.testing.assert_array_equal(s.allowed_rows(np.array(full)), [r in set(allowed) for r in full])
    for r in full:
        assert s.allows(r) == (r in set(allowed))
    for t in (1, 2):
        for params in combinations(range(len(s.sizes)), t):
            oracle = sorted({tuple(r[p] for p in params) for r in allowed})
            assert [tuple(x) for x in s.tuples(params).tolist()] == oracle
            for combo in product(*(range(s.sizes[p]) for p in params)):
                partial = [-1] * len(s.sizes)
                for p, c in zip(params, combo):
                    partial[p] = c
                done = s.complete(partial)
                assert s.feasible(partial) == (combo in set(oracle))
                if done is not None:
                    assert done in set(allowed) and all(done[p] == c for p, c in zip(params, combo))


@settings(max_examples=40, deadline=None)
@given(s=structures())
def test_covertable_conditions_say_the_same(s):
    conds = s.to_covertable()
    for r in product(*(range(k) for k in s.sizes)):
        row = dict(enumerate(r))
        assert all(evaluate(c, row) is not False for c in conds) == s.allows(r)


def test_space_file_constraints_are_read_by_name(tmp_path):
    f = tmp_path / "c.toml"
    f.write_text('[constraints]\nforbid = [\n  { map_size = "small", step_size = "large" },\n'
                 '  { variance = "none", outlier_probability = ["high", "low"] },\n]\n')
    space = load_space(f)
    assert space.constraints == (
        Constraint((("map_size", ("small",)), ("step_size", ("large",)))),
        Constraint((("outlier_probability", ("low", "high")), ("variance", ("none",)))),  # space order
    )
    s = space.structure
    names = list(space.names)
    assert s.forbidden[0] == ((names.index("map_size"), frozenset({0})), (names.index("step_size"), frozenset({2})))
    assert s.constrained == tuple(sorted(names.index(n) for n in
                                         ("map_size", "step_size", "variance", "outlier_probability")))
    # round trip through the file format
    again = space_from_mapping(space.to_dict(), source=str(f))
    assert again == space


def test_table1_has_no_constraint():
    assert table1_space().constraints == () and table1_space().structure.forbidden == ()


@pytest.mark.parametrize("table, message", [
    ({"forbid": [{"map_size": "tiny", "step_size": "large"}]},
     "x.toml: [constraints].forbid[0].map_size: unknown class 'tiny' (classes: small, medium, large)"),
    ({"forbid": [{"map_sise": "small", "step_size": "large"}]},
     "x.toml: [constraints].forbid[0].map_sise: unknown parameter"),
    ({"forbid": [{"map_size": "small"}]}, "x.toml: [constraints].forbid[0]: a constraint names at least two"),
    ({"forbid": [{"map_size": "small", "step_size": 3}]},
     "x.toml: [constraints].forbid[0].step_size: expected a class name or a list of class names"),
    ({"forbid": [{"map_size": ["small", "small"], "step_size": "large"}]},
     "x.toml: [constraints].forbid[0].map_size: a class appears twice"),
    ({"forbid": ["map_size"]}, "x.toml: [constraints].forbid[0]: expected a table"),
    ({"forbid": {"map_size": "small"}}, "x.toml: [constraints].forbid: expected a list"),
    ({"avoid": []}, "x.toml: [constraints].avoid: unknown key"),
    ([1], "x.toml: [constraints]: expected a table"),
])
def test_malformed_constraints_name_file_and_key(table, message):
    with pytest.raises(ConfigError) as err:
        space_from_mapping({"constraints": table}, source="x.toml")
    assert str(err.value).startswith(message)


def test_a_class_no_allowed_case_can_have_is_refused():
    # inactivity has two classes: forbidding inactive with each of them leaves no case with inactive
    table = {"forbid": [{"inactivity": "inactive", "directionality": "random"},
                        {"inactivity": "inactive", "directionality": "loop"}]}
    with pytest.raises(ConfigError, match=r"x.toml: \[constraints\] forbid every case with inactivity = 'inactive'"):
        space_from_mapping({"constraints": table}, source="x.toml")


def test_constraints_are_read_against_the_overridden_classes():
    space = space_from_mapping({"map_size": {"classes": {"tiny": [1, 4], "rest": [4, 400]}},
                                "constraints": {"forbid": [{"map_size": "tiny", "step_size": "large"}]}},
                               source="x.toml")
    assert space.structure.forbidden == (((3, frozenset({0})), (5, frozenset({2}))),)
    with pytest.raises(ConfigError, match="unknown class 'small'"):
        space_from_mapping({"map_size": {"classes": {"tiny": [1, 4], "rest": [4, 400]}}, "constraints": SMALL_LARGE},
                           source="x.toml")
