"""Bookkeeping shared by the SLAMs built from replaceable units (FastSLAM 1.0 and 2.0, EKF-SLAM).

:class:`UnitTable` is the base of their ``...Steps`` tables (a frozen dataclass whose fields are
the units), :class:`UnitSlam` the base of the adapters (settings, units, ``with_steps``, the start
pose), :class:`LandmarkIndex` maps landmark ids to storage columns in order of first observation.
The particle filters share the weight normalisation (:func:`normalise_log_weights`), the
resampling tail of a step (:func:`resample_tail`), the best-particle estimate
(:func:`best_estimate`), the per-step pose of the trajectory they report (:func:`best_pose`,
:class:`TrajectoryLog`), the linearisation of the measurement model (:func:`linearise`) and, for
the ones that run one filter at a time, their bookkeeping (:class:`ParticleFilterSlam`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from typing import Any, Callable, ClassVar

import numpy as np

from faultlab.errors import ConfigError, SlamInputError, SlamOutputError
from faultlab.slam.protocol import Estimate, SlamAdapter, as_start_pose, check_generator
from faultlab.slam import twins as _twins
from faultlab.slam.streams import unit_streams
from faultlab.slam.units import wrap_heading
from faultlab.vocabulary import KNOWN_ASSOCIATION

__all__ = ["UnitTable", "UnitSlam", "ParticleFilterSlam", "LandmarkIndex", "step_kind", "grown_capacity",
           "normalise_log_weights", "resample_tail", "best_estimate", "linearise", "sample_pose", "best_pose",
           "TrajectoryLog"]


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
        # what the filter calls: the reference units' compiled twins, every other unit as given
        self._run_steps = _twins.twinned(steps) if _twins.JIT_ENABLED else steps

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


class ParticleFilterSlam(UnitSlam):
    """Base of a particle-filter SLAM that runs one filter at a time on a state object.

    The state (``self._state``) has ``poses`` (N, 3) and normalised log weights ``logw`` (N,) and
    a ``replace(**fields)`` method.  A subclass names the units of its table that give the map
    (:attr:`map_unit`) and apply a resampling (:attr:`apply_unit`), and the units that draw random
    numbers (:attr:`random_units`), each of which gets its own stream in :meth:`_begin`.
    """

    #: Units that draw random numbers, each from its own stream.
    random_units: ClassVar[tuple[str, ...]]
    #: The unit ``(state) -> (ids (M,), xy (M, 2))`` of the map estimate.
    map_unit: ClassVar[str]
    #: The unit ``(state, indices (N,)) -> state`` that applies a resampling.
    apply_unit: ClassVar[str]

    def __init__(self, config=None, *, steps=None):
        super().__init__(config, steps=steps)
        self._state = None

    def _begin(self, state, rng: np.random.Generator) -> None:
        """Start from ``state`` with the unit streams derived from ``rng``."""
        self._streams = unit_streams(rng, self.random_units)
        self._state = state
        self._t = 0
        self._n_resamples = 0
        self._trajectory = TrajectoryLog()

    def estimate(self) -> Estimate:
        """The map and pose of the highest-weight particle (:func:`best_estimate`); the trajectory is
        that particle's pose after every step (:func:`best_pose`)."""
        return best_estimate(getattr(self._steps, self.map_unit), self._require_state(),
                             trajectory=self._trajectory.poses())

    @property
    def n_resamples(self) -> int:
        """How many updates since :meth:`reset` resampled."""
        self._require_state()
        return self._n_resamples

    @property
    def state(self):
        """The current particle state (read-only use: its arrays are the filter's own)."""
        return self._require_state()

    def _require_state(self):
        if self._state is None:
            raise SlamInputError(f"{self.name}: reset() must be called first")
        return self._state

    def _begin_step(self, control: np.ndarray, observations):
        """``(state, u (2,), u_n (N, 2), k, empty)`` at the start of an update (see :func:`step_kind`)."""
        st = self._require_state()
        u, k, empty = step_kind(control, observations)
        return st, u, np.broadcast_to(u, (st.n_particles, 2)), k, empty

    def _finish(self, state, poses: np.ndarray, logw: np.ndarray, empty: bool) -> None:
        """Store the step's poses and weights in ``state``, then the resampling tail; the step is over."""
        st = state.replace(poses=np.asarray(poses, dtype=float), logw=logw)
        st, resampled = resample_tail(self._steps, st, empty, self._streams["resample"], self._config,
                                      apply=getattr(self._steps, self.apply_unit))
        self._n_resamples += resampled
        self._state = st
        self._trajectory.append(st.poses[int(np.argmax(st.logw))])
        self._t += 1


