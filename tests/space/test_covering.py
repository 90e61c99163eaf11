import os
import random
import subprocess
import sys
from itertools import combinations, product

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.errors import ConfigError
from faultlab.space import ClassStructure, table1_space
from faultlab.space.covering import covering_array, extend_rows, uncovered_tuples

from tests.space.test_constraints import _forbidden_by_hand, structures


def brute_force_missing(sizes, forbidden, rows, t):
    """Every t-tuple of classes some allowed full row has, minus those in ``rows``: all enumerated."""
    allowed = [r for r in product(*(range(k) for k in sizes)) if not _forbidden_by_hand(r, forbidden)]
    missing = []
    for params in combinations(range(len(sizes)), t):
        need = {tuple(r[p] for p in params) for r in allowed}
        have = {tuple(int(r[p]) for p in params) for r in rows}
        missing += [(params, x) for x in sorted(need - have)]
    return missing


@settings(max_examples=40, deadline=None)
@given(sizes=st.lists(st.integers(2, 4), min_size=2, max_size=5))
def test_pairwise_array_covers_every_pair_of_any_small_space(sizes):
    s = ClassStructure(tuple(sizes))
    rows = covering_array(s, 2)
    assert brute_force_missing(sizes, (), rows, 2) == []
    a, b = sorted(sizes)[-2:]
    assert len(rows) >= a * b  # the two largest parameters alone need a * b rows


@settings(max_examples=40, deadline=None)
@given(s=structures(), t=st.integers(1, 3))
def test_arrays_with_constraints_cover_every_feasible_tuple_and_no_forbidden_row(s, t):
    t = min(t, len(s.sizes))
    rows = covering_array(s, t)
    assert not any(_forbidden_by_hand(tuple(r), s.forbidden) for r in rows)
    assert brute_force_missing(s.sizes, s.forbidden, rows, t) == []
    assert next(uncovered_tuples(s, rows, t), None) is None


def test_uncovered_tuples_lists_what_is_missing():
    s = ClassStructure((2, 2, 3))
    rows = np.array([[0, 0, 0], [1, 1, 1]])
    got = sorted((params, tuple(c)) for params, cs in uncovered_tuples(s, rows, 2) for c in cs.tolist())
    assert got == sorted(brute_force_missing((2, 2, 3), (), rows, 2))
    assert len(got) == 4 + 6 + 6 - 6  # 16 pairs, 6 covered by the two rows


def test_table1_arrays_and_their_size_depend_on_the_space_only():
    s = table1_space().structure
    a = covering_array(s, 2)
    assert brute_force_missing_fast(s, a, 2) == 0
    assert 5 * 3 <= len(a) <= 25  # bias (5) x a 3-class parameter is the lower bound
    assert not a.flags.writeable
    b = covering_array.__wrapped__(s, 2)  # recomputed without the cache: the same rows
    np.testing.assert_array_equal(a, b)


def brute_force_missing_fast(structure, rows, t):
    """Pairs missing from ``rows``, counted with Python sets (no constraints)."""
    n = 0
    for params in combinations(range(structure.n_parameters), t):
        need = set(product(*(range(structure.sizes[p]) for p in params)))
        n += len(need - {tuple(int(r[p]) for p in params) for r in rows})
    return n


HASHED = ClassStructure((3, 2, 4, 3, 2), (((0, frozenset({0})), (2, frozenset({1, 3}))),
                                          ((1, frozenset({1})), (3, frozenset({0})), (4, frozenset({1})))))


def test_arrays_do_not_depend_on_the_hash_seed():
    # covertable keeps sets and dicts; string hashing differs between processes unless fixed
    code = ("from faultlab.space import ClassStructure; from faultlab.space.covering import covering_array; "
            f"print(covering_array({HASHED!r}, 2).tolist())")
    env = dict(os.environ, PYTHONHASHSEED="12345")
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True)
    assert done.stdout.strip() == str(covering_array(HASHED, 2).tolist())


def test_arrays_leave_the_global_random_state_alone():
    random.seed(5)
    before = random.getstate()
    covering_array.__wrapped__(HASHED, 2)
    assert random.getstate() == before


@pytest.mark.parametrize("t0", [1, 2])
def test_extra_rows_cover_the_next_strength_first_then_every_combination(t0):
    sizes = (2, 3, 2, 3)
    s = ClassStructure(sizes)
    base = covering_array(s, t0)
    key = tuple(map(tuple, base.tolist()))
    extra = extend_rows(s, key, 50, t0 + 1)
    assert extra.shape == (50, 4)
    np.testing.assert_array_equal(extend_rows(s, key, 7, t0 + 1), extra[:7])  # fewer rows: a prefix
    rows = np.concatenate([base, extra])
    # every extra row covers a new (t0+1)-tuple until all are covered
    missing = [len(brute_force_missing(sizes, (), rows[:len(base) + k], t0 + 1)) for k in range(51)]
    m = missing.index(0)
    assert all(a > b for a, b in zip(missing[:m], missing[1:m + 1]))
    # all 36 combinations come before any repetition; then the rows repeat in order
    assert len({tuple(r) for r in rows[:36]}) == 36
    np.testing.assert_array_equal(rows[36:], rows[:len(rows) - 36])


def test_extra_rows_respect_constraints():
    s = ClassStructure((3, 3, 2), (((0, frozenset({0})), (1, frozenset({0, 1}))),))
    base = covering_array(s, 2)
    extra = extend_rows(s, tuple(map(tuple, base.tolist())), 10, 3)
    assert not any(_forbidden_by_hand(tuple(r), s.forbidden) for r in np.concatenate([base, extra]))


def test_strength_out_of_range():
    with pytest.raises(ConfigError, match="between 1 and the number of parameters"):
        covering_array(ClassStructure((2, 2)), 3)
