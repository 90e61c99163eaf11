"""Test-design strategies from combinatorial testing over the classes of Table I.

The paper's systematic suite is *each-choice*: every class of every parameter in some case
(Sec. VI).  It calls combinatorial testing complementary (Sec. III); the combinatorial-testing
literature ranks each-choice below *base choice* and *pairwise* (Grindal et al., EMSE 2006).
The builders here produce those suites over the same classes, so that suites of equal size can be
compared:

- :func:`base_choice_suite`: a base case plus one case per non-base class, varying one
  parameter at a time (kind ``base-choice``);
- :func:`t_wise_suite`: every feasible combination of classes of every ``t`` parameters in
  some case (kinds ``pairwise`` for t = 2 and ``<t>-wise``, e.g. ``3-wise``);
- :func:`effect_guided_suite`: each-choice first, then classes in proportion to weights
  estimated from an earlier campaign (kind ``effect-guided``).

The strength of a t-wise suite is part of its kind's name because the kind is the suite's
identity in a campaign: its seeds, its rows in the results and its place in reports.

Every builder honours the space's constraints (:mod:`faultlab.space.constraints`), takes an
explicit ``rng`` (same rng, same suite) and draws the value of every chosen class as the
systematic suite does (:meth:`~faultlab.space.parameters.Parameter.draw`).  Sizes: a
combinatorial suite has a minimum (its covering rows); a smaller ``n_cases`` is an error naming
it, a larger one adds rows that greedily cover tuples of the next strengths (pairs after base
choice, (t+1)-tuples after t-wise; :func:`faultlab.space.covering.extend_rows`).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Mapping

import numpy as np

from faultlab.errors import ConfigError
from faultlab.space.case import CaseSpec
from faultlab.space.choice import cases_from_classes, check_rng, each_choice_cases
from faultlab.space.covering import covering_array, extend_rows
from faultlab.space.parameters import ParameterSpace
from faultlab.space.settings import read_class_weights

__all__ = [
    "t_wise_strength",
    "t_wise_kind",
    "base_choice_rows",
    "base_choice_suite",
    "t_wise_suite",
    "effect_guided_suite",
]

_T_WISE = re.compile(r"^([1-9][0-9]*)-wise$")


def t_wise_strength(kind: str) -> int | None:
    """The strength of a t-wise suite kind (``pairwise`` -> 2, ``3-wise`` -> 3), else None.

    ``2-wise`` is not a kind: the pairwise suite has one name.
    """
    if kind == "pairwise":
        return 2
    m = _T_WISE.match(kind)
    if m and int(m.group(1)) >= 3:
        return int(m.group(1))
    return None


def t_wise_kind(strength: int) -> str:
    """The kind name of a t-wise suite (inverse of :func:`t_wise_strength`)."""
    if strength < 2:
        raise ConfigError(f"a t-wise suite needs a strength of at least 2, got {strength}")
    return "pairwise" if strength == 2 else f"{strength}-wise"


def _size(n_cases: int | None, need: int, what: str, space: ParameterSpace) -> int:
    n = need if n_cases is None else int(n_cases)
    if n < need:
        raise ConfigError(f"a {what} suite needs at least {need} cases for {space.source}, got n_cases={n}")
    return n


# ---------------------------------------------------------------------------
# Base choice
# ---------------------------------------------------------------------------

def base_choice_rows(space: ParameterSpace, base: Mapping[str, str] | None = None
                     ) -> tuple[np.ndarray, list[tuple[str, str]]]:
    """The class rows of the base-choice suite and the variations constraints exclude.

    Parameters
    ----------
    space : ParameterSpace
    base : mapping, optional
        Parameter -> base class name, on top of the space's base classes
        (:meth:`ParameterSpace.base_classes`).

    Returns
    -------
    rows : ndarray, shape (1 + n_variations, n_parameters), int64
        The base case, then for every parameter (in order) and every non-base class (in class
        order) the base case with that parameter at that class, unless a constraint forbids it.
    excluded : list of (str, str)
        The (parameter, class) variations that constraints forbid.

    Raises
    ------
    ConfigError
        No base class for a parameter, or the base case itself is forbidden.
    """
    if base:
        space = space.with_base(base)
    b = space.base_classes()
    structure = space.structure
    row0 = np.array([b[p.name] for p in space.parameters], dtype=np.int64)
    if not structure.allows(row0):
        names = ", ".join(f"{p.name}={p.class_names[k]}" for p, k in zip(space.parameters, row0))
        raise ConfigError(f"{space.source}: the base case ({names}) is forbidden by [constraints]; "
                          f"choose other base classes in [base]")
    rows, excluded = [row0], []
    for j, p in enumerate(space.parameters):
        for k in range(p.n_classes):
            if k == row0[j]:
                continue
            r = row0.copy()
            r[j] = k
            if structure.allows(r):
                rows.append(r)
            else:
                excluded.append((p.name, p.class_names[k]))
    return np.array(rows, dtype=np.int64), excluded


def base_choice_suite(space: ParameterSpace, *, rng: np.random.Generator, n_cases: int | None = None,
                      base: Mapping[str, str] | None = None) -> list[CaseSpec]:
    """Base-choice suite: the base case, then one parameter varied at a time.

    Parameters
    ----------
    space : ParameterSpace
    rng : numpy.random.Generator
        Draws the values inside the classes (and nothing else).
    n_cases : int, optional
        Default and minimum: 1 + the number of allowed variations (22 with Table I).  Extra cases
        greedily cover class pairs not yet covered, then triples, ...
    base : mapping, optional
        Parameter -> base class name (default: the space's ``[base]``, else the class of the
        fixed suite's value).

    Returns
    -------
    list of CaseSpec
        Case 1 is the base case; then the variations in parameter and class order.
    """
    check_rng(rng)
    rows, _ = base_choice_rows(space, base)
    n = _size(n_cases, len(rows), "base-choice", space)
    if n > len(rows):
        extra = extend_rows(space.structure, tuple(map(tuple, rows.tolist())), n - len(rows), 2)
        rows = np.concatenate([rows, extra])
    return cases_from_classes(space, rows, rng=rng)


# ---------------------------------------------------------------------------
# t-wise
# ---------------------------------------------------------------------------

def t_wise_suite(space: ParameterSpace, *, rng: np.random.Generator, strength: int = 2,
                 n_cases: int | None = None) -> list[CaseSpec]:
    """t-wise suite: every feasible combination of classes of any ``strength`` parameters.

    The covering rows come from :func:`faultlab.space.covering.covering_array` (canonical for
    the space's classes and constraints, so the minimum size does not depend on ``rng``).
    ``rng`` then relabels the classes of every parameter no constraint names (a random
    permutation per parameter: still a covering array, a different one per run), shuffles the
    rows and draws the values.

    Parameters
    ----------
    space : ParameterSpace
    rng : numpy.random.Generator
    strength : int
        t, from 2 to the number of parameters.
    n_cases : int, optional
        Default and minimum: the number of covering rows (:func:`faultlab.space.registry.min_suite_size`; for Table I
        with covertable 3.2: pairwise 20, 3-wise 82, 4-wise 292 cases).  Extra cases greedily
        cover (t+1)-tuples, then (t+2)-tuples, ...

    Returns
    -------
    list of CaseSpec
        The covering rows (shuffled), then the extra rows.
    """
    check_rng(rng)
    if not 2 <= int(strength) <= len(space.parameters):
        raise ConfigError(f"a t-wise suite needs a strength between 2 and {len(space.parameters)}, "
                          f"got {strength}")
    structure = space.structure
    rows = covering_array(structure, int(strength))
    n = _size(n_cases, len(rows), t_wise_kind(int(strength)), space)
    extra = extend_rows(structure, tuple(map(tuple, rows.tolist())), n - len(rows), int(strength) + 1) \
        if n > len(rows) else np.empty((0, structure.n_parameters), dtype=np.int64)
    fixed = set(structure.constrained)
    perms = [np.arange(k) if j in fixed else rng.permutation(k) for j, k in enumerate(structure.sizes)]
    order = rng.permutation(len(rows))
    out = np.concatenate([rows[order], extra])
    out = np.stack([perms[j][out[:, j]] for j in range(structure.n_parameters)], axis=1) if len(out) else out
    return cases_from_classes(space, out, rng=rng)


# ---------------------------------------------------------------------------
# Effect-guided
# ---------------------------------------------------------------------------

def _weights(space: ParameterSpace, weights) -> dict[str, np.ndarray]:
    if weights is None:
        got = space.class_weights()
        if got is None:
            raise ConfigError(f"{space.source}: an effect-guided suite needs class weights ([weights] in the "
                              f"space file, or a CSV file with the columns parameter, class, weight)")
        return got
    if isinstance(weights, (str, Path)):
        return space.with_weights(read_class_weights(weights), source=str(weights)).class_weights()
    return space.with_weights(weights, source="weights").class_weights()


def effect_guided_suite(space: ParameterSpace, *, rng: np.random.Generator, n_cases: int | None = None,
                        weights: Mapping[str, Mapping[str, float]] | str | Path | None = None
                        ) -> list[CaseSpec]:
    """Effect-guided suite: each-choice first, the remaining cases by class weight.

    Every case chooses, for every parameter, a class not yet covered while there is one (in
    proportion to the weights among those), and afterwards any class in proportion to the
    weights (:func:`faultlab.space.choice.each_choice_cases`).  With ``n_cases >=
    space.min_cases`` (and no constraint in the way) every class is covered.

    Parameters
    ----------
    space : ParameterSpace
    rng : numpy.random.Generator
    n_cases : int, optional
        Any size >= 1; default ``space.min_cases``.
    weights : mapping or path, optional
        ``{parameter: {class: weight}}`` or a CSV file (columns parameter, class, weight); by
        default the space's ``[weights]``.  Parameters not listed get equal weights.
        :func:`faultlab.space.settings.weights_from_effects` derives weights from detection
        rates or odds ratios.

    Raises
    ------
    ConfigError
        No weights, malformed weights, ``n_cases < 1``.
    """
    check_rng(rng)
    w = _weights(space, weights)
    n = space.min_cases if n_cases is None else int(n_cases)
    if n < 1:
        raise ConfigError(f"a suite needs at least one case, got n_cases={n}")
    return each_choice_cases(space, rng=rng, n_cases=n, weights=w)