def grown_capacity(capacity: int, needed: int) -> int | None:
    """The new capacity of a landmark store that must hold ``needed`` landmarks: None if ``capacity``
    suffices, else twice it (or ``needed`` if that is more), so that growing costs O(1) amortised."""
    if needed <= capacity:
        return None
    return max(2 * capacity, needed)


def step_kind(control: np.ndarray, observations) -> tuple[np.ndarray, int, bool]:
    """``(u, k, empty)`` of one step: the control as floats (2,), the number of observations and
    whether it is an *empty update* (control exactly (0, 0) and no observation)."""
    k = len(observations)
    u = np.asarray(control, dtype=float)
    return u, k, k == 0 and u[0] == 0.0 and u[1] == 0.0


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


def best_estimate(extract_map: Callable, state, *, trajectory: np.ndarray | None = None) -> Estimate:
    """The estimate of a particle filter: the map ``extract_map(state)`` and the highest-weight particle's pose.

    Ties (uniform weights right after a resampling) go to the lowest particle index.  ``trajectory``
    (T, 3), the filter's pose after every step, is passed on as the estimate's trajectory.
    """
    ids, xy = extract_map(state)
    i = int(np.argmax(state.logw))
    return Estimate(state.poses[i].copy(), np.asarray(ids, dtype=np.int64), np.asarray(xy, dtype=float),
                    trajectory=trajectory)


def best_pose(poses: np.ndarray, logw: np.ndarray) -> np.ndarray:
    """The pose of each filter's highest-weight particle (ties: the lowest index), as :func:`best_estimate` takes it.

    The pose a particle filter reports per step for its trajectory, so that the trajectory ends in
    the estimate's pose.  Right after a resampling the weights are uniform and this is the first
    resampled particle: a draw from the posterior rather than its mean (the mean costs a circular
    mean of every particle's heading per step, an eighth of a step of the reference FastSLAM).

    Parameters
    ----------
    poses : ndarray, shape (..., N, 3)
        Particle poses (x, y, theta), m and rad; leading axes index independent filters.
    logw : ndarray, shape (..., N)
        Log weights of each filter.

    Returns
    -------
    ndarray, shape (..., 3)
        A new array.
    """
    i = np.argmax(logw, axis=-1)
    return np.take_along_axis(poses, i[..., None, None], axis=-2)[..., 0, :]


class TrajectoryLog:
    """The poses a SLAM reports after each step, appended one step at a time (amortised O(1) per step).

    Rows are kept in a buffer that doubles when full; :meth:`poses` returns a copy of the rows so far.
    """

    def __init__(self, width: tuple[int, ...] = (3,)) -> None:
        self._buf = np.empty((64, *width))
        self._n = 0

    def __len__(self) -> int:
        return self._n

    def append(self, pose: np.ndarray) -> None:
        """Add the pose(s) of the step just processed, shape ``width``."""
        if self._n == self._buf.shape[0]:
            self._buf = np.concatenate([self._buf, np.empty_like(self._buf)])
        self._buf[self._n] = pose
        self._n += 1

    def poses(self) -> np.ndarray:
        """The poses so far, shape (T, *width) (a copy)."""
        return self._buf[:self._n].copy()


def linearise(steps, poses: np.ndarray, mu: np.ndarray, P: np.ndarray, z: np.ndarray,
              Q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The measurement model at ``poses``: ``(H, nu, S)`` from the units ``predict_measurement``,
    ``innovation`` (with ``wrap_bearing``) and ``innovation_covariance``, called in that order.

    Shapes: poses (N, 3), mu (N, k, 2), P (N, k, 2, 2), z (k, 2) -> H (N, k, 2, 2), nu (N, k, 2), S (N, k, 2, 2).
    """
    zhat, H = steps.predict_measurement(poses, mu)
    nu = steps.innovation(z, zhat, wrap=steps.wrap_bearing)
    S = steps.innovation_covariance(H, P, Q)
    return H, nu, S


def sample_pose(steps, poses: np.ndarray, u_n: np.ndarray, lam: np.ndarray, eta: np.ndarray, M: np.ndarray,
                rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """FastSLAM 2.0's pose draw (Table 13.2, lines 12-16): ``proposal``, ``sample_proposal``, ``motion_model``.

    Returns the sampled poses (N, 3) and the proposal covariance (N, 2, 2) (for the weight).
    """
    mean, cov = steps.proposal(lam, eta, M)
    du = np.asarray(steps.sample_proposal(mean, cov, rng), dtype=float)
    return steps.motion_model(poses, u_n + du, wrap=steps.wrap_heading), cov
