"""Choosing classes and drawing values: the steps every suite builder shares.

- :func:`each_choice_cases`: the construction of Sec. VI -- for every case and parameter a class
  that is not yet covered, the value drawn inside it -- with uniform (systematic suite) or
  weighted (effect-guided suite) choice, honouring the space's constraints;
- :func:`cases_from_classes`: cases from given class indices (combinatorial suites), every value
  drawn inside its class by :meth:`~faultlab.space.parameters.Parameter.draw`.
"""

from __future__ import annotations

from typing import Mapping

import numpy as np

from faultlab.space.case import CaseSpec
from faultlab.space.parameters import ParameterSpace

__all__ = ["check_rng", "each_choice_cases", "cases_from_classes"]


def check_rng(rng) -> np.random.Generator:
    """``rng`` if it is a numpy Generator, else TypeError."""
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    return rng


def each_choice_cases(space: ParameterSpace, *, rng: np.random.Generator, n_cases: int,
                      weights: Mapping[str, np.ndarray] | None = None) -> list[CaseSpec]:
    """``n_cases`` cases that cover every class as early as possible (Sec. VI).

    For every case and parameter (in order) the class is chosen among the *candidates*:

    - while the parameter has uncovered classes: those (Sec. VI, "preferably one that is not
      yet included in the suite");
    - otherwise, with ``weights=None``: all classes while some other parameter is still
      uncovered, the least-covered classes once every class of every parameter is covered
      (the systematic suite's extra cases); with weights: all classes.

    The choice is uniform (``weights=None``) or proportional to the parameter's weights among
    the candidates (uniform if their weights are all zero).  With constraints, only classes that
    keep the case completable to an allowed case are eligible (the candidates among them if any,
    else all of them), so every case is allowed; full coverage within ``space.min_cases`` cases
    is then not guaranteed.  The value is drawn inside the class right after it is chosen.

    Parameters
    ----------
    space : ParameterSpace
    rng : numpy.random.Generator
    n_cases : int
    weights : mapping, optional
        Parameter name -> class weights, shape (n_classes,).

    Returns
    -------
    list of CaseSpec
    """
    structure = space.structure
    constrained = bool(structure.forbidden)
    counts = [np.zeros(p.n_classes, dtype=np.int64) for p in space.parameters]
    wts = None if weights is None else [np.asarray(weights[p.name], dtype=float) for p in space.parameters]
    cases = []
    for _ in range(n_cases):
        all_covered = all(bool(np.all(c > 0)) for c in counts)
        row = [-1] * structure.n_parameters
        values: dict = {}
        classes: dict = {}
        for j, p in enumerate(space.parameters):
            cnt = counts[j]
            if weights is None and all_covered:
                mask = cnt == cnt.min()
            elif np.any(cnt == 0):
                mask = cnt == 0
            else:
                mask = np.ones(p.n_classes, dtype=bool)
            if constrained:
                ok = np.array([structure.feasible(row[:j] + [c] + row[j + 1:]) for c in range(p.n_classes)])
                mask = mask & ok if np.any(mask & ok) else ok
            cand = np.flatnonzero(mask)
            w = None if weights is None else wts[j][cand]
            if w is None or not w.sum() > 0:
                k = int(cand[rng.integers(cand.size)])
            else:  # inverse CDF: a class of weight zero is never chosen
                cum = np.cumsum(w)
                k = int(cand[min(int(np.searchsorted(cum, rng.random() * cum[-1], side="right")), cand.size - 1)])
            values.update(p.draw(k, rng))
            classes[p.name] = k
            row[j] = k
            cnt[k] += 1
        cases.append(CaseSpec(values, classes))
    return cases


def cases_from_classes(space: ParameterSpace, rows: np.ndarray, *, rng: np.random.Generator) -> list[CaseSpec]:
    """One case per row of class indices, every value drawn inside its class.

    Parameters
    ----------
    rows : ndarray, shape (n_cases, n_parameters), int
        Class index of every parameter (space order), all >= 0.

    Returns
    -------
    list of CaseSpec
        Values drawn case by case, parameter by parameter, from ``rng``.
    """
    cases = []
    for r in np.asarray(rows, dtype=np.int64):
        values: dict = {}
        classes: dict = {}
        for p, k in zip(space.parameters, r):
            values.update(p.draw(int(k), rng))
            classes[p.name] = int(k)
        cases.append(CaseSpec(values, classes))
    return cases
