"""Bookkeeping shared by the SLAMs built from replaceable units (FastSLAM 1.0 and 2.0, EKF-SLAM).

:class:`UnitTable` is the base of their ``...Steps`` tables (a frozen dataclass whose fields are
the units), :class:`UnitSlam` the base of the adapters (settings, units, ``with_steps``, the start
pose), :class:`LandmarkIndex` maps landmark ids to storage columns in order of first observation.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any, ClassVar

import numpy as np

from faultlab.errors import ConfigError
from faultlab.slam.protocol import SlamAdapter, as_start_pose, check_generator
from faultlab.slam.units import wrap_heading

__all__ = ["UnitTable", "UnitSlam", "LandmarkIndex"]


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


class UnitSlam(SlamAdapter):
    """Base of a SLAM adapter built from a table of replaceable units.

    A subclass sets :attr:`config_type`, :attr:`steps_type` and :attr:`reference_steps`.  Faults
    build a copy with other units through :meth:`with_steps`; the instance itself never changes
    its units.

    Parameters
    ----------
    config : config_type, optional
        The settings (default: ``config_type()``).
    steps : steps_type, optional
        The units (default: :attr:`reference_steps`), or a copy with one unit replaced (a fault).
    """

    config_type: ClassVar[type]
    steps_type: ClassVar[type]
    reference_steps: ClassVar[Any]

    def __init__(self, config=None, *, steps=None):
        config = self.config_type() if config is None else config
        steps = self.reference_steps if steps is None else steps
        name = type(self).__name__
        if not isinstance(config, self.config_type):
            raise ConfigError(f"{name}: config must be a {self.config_type.__name__}, got {type(config).__name__}")
        if not isinstance(steps, self.steps_type):
            raise ConfigError(f"{name}: steps must be a {self.steps_type.__name__}, got {type(steps).__name__}")
        self._config = config
        self._steps = steps

    @property
    def config(self):
        """The settings."""
        return self._config

    @property
    def steps(self):
        """The units."""
        return self._steps

    def with_steps(self, steps) -> "UnitSlam":
        """A new, un-reset instance with the same settings and other units."""
        return type(self)(self._config, steps=steps)

    def __repr__(self) -> str:
        return f"{type(self).__name__}({self._config!r}, replaced={list(self._steps.replaced())})"

    def _start_pose(self, pose, rng) -> np.ndarray:
        """The validated start pose (3,) with its heading wrapped; checks ``rng`` too."""
        p = as_start_pose(pose, where=self.name)
        check_generator(rng, where=self.name)
        p[2] = float(wrap_heading(p[2]))
        return p


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
