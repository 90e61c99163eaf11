"""Suite builders: *systematic* (Sec. VI), *random* and *fixed* (Sec. VII-C control suites)."""

from __future__ import annotations

import numpy as np

from faultlab.errors import ConfigError
from faultlab.space.case import FIXED_VALUES, CaseSpec
from faultlab.space.parameters import ParameterSpace, table1_space
from faultlab.vocabulary import SUITE_KINDS

__all__ = ["SUITE_KINDS", "build_suite", "systematic_suite", "random_suite", "fixed_suite"]



def _check_rng(rng) -> np.random.Generator:
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    return rng


def systematic_suite(space: ParameterSpace, *, rng: np.random.Generator,
                     n_cases: int | None = None) -> list[CaseSpec]:
    """Coverage-driven suite (Sec. VI).

    For every case and parameter, a class is chosen uniformly among the classes
    not yet covered (uniformly among all classes once the parameter is fully
    covered) and the value is drawn uniformly inside it.  Cases are added until
    every class of every parameter is covered, i.e. ``space.min_cases`` cases
    (5 with Table I).  If ``n_cases`` is larger, further cases choose uniformly
    among each parameter's least-covered classes.

    Raises
    ------
    ConfigError
        If ``n_cases`` is smaller than ``space.min_cases``.
    """
    _check_rng(rng)
    need = space.min_cases
    n = need if n_cases is None else int(n_cases)
    if n < need:
        raise ConfigError(f"a systematic suite needs at least {need} cases to cover every class of "
                          f"{space.source}, got n_cases={n}")
    counts = {p.name: np.zeros(p.n_classes, dtype=np.int64) for p in space.parameters}
    cases = []
    for i in range(n):
        all_covered = all(bool(np.all(c > 0)) for c in counts.values())
        values: dict = {}
        classes: dict = {}
        for p in space.parameters:
            cnt = counts[p.name]
            if all_covered:  # extra cases: least-covered classes first
                cand = np.flatnonzero(cnt == cnt.min())
            else:  # Sec. VI: "preferably one that is not yet included in the suite"
                cand = np.flatnonzero(cnt == 0)
                if cand.size == 0:
                    cand = np.arange(p.n_classes)
            k = int(cand[rng.integers(cand.size)])
            values.update(p.draw(k, rng))
            classes[p.name] = k
            cnt[k] += 1
        cases.append(CaseSpec(values, classes))
    return cases


def random_suite(space: ParameterSpace, *, rng: np.random.Generator, n_cases: int | None = None) -> list[CaseSpec]:
    """Control suite with every value drawn over its parameter's whole domain.

    The class is drawn with :meth:`Parameter.random_weights` (atoms ``1/n``
    each, the rest proportional to interval length), then the value uniformly
    inside it: a uniform draw over the union of the intervals.  ``n_cases``
    defaults to ``space.min_cases`` (the size of the systematic suite).
    """
    _check_rng(rng)
    n = _n_control(space, n_cases)
    cases = []
    for _ in range(n):
        values: dict = {}
        classes: dict = {}
        for p in space.parameters:
            k = int(rng.choice(p.n_classes, p=p.random_weights()))
            values.update(p.draw(k, rng))
            classes[p.name] = k
        cases.append(CaseSpec(values, classes))
    return cases


def fixed_suite(space: ParameterSpace, *, n_cases: int | None = None) -> list[CaseSpec]:
    """Control suite: every case has :data:`~faultlab.space.case.FIXED_VALUES`.

    Class indices are those of the values in ``space`` (-1 where outside).
    ``n_cases`` defaults to ``space.min_cases``.  The cases differ only in the
    scenario seed.
    """
    n = _n_control(space, n_cases)
    classes = space.classify(FIXED_VALUES)
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
    kind : {"systematic", "random", "fixed"}
    space : ParameterSpace, optional
        Table I when None.
    rng : numpy.random.Generator
        The only source of randomness (unused by ``fixed``).
    n_cases : int, optional
        Number of cases; default ``space.min_cases`` (5 with Table I).

    Raises
    ------
    ConfigError
        Unknown kind, or too few cases.
    """
    space = space or table1_space()
    if kind == "systematic":
        return systematic_suite(space, rng=rng, n_cases=n_cases)
    if kind == "random":
        return random_suite(space, rng=rng, n_cases=n_cases)
    if kind == "fixed":
        _check_rng(rng)
        return fixed_suite(space, n_cases=n_cases)
    raise ConfigError(f"unknown suite kind {kind!r} (expected one of {', '.join(SUITE_KINDS)})")
