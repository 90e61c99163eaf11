"""Suite builders: *systematic* (Sec. VI), *random* and *fixed* (Sec. VII-C control suites).

:func:`faultlab.space.registry.build_suite` dispatches to every registered strategy.

The combinatorial strategies (base choice, t-wise, effect-guided) live in
:mod:`faultlab.space.strategies`.
"""

from __future__ import annotations

import numpy as np

from faultlab.errors import ConfigError
from faultlab.space.case import FIXED_VALUES, CaseSpec
from faultlab.space.choice import check_rng, each_choice_cases
from faultlab.space.parameters import ParameterSpace

__all__ = ["systematic_suite", "random_suite", "fixed_suite"]

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
