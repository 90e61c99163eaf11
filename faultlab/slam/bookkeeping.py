"""Bookkeeping shared by the SLAMs built from replaceable units (EKF-SLAM, FastSLAM 2.0).

:class:`UnitTable` is the base of their ``...Steps`` tables (a frozen dataclass whose fields are
the units), :class:`LandmarkIndex` maps landmark ids to storage columns in order of first
observation.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np

from faultlab.errors import ConfigError

__all__ = ["UnitTable", "LandmarkIndex"]


@dataclass(frozen=True)
class UnitTable:
    """Base of a table of replaceable units: every field is a plain function.

    A subclass declares the units as fields whose defaults are the reference implementations;
    ``dataclasses.replace(table, unit=new_function)`` replaces one unit (a fault).
    """

    def __post_init__(self) -> None:
        for f in fields(self):
            if not callable(getattr(self, f.name)):
                raise ConfigError(f"{type(self).__name__}.{f.name} must be callable, "
                                  f"got {getattr(self, f.name)!r}")

    @classmethod
    def unit_names(cls) -> tuple[str, ...]:
        """Names of the replaceable units, in algorithm order."""
        return tuple(f.name for f in fields(cls))

    def replaced(self) -> tuple[str, ...]:
        """Names of the units that differ from the reference (the field defaults)."""
        ref = type(self)()
        return tuple(n for n in self.unit_names() if getattr(self, n) is not getattr(ref, n))


class LandmarkIndex:
    """Landmark id -> storage column, columns numbered in order of first observation.

    Lookups are vectorised (``searchsorted`` on the sorted ids); ids may be any int64 values.
    """

    def __init__(self) -> None:
        self._ids = np.empty(0, dtype=np.int64)  # column order
        self._sorted_ids = np.empty(0, dtype=np.int64)
        self._sorted_cols = np.empty(0, dtype=np.intp)

    @property
    def ids(self) -> np.ndarray:
        """Ids in column order, shape (C,) (the index's own array: do not modify)."""
        return self._ids

    def __len__(self) -> int:
        return int(self._ids.size)

    def lookup(self, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Columns of ``ids`` (k,) and which of them are known.

        Returns
        -------
        cols : ndarray of intp, shape (k,)
            Valid where ``seen``.
        seen : ndarray of bool, shape (k,)
        """
        ids = np.asarray(ids, dtype=np.int64)
        sid = self._sorted_ids
        if not sid.size:
            return np.zeros(ids.size, dtype=np.intp), np.zeros(ids.size, dtype=bool)
        pos = np.minimum(np.searchsorted(sid, ids), sid.size - 1)
        return self._sorted_cols[pos], sid[pos] == ids

    def add(self, ids: np.ndarray) -> np.ndarray:
        """Give new, distinct ids (m,) the next columns; returns those columns (m,)."""
        ids = np.asarray(ids, dtype=np.int64)
        C = self._ids.size
        cols = np.arange(C, C + ids.size, dtype=np.intp)
        self._ids = np.concatenate([self._ids, ids])
        allid = np.concatenate([self._sorted_ids, ids])
        allcol = np.concatenate([self._sorted_cols, cols])
        order = np.argsort(allid, kind="stable")
        self._sorted_ids, self._sorted_cols = allid[order], allcol[order]
        return cols
