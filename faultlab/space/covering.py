"""Covering arrays over equivalence classes: every feasible t-tuple of classes in some row.

Rows are built by covertable's greedy generator (a maintained library for t-wise covering arrays
with constraints) over class *indices*; this module turns a :class:`ClassStructure` into its
input, checks the result against the feasible tuples of :meth:`ClassStructure.tuples` and adds a
row for any feasible tuple the generator left out (it may, with constraints).

Determinism: covertable orders the tuples it covers with a hash of each tuple and a *salt* string
(its default ``sorters.hash``); it never touches Python's ``random`` with that sorter (its
``sorters.random`` would use the global ``random`` state and is not used).  The arrays here are
*canonical*: built with fixed salts, so an array depends only on the class structure and the
strength, never on a random generator.  The suite builders randomise them (relabelled classes,
row order, values inside classes) with their own ``rng``.  Results are cached per process.
"""

from __future__ import annotations

from functools import lru_cache
from itertools import islice

import numpy as np
from covertable import Controller

from faultlab.errors import ConfigError
from faultlab.space.constraints import ClassStructure

__all__ = ["covering_array", "extend_rows", "uncovered_tuples"]

#: Salts tried for a canonical array (the smallest array wins; ties go to the first salt).
#: Each try costs a full greedy run, so fewer for higher strengths.
_SALT_TRIES = {1: 4, 2: 8, 3: 4}


def _controller(structure: ClassStructure, strength: int, salt: str, presets=None) -> Controller:
    factors = [list(range(k)) for k in structure.sizes]
    return Controller(factors, strength=strength, salt=salt, presets=[list(map(int, r)) for r in presets or []],
                      constraints=structure.to_covertable() or None)


def _check_strength(structure: ClassStructure, strength: int) -> None:
    if not 1 <= int(strength) <= structure.n_parameters:
        raise ConfigError(f"a t-wise strength must be between 1 and the number of parameters "
                          f"({structure.n_parameters}), got {strength}")


def uncovered_tuples(structure: ClassStructure, rows: np.ndarray, strength: int):
    """The feasible ``strength``-tuples of classes no row contains.

    Yields
    ------
    (parameters, classes) : tuple of int, ndarray
        For every set of parameters, the class combinations (shape (m, strength)) not covered.
    """
    rows = np.asarray(rows, dtype=np.int64).reshape(-1, structure.n_parameters)
    for params in structure.interactions(strength):
        need = structure.tuples(params)
        radix = np.array([int(np.prod([structure.sizes[q] for q in params[j + 1:]])) for j in range(len(params))],
                         dtype=np.int64)
        have = np.unique(rows[:, params] @ radix) if rows.size else np.empty(0, np.int64)
        missing = ~np.isin(need @ radix, have)
        if missing.any():
            yield params, need[missing]


def _complete(structure: ClassStructure, rows: list[tuple[int, ...]], strength: int) -> list[tuple[int, ...]]:
    """``rows`` plus one row per feasible tuple still uncovered (each found by depth-first search)."""
    rows = list(rows)
    while True:
        gap = next(uncovered_tuples(structure, np.array(rows, dtype=np.int64), strength), None)
        if gap is None:
            return rows
        params, classes = gap
        partial = [-1] * structure.n_parameters
        for p, c in zip(params, classes[0]):
            partial[p] = int(c)
        row = structure.complete(partial)
        if row is None:  # cannot happen: tuples() returns only completable tuples
            raise AssertionError(f"feasible tuple {params}={classes[0]} has no completion")
        rows.append(row)


@lru_cache(maxsize=64)
def covering_array(structure: ClassStructure, strength: int) -> np.ndarray:
    """A canonical ``strength``-wise covering array of the classes of ``structure``.

    Parameters
    ----------
    structure : ClassStructure
    strength : int
        1 <= t <= number of parameters.

    Returns
    -------
    ndarray, shape (n_rows, n_parameters), int64
        Class indices; every row respects the constraints and every feasible t-tuple of classes
        occurs in some row.  Read-only (shared by the cache).
    """
    _check_strength(structure, strength)
    best = None
    for i in range(_SALT_TRIES.get(int(strength), 1)):
        rows = [tuple(r) for r in _controller(structure, strength, f"faultlab-{i}").make_async()]
        rows = _complete(structure, rows, strength)
        if best is None or len(rows) < len(best):
            best = rows
    out = np.array(best, dtype=np.int64).reshape(-1, structure.n_parameters)
    out.setflags(write=False)
    return out


@lru_cache(maxsize=64)
def extend_rows(structure: ClassStructure, rows: tuple[tuple[int, ...], ...], n_extra: int,
                strength: int) -> np.ndarray:
    """``n_extra`` further rows after ``rows`` that greedily cover new tuples of growing strength.

    The extra rows are those covertable adds to ``rows`` (given as presets) to cover every
    feasible ``strength``-tuple, then every ``strength + 1``-tuple, and so on; once every
    strength up to all parameters is covered (every allowed class combination is a row), the
    rows are repeated in order.

    Returns
    -------
    ndarray, shape (n_extra, n_parameters), int64
    """
    if int(strength) < 1:
        raise ConfigError(f"a t-wise strength must be at least 1, got {strength}")
    have = [tuple(map(int, r)) for r in rows]
    extra: list[tuple[int, ...]] = []
    for t in range(int(strength), structure.n_parameters + 1):
        if len(extra) >= n_extra:
            break
        presets = have + extra
        gen = _controller(structure, t, "faultlab-0", presets=presets).make_async()
        made = [tuple(r) for r in islice(gen, len(presets) + n_extra - len(extra))]
        if made[:len(presets)] != presets:  # a preset violating the constraints would be dropped
            raise AssertionError("covertable did not return the preset rows first")
        extra.extend(made[len(presets):])
    pool, i = have + extra, 0
    while len(extra) < n_extra:
        extra.append(pool[i % len(pool)])
        i += 1
    out = np.array(extra[:n_extra], dtype=np.int64).reshape(-1, structure.n_parameters)
    out.setflags(write=False)
    return out
