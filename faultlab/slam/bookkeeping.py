"""Bookkeeping shared by the SLAMs built from replaceable units (FastSLAM 1.0 and 2.0, EKF-SLAM).

:class:`UnitTable` is the base of their ``...Steps`` tables (a frozen dataclass whose fields are
the units), :class:`UnitSlam` the base of the adapters (settings, units, ``with_steps``, the start
pose), :class:`LandmarkIndex` maps landmark ids to storage columns in order of first observation.
The particle filters share the weight normalisation (:func:`normalise_log_weights`), the
resampling tail of a step (:func:`resample_tail`) and the best-particle estimate
(:func:`best_estimate`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any, Callable, ClassVar

import numpy as np

from faultlab.errors import ConfigError, SlamInputError, SlamOutputError
from faultlab.slam.protocol import Estimate, SlamAdapter
from faultlab.slam.units import wrap_heading
from faultlab.vocabulary import KNOWN_ASSOCIATION

__all__ = ["UnitTable", "UnitSlam", "LandmarkIndex", "normalise_log_weights", "resample_tail", "best_estimate"]


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
        if getattr(config, "association", KNOWN_ASSOCIATION) != self.association:
            raise ConfigError(f"{name}: config.association is {config.association!r} but {name} works with "
                              f"{self.association!r} data association (build SLAMs by name: "
                              f"faultlab.slam.registry.build_slam)")
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
        p = np.asarray(pose, dtype=float)
        if p.shape != (3,) or not np.all(np.isfinite(p)):
            raise SlamInputError(f"{self.name}: start pose must be 3 finite numbers (x, y, theta), got {pose!r}")
        if not isinstance(rng, np.random.Generator):
            raise SlamInputError(f"{self.name}: rng must be a numpy.random.Generator, got {type(rng).__name__}")
        p = p.copy()
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


def normalise_log_weights(logw: np.ndarray, *, name: str, step: int) -> np.ndarray:
    """Normalised log weights (log-sum-exp) of one particle filter.

    Parameters
    ----------
    logw : ndarray, shape (N,)
        Unnormalised log weights.
    name, step : str, int
        The SLAM and the step, for the message.

    Raises
    ------
    SlamOutputError
        If no weight is finite.
    """
    top = logw.max()
    if not math.isfinite(top):
        raise SlamOutputError(f"{name}: particle weights are not finite at step {step}")
    logw = logw - top
    logw -= math.log(np.exp(logw).sum())
    return logw


def resample_tail(steps, state, empty: bool, rng: np.random.Generator, config, *,
                  apply: Callable) -> tuple[Any, int]:
    """The end of a particle filter's step (Table 13.1, lines 24-28): N_eff, the decision, the copies.

    Calls ``steps.effective_sample_size`` on the weights ``exp(state.logw)``, then
    ``steps.resample(w, n_eff, empty, rng, config)`` and, if it returned indices, ``apply(state, indices)``.

    Returns
    -------
    state
        The state after resampling (``state`` itself if there was none).
    resampled : int
        1 if the particles were resampled, else 0.
    """
    w = np.exp(state.logw)
    n_eff = steps.effective_sample_size(w)
    idx = steps.resample(w, n_eff, empty, rng, config)
    if idx is None:
        return state, 0
    return apply(state, np.asarray(idx)), 1


def best_estimate(extract_map: Callable, state) -> Estimate:
    """The estimate of a particle filter: the map ``extract_map(state)`` and the highest-weight particle's pose.

    Ties (uniform weights right after a resampling) go to the lowest particle index.
    """
    ids, xy = extract_map(state)
    i = int(np.argmax(state.logw))
    return Estimate(state.poses[i].copy(), np.asarray(ids, dtype=np.int64), np.asarray(xy, dtype=float))
