"""Suite builders: *systematic* (Sec. VI), *random* and *fixed* (Sec. VII-C control suites), and
the dispatch to every suite kind (:data:`faultlab.vocabulary.SUITE_KINDS`).

The combinatorial strategies (base choice, t-wise, effect-guided) live in
:mod:`faultlab.space.strategies`.
"""

from __future__ import annotations

import numpy as np

from faultlab.errors import ConfigError
from faultlab.space.case import FIXED_VALUES, CaseSpec
from faultlab.space.choice import check_rng, each_choice_cases
from faultlab.space.parameters import ParameterSpace, table1_space
from faultlab.space.strategies import base_choice_suite, effect_guided_suite, t_wise_strength, t_wise_suite
from faultlab.vocabulary import SUITE_KINDS

__all__ = ["SUITE_KINDS", "build_suite", "systematic_suite", "random_suite", "fixed_suite"]

#: Draws of a whole case before the random suite gives up on the constraints.
_MAX_REJECTIONS = 10_000


def systematic_suite(space: ParameterSpace, *, rng: np.random.Generator,
                     n_cases: int | None = None) -> list[CaseSpec]:
    """Coverage-driven suite (Sec. VI).

    For every case and parameter, a class is chosen uniformly among the classes
    not yet covered (uniformly among all classes once the parameter is fully
    covered) and the value is drawn uniformly inside it.  Cases are added until
    every class of every parameter is covered, i.e. ``space.min_cases`` cases
    (5 with Table I).  If ``n_cases`` is larger, further cases choose uniformly
    among each parameter's least-covered classes.  With constraints, only classes
    that keep the case allowed are chosen (:func:`~faultlab.space.choice.each_choice_cases`).

    Raises
    ------
    ConfigError
        If ``n_cases`` is smaller than ``space.min_cases``.
    """
    check_rng(rng)
    need = space.min_cases
    n = need if n_cases is None else int(n_cases)
    if n < need:
        raise ConfigError(f"a systematic suite needs at least {need} cases to cover every class of "
                          f"{space.source}, got n_cases={n}")
    return each_choice_cases(space, rng=rng, n_cases=n)


def random_suite(space: ParameterSpace, *, rng: np.random.Generator, n_cases: int | None = None) -> list[CaseSpec]:
    """Control suite with every value drawn over its parameter's whole domain.

    The class is drawn with :meth:`Parameter.random_weights` (atoms ``1/n``
    each, the rest proportional to interval length), then the value uniformly
    inside it: a uniform draw over the union of the intervals.  With constraints,
    a case whose classes are forbidden is drawn again (a uniform draw over the
    allowed cases).  ``n_cases`` defaults to ``space.min_cases`` (the size of the
    systematic suite).
    """
    check_rng(rng)
    n = _n_control(space, n_cases)
    structure = space.structure
    cases = []
    for _ in range(n):
        for _attempt in range(_MAX_REJECTIONS):
            values: dict = {}
            classes: dict = {}
            for p in space.parameters:
                k = int(rng.choice(p.n_classes, p=p.random_weights()))
                values.update(p.draw(k, rng))
                classes[p.name] = k
            if not structure.forbidden or structure.allows([classes[p.name] for p in space.parameters]):
                break
        else:
            raise ConfigError(f"{space.source}: the random suite drew {_MAX_REJECTIONS} forbidden cases in a "
                              f"row; the [constraints] leave too few allowed combinations for it")
        cases.append(CaseSpec(values, classes))
    return cases


def fixed_suite(space: ParameterSpace, *, n_cases: int | None = None) -> list[CaseSpec]:
    """Control suite: every case has :data:`~faultlab.space.case.FIXED_VALUES`.

    Class indices are those of the values in ``space`` (-1 where outside).
    ``n_cases`` defaults to ``space.min_cases``.  The cases differ only in the
    scenario seed.

    Raises
    ------
    ConfigError
        ``n_cases < 1``, or constraints forbid the fixed case.
    """
    n = _n_control(space, n_cases)
    classes = space.classify(FIXED_VALUES)
    if not space.structure.allows([classes[p.name] for p in space.parameters]):
        raise ConfigError(f"{space.source}: [constraints] forbid the fixed suite's case")
    return [CaseSpec(dict(FIXED_VALUES), dict(classes)) for _ in range(n)]


def _n_control(space: ParameterSpace, n_cases: int | None) -> int:
    n = space.min_cases if n_cases is None else int(n_cases)
    if n < 1:
        raise ConfigError(f"a suite needs at least one case, got n_cases={n}")
    return n


def build_suite(kind: str, space: ParameterSpace | None = None, *, rng: np.random.Generator,
                n_cases: int | None = None) -> list[CaseSpec]:
    """Build a suite of :class:`CaseSpec` s.

    Parameters
    ----------
    kind : str
        One of :data:`~faultlab.vocabulary.SUITE_KINDS`: ``systematic``, ``random``, ``fixed``,
        ``base-choice``, ``pairwise``, ``<t>-wise`` (e.g. ``3-wise``), ``effect-guided``.
        Base classes and class weights come from the space (``[base]``, ``[weights]``).
    space : ParameterSpace, optional
        Table I when None.
    rng : numpy.random.Generator
        The only source of randomness (unused by ``fixed``).
    n_cases : int, optional
        Number of cases; default: the builder's choice (``space.min_cases``, 5 with Table I,
        for systematic, random, fixed and effect-guided; the covering rows for base-choice and
        t-wise).

    Raises
    ------
    ConfigError
        Unknown kind, or too few cases.
    """
    space = space or table1_space()
    if kind not in SUITE_KINDS:
        raise ConfigError(f"unknown suite kind {kind!r} (expected one of {', '.join(SUITE_KINDS)})")
    check_rng(rng)
    if kind == "systematic":
        return systematic_suite(space, rng=rng, n_cases=n_cases)
    if kind == "random":
        return random_suite(space, rng=rng, n_cases=n_cases)
    if kind == "fixed":
        return fixed_suite(space, n_cases=n_cases)
    if kind == "base-choice":
        return base_choice_suite(space, rng=rng, n_cases=n_cases)
    if kind == "effect-guided":
        return effect_guided_suite(space, rng=rng, n_cases=n_cases)
    strength = t_wise_strength(kind)
    if strength is not None:
        return t_wise_suite(space, rng=rng, strength=strength, n_cases=n_cases)
    raise ConfigError(f"suite kind {kind!r} has no builder")  # a name added to SUITE_KINDS only
