"""Coverage (Sec. V): covered equivalence classes / all classes, per parameter and overall.

Besides the paper's class coverage (each-choice), the criteria of the combinatorial strategies
(:mod:`faultlab.space.strategies`):

- *t-wise class coverage* (:func:`t_wise_coverage`): covered / feasible combinations of classes of
  any ``t`` parameters (pairwise: t = 2); combinations that constraints rule out are not counted;
- *base-choice coverage* (:func:`base_choice_coverage`): covered / allowed (parameter, non-base
  class) pairs, a pair being covered by a case with that class and every other parameter at its
  base class.

All measures classify the cases' values against the space (recorded class indices are not trusted).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import numpy as np
import pandas as pd

from faultlab.errors import ConfigError
from faultlab.space.case import CaseSpec
from faultlab.space.covering import uncovered_tuples
from faultlab.space.parameters import ParameterSpace
from faultlab.space.strategies import base_choice_rows, t_wise_kind

__all__ = [
    "ParameterCoverage",
    "Coverage",
    "coverage",
    "class_matrix",
    "TupleCoverage",
    "t_wise_coverage",
    "BaseChoiceCoverage",
    "base_choice_coverage",
]


@dataclass(frozen=True)
class ParameterCoverage:
    """How often each class of one parameter occurs in a suite.

    Attributes
    ----------
    name : str
    class_names : tuple of str
    counts : tuple of int
        Number of cases per class, in class order.
    n_outside : int
        Cases whose value lies in no class (class -1).
    """

    name: str
    class_names: tuple[str, ...]
    counts: tuple[int, ...]
    n_outside: int = 0

    @property
    def n_classes(self) -> int:
        return len(self.counts)

    @property
    def covered(self) -> int:
        return sum(1 for c in self.counts if c > 0)

    @property
    def ratio(self) -> float:
        return self.covered / self.n_classes if self.n_classes else 1.0

    @property
    def uncovered(self) -> tuple[str, ...]:
        return tuple(n for n, c in zip(self.class_names, self.counts) if c == 0)


@dataclass(frozen=True)
class Coverage:
    """Coverage of a suite with respect to a parameter space.

    Attributes
    ----------
    parameters : tuple of ParameterCoverage
        In the space's parameter order.
    n_cases : int
    """

    parameters: tuple[ParameterCoverage, ...]
    n_cases: int

    @property
    def covered(self) -> int:
        return sum(p.covered for p in self.parameters)

    @property
    def total(self) -> int:
        return sum(p.n_classes for p in self.parameters)

    @property
    def ratio(self) -> float:
        """Overall coverage: covered classes of all parameters / all classes."""
        return self.covered / self.total if self.total else 1.0

    @property
    def per_parameter(self) -> dict[str, float]:
        return {p.name: p.ratio for p in self.parameters}

    def __getitem__(self, name: str) -> ParameterCoverage:
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    def table(self) -> pd.DataFrame:
        """One row per parameter plus an ``overall`` row.

        Columns: parameter, classes, covered, coverage (ratio in [0, 1]),
        counts (cases per class, ``name=count`` joined by spaces), uncovered.
        """
        rows = [{
            "parameter": p.name,
            "classes": p.n_classes,
            "covered": p.covered,
            "coverage": p.ratio,
            "counts": " ".join(f"{n}={c}" for n, c in zip(p.class_names, p.counts)),
            "uncovered": " ".join(p.uncovered),
        } for p in self.parameters]
        rows.append({"parameter": "overall", "classes": self.total, "covered": self.covered,
                     "coverage": self.ratio, "counts": f"{self.n_cases} cases", "uncovered": ""})
        return pd.DataFrame(rows, columns=["parameter", "classes", "covered", "coverage", "counts", "uncovered"])

    def __str__(self) -> str:
        df = self.table()
        df["coverage"] = [f"{100 * r:.0f} %" for r in df["coverage"]]
        return df.to_string(index=False)


def coverage(cases: Iterable[CaseSpec], space: ParameterSpace) -> Coverage:
    """Coverage of ``cases`` with respect to ``space``.

    Every case's values are classified against ``space`` (so cases drawn from
    another space, or written by hand, are judged by this space's classes; the
    class indices recorded in the cases are not trusted).

    Parameters
    ----------
    cases : iterable of CaseSpec
    space : ParameterSpace

    Returns
    -------
    Coverage
    """
    cases = list(cases)
    out = []
    for p in space.parameters:
        idx = np.array([p.classify(c.values) for c in cases], dtype=np.int64)
        counts = np.bincount(idx[idx >= 0], minlength=p.n_classes) if len(idx) else np.zeros(p.n_classes, int)
        out.append(ParameterCoverage(p.name, p.class_names, tuple(int(c) for c in counts),
                                     int(np.sum(idx < 0))))
    return Coverage(tuple(out), len(cases))


def class_matrix(cases: Iterable[CaseSpec], space: ParameterSpace) -> np.ndarray:
    """Class index of every case and parameter (values classified against ``space``).

    Returns
    -------
    ndarray, shape (n_cases, n_parameters), int64
        -1 where a value lies in no class.
    """
    cases = list(cases)
    return np.array([[p.classify(c.values) for p in space.parameters] for c in cases],
                    dtype=np.int64).reshape(len(cases), len(space.parameters))


@dataclass(frozen=True)
class TupleCoverage:
    """t-wise class coverage of a suite.

    Attributes
    ----------
    strength : int
        t (2 = pairwise).
    covered : int
        Feasible t-tuples of classes that some case contains.
    total : int
        Feasible t-tuples of classes (all combinations of classes of any t parameters that the
        constraints allow).
    excluded : int
        Combinations the constraints rule out (not in ``total``).
    """

    strength: int
    covered: int
    total: int
    excluded: int = 0

    @property
    def ratio(self) -> float:
        return self.covered / self.total if self.total else 1.0

    @property
    def name(self) -> str:
        return t_wise_kind(self.strength)

    def __str__(self) -> str:
        what = "class pairs" if self.strength == 2 else f"class {self.strength}-tuples"
        tail = f"; {self.excluded} excluded by constraints" if self.excluded else ""
        return (f"{self.name} coverage: {100 * self.ratio:.0f} % ({self.covered} of {self.total} "
                f"{what}{tail})")


def t_wise_coverage(cases: Iterable[CaseSpec], space: ParameterSpace, strength: int = 2) -> TupleCoverage:
    """t-wise class coverage of ``cases``: covered / feasible t-tuples of classes.

    Parameters
    ----------
    cases : iterable of CaseSpec
    space : ParameterSpace
    strength : int
        t, between 1 and the number of parameters (1 is class coverage).

    Returns
    -------
    TupleCoverage
    """
    structure = space.structure
    if not 1 <= int(strength) <= structure.n_parameters:
        raise ConfigError(f"a t-wise coverage needs a strength between 1 and {structure.n_parameters}, "
                          f"got {strength}")
    rows = class_matrix(cases, space)
    total = excluded = 0
    for params in structure.interactions(int(strength)):
        n = structure.tuples(params).shape[0]
        total += n
        excluded += int(np.prod([structure.sizes[p] for p in params])) - n
    missing = sum(len(c) for _, c in uncovered_tuples(structure, rows, int(strength)))
    return TupleCoverage(int(strength), total - missing, total, excluded)


@dataclass(frozen=True)
class BaseChoiceCoverage:
    """Base-choice coverage of a suite.

    Attributes
    ----------
    base : dict
        Parameter -> base class name.
    covered : int
        Allowed (parameter, non-base class) variations exercised by a case with every other
        parameter at its base class.
    total : int
        Allowed variations.
    base_case : bool
        Whether some case has every parameter at its base class.
    uncovered : tuple of (str, str)
    excluded : tuple of (str, str)
        Variations the constraints forbid (not in ``total``).
    """

    base: dict
    covered: int
    total: int
    base_case: bool
    uncovered: tuple[tuple[str, str], ...] = ()
    excluded: tuple[tuple[str, str], ...] = ()

    @property
    def ratio(self) -> float:
        return self.covered / self.total if self.total else 1.0

    def __str__(self) -> str:
        tail = f"; {len(self.excluded)} excluded by constraints" if self.excluded else ""
        return (f"base-choice coverage: {100 * self.ratio:.0f} % ({self.covered} of {self.total} one-parameter "
                f"variations of the base case{tail}; base case {'present' if self.base_case else 'missing'})")


def base_choice_coverage(cases: Iterable[CaseSpec], space: ParameterSpace,
                         base=None) -> BaseChoiceCoverage:
    """Base-choice coverage: covered / allowed (parameter, non-base class) variations.

    Parameters
    ----------
    cases : iterable of CaseSpec
    space : ParameterSpace
    base : mapping, optional
        Parameter -> base class name on top of the space's base classes.
    """
    rows, excluded = base_choice_rows(space, base)
    b = rows[0]
    got = class_matrix(cases, space)
    diff = got != b
    one = got[diff.sum(axis=1) == 1]
    seen = {(int(np.flatnonzero(r != b)[0]), int(r[r != b][0])) for r in one}
    wanted = [(int(np.flatnonzero(r != b)[0]), int(r[r != b][0])) for r in rows[1:]]
    params = space.parameters
    uncovered = tuple((params[j].name, params[j].class_names[k]) for j, k in wanted if (j, k) not in seen)
    return BaseChoiceCoverage(base={p.name: p.class_names[k] for p, k in zip(params, b)},
                              covered=len(wanted) - len(uncovered), total=len(wanted),
                              base_case=bool(np.any(~diff.any(axis=1))) if len(got) else False,
                              uncovered=uncovered, excluded=tuple(excluded))
