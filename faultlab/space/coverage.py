"""Coverage (Sec. V): covered equivalence classes / all classes, per parameter and overall."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

import numpy as np
import pandas as pd

from faultlab.space.case import CaseSpec
from faultlab.space.parameters import ParameterSpace

__all__ = ["ParameterCoverage", "Coverage", "coverage"]


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
