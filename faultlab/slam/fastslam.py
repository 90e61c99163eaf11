"""A fast, vectorised reference FastSLAM 1.0, structured for fault injection.

The algorithm is FastSLAM 1.0 with known correspondences (Thrun, Burgard & Fox,
*Probabilistic Robotics*, Table 13.1), set up as in the paper (Sec. VII-A,
the PythonRobotics implementation): per-particle control noise in the
prediction, range-bearing landmarks with one EKF per landmark and particle,
low-variance resampling when ``N_eff < N / resample_ratio``.  As in the paper's
modified version an *empty update* (control exactly (0, 0) and no observation,
as during inactivity) adds no control noise and never resamples.

Units
-----
Each step of the algorithm is a field of :class:`FastSlamSteps`, a plain
function over arrays for all particles ``N`` and all ``k`` observations of a
step (the reference implementations, with the exact signatures and shapes,
are documented in :mod:`faultlab.slam.units`).  A fault replaces exactly one
field: ``dataclasses.replace(REFERENCE_STEPS, resample=naive)``.  Units get what
they need as explicit arguments (the wrap functions are passed in as
``wrap=steps.wrap_bearing`` / ``wrap=steps.wrap_heading``), so replacing a unit
changes that unit only.

====================== ======================================================================
unit                   signature (shapes)
====================== ======================================================================
sample_controls        ``(u (2,), n, rng, config) -> (N, 2)`` noisy controls per particle
motion_model           ``(poses (N,3), u (N,2), *, wrap) -> (N,3)``
wrap_heading           ``(a) -> a`` wrapped to [-pi, pi), used by the motion model
wrap_bearing           ``(a) -> a`` used only by innovation and init_landmarks
init_landmarks         ``(poses (N,3), z (k,2), Q (2,2), *, wrap) -> mu (N,k,2), P (N,k,2,2)``
classify_new           ``(seen (k,) bool, mu (N,k,2)) -> new (N,k) bool``
predict_measurement    ``(poses (N,3), mu (N,k,2)) -> z_hat (N,k,2), H (N,k,2,2)``
innovation             ``(z (k,2), z_hat (N,k,2), *, wrap) -> nu (N,k,2)``
innovation_covariance  ``(H, P (N,k,2,2), Q (2,2)) -> S (N,k,2,2)``
log_likelihood         ``(nu (N,k,2), S (N,k,2,2)) -> (N,k)``
combine_weights        ``(logw (N,), loglik (N,k), known (N,k) bool) -> logw (N,)``
ekf_update             ``(mu (N,k,2), P, H, S (N,k,2,2), nu (N,k,2)) -> mu, P``
effective_sample_size  ``(w (N,)) -> float``
resample               ``(w (N,), n_eff, empty, rng, config) -> indices (N,) or None``
apply_resample         ``(state, indices (N,)) -> state``
extract_map            ``(state) -> ids (M,), xy (M,2)``
====================== ======================================================================

Random streams (common random numbers by unit)
----------------------------------------------
The units that draw random numbers are listed in
:data:`faultlab.slam.units.STREAM_UNITS` (``sample_controls`` and ``resample``).
:meth:`FastSlam.reset` derives one generator per such unit from the SLAM's
``rng`` with :func:`faultlab.slam.streams.unit_streams` (keyed by the unit's
name), and every call of a unit receives its *own* stream as ``rng``.  A fault
that changes how one unit uses randomness (more draws, fewer draws, another
distribution) therefore leaves the draws of every other unit bit-identical:
with the same seed, a faulty run and the baseline share every random number
except those of the replaced unit (the runner gives every variant the same
seed per repetition).  A replacement unit must draw only from the ``rng`` it
is given.

One update (:meth:`FastSlam.update`) runs::

    u_i   = sample_controls(u, N, rng_sc, config)       # skipped for an empty update (u_i = u)
    x_i   = motion_model(x_i, u_i, wrap=wrap_heading)
    # if the step has observations z (k, 2) of ids with storage columns cols; all pairs at once:
    mu, P = the particles' stored means/covariances of cols   # zeros for never-seen ids
    new   = classify_new(seen, mu)
    mu0, P0 = init_landmarks(x_i, z[c], Q, wrap=wrap_bearing)  # c: observations with a new pair
    mu, P = mu0, P0 where new                            # so the next units see valid values
    z_hat, H = predict_measurement(x_i, mu)
    nu    = innovation(z, z_hat, wrap=wrap_bearing)
    S     = innovation_covariance(H, P, Q)
    logw  = combine_weights(logw, log_likelihood(nu, S), ~new)   # then normalised (logsumexp)
    mu', P' = ekf_update(mu, P, H, S, nu), but mu0, P0 where new -> written back to storage
    # always:
    n_eff = effective_sample_size(exp(logw))
    idx   = resample(exp(logw), n_eff, empty, rng_rs, config)
    state = apply_resample(state, idx) if idx is not None

where ``rng_sc`` and ``rng_rs`` are the streams of ``sample_controls`` and ``resample``.

The units after ``classify_new`` are called once per step with all ``k``
observations; ``combine_weights`` is not called in steps without observations.

Weights are kept as normalised **log** weights: with 100+ observations per
step the product of likelihoods underflows in linear form.

Storage and resampling
----------------------
The particles live in arrays: poses (N, 3), log weights (N,), landmark means
(N, cap, 2) and covariances (N, cap, 2, 2), one column per landmark id in
order of first observation (an id -> column lookup via ``searchsorted``;
capacity doubles when full).  Copying the landmark arrays at every resampling
would cost O(N L) memory traffic per step (58 MB for the largest Table I map),
so the storage is copy-on-write with a per-column ancestry index
``anc`` (N, cap): particle ``i`` reads column ``j`` from storage row
``anc[lineage[i], j]`` (see :class:`ParticleState`).  Resampling only composes
``lineage = lineage[idx]`` (O(N)); before the filter gathers the observed
columns it materialises the pending lineage once (``anc = anc[lineage]``, a
row gather of O(N C) int32, only after a resampling), and after the update it
writes every particle's new estimates of the observed columns into its own row
and points those columns of ``anc`` at it (all particles update the same
observed columns, so this is exact).  Inactivity (no observation) therefore
costs O(N) per step even with a resample-every-step variant, and an observed
step touches only the observed columns.

Memory layout (an implementation detail, invisible through the documented
shapes): the storage is component-major and particle-fastest, i.e. the mean
buffer is (2, cap, N) and the covariance buffer (2, 2, cap, N), so that the
N values of one landmark component are contiguous; the reference units'
(N, k, ...) outputs are views of (2, [2,] k, N) buffers in the same order.
Gathering the observed columns, the elementwise 2 x 2 algebra and the
write-back then all run over contiguous memory.

The estimate is the highest-weight particle: its pose and its map
(``extract_map``); ties (all weights are equal right after a resampling) go to
the lowest particle index.  This follows the "best particle" convention; since
resampling soon gives all particles a common ancestor, their maps are nearly
identical in practice (their map errors typically agree to a fraction of a mm).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Callable, ClassVar

import numpy as np

from faultlab.config import Option
from faultlab.errors import SlamInputError, SlamOutputError
from faultlab.slam import units as _units
from faultlab.slam.bookkeeping import UnitSlam, UnitTable
from faultlab.slam.noise import NoiseConfig
from faultlab.slam.sharing import correct_in_sharer_order
from faultlab.slam.units import STREAM_UNITS, ParticleState, landmark_rows
from faultlab.slam.protocol import Estimate, Observations
from faultlab.slam.streams import unit_streams

__all__ = ["FastSlamConfig", "FastSlamSteps", "REFERENCE_STEPS", "FastSlam", "Particles", "ParticleState",
           "landmark_rows"]


@dataclass(frozen=True)
class FastSlamConfig(NoiseConfig):
    """Settings of the reference FastSLAM 1.0 (defaults: the paper's setup, Sec. VII-A).

    The noise fields (``std_v``, ``std_omega``, ``std_range``, ``std_bearing``) are those of
    :class:`~faultlab.slam.noise.NoiseConfig`.

    Attributes
    ----------
    n_particles : int
        Number of particles N (>= 1).
    resample_ratio : float
        Resample when ``N_eff < N / resample_ratio`` (>= 1).
    """

    n_particles: int = 200
    resample_ratio: float = 1.5

    #: field -> its setting in an experiment's ``[slam]`` table (angles in degrees there).
    OPTIONS: ClassVar[dict[str, Option]] = {
        "n_particles": Option("particles", integer=True, bounds={"minimum": 1}),
        **NoiseConfig.OPTIONS,
        "resample_ratio": Option("resample_ratio", bounds={"minimum": 1.0}),
    }


@dataclass(frozen=True)
class FastSlamSteps(UnitTable):
    """The replaceable units of FastSLAM 1.0 (see the table in the module docstring).

    Every field is a plain function; :data:`REFERENCE_STEPS` holds the reference
    implementations from :mod:`faultlab.slam.units`.  Replace one unit with
    ``dataclasses.replace(steps, unit=new_function)``.  The units named in
    :attr:`stream_units` receive their own random stream as ``rng`` (see
    "Random streams" in the module docstring).
    """

    #: Units that draw random numbers, each from its own stream (:data:`faultlab.slam.units.STREAM_UNITS`).
    stream_units: ClassVar[tuple[str, ...]] = STREAM_UNITS

    sample_controls: Callable = _units.sample_controls
    motion_model: Callable = _units.motion_model
    wrap_heading: Callable = _units.wrap_heading
    wrap_bearing: Callable = _units.wrap_bearing
    init_landmarks: Callable = _units.init_landmarks
    classify_new: Callable = _units.classify_new
    predict_measurement: Callable = _units.predict_measurement
    innovation: Callable = _units.innovation
    innovation_covariance: Callable = _units.innovation_covariance
    log_likelihood: Callable = _units.log_likelihood
    combine_weights: Callable = _units.combine_weights
    ekf_update: Callable = _units.ekf_update
    effective_sample_size: Callable = _units.effective_sample_size
    resample: Callable = _units.resample
    apply_resample: Callable = _units.apply_resample
    extract_map: Callable = _units.extract_map


#: The reference FastSLAM 1.0 units.
REFERENCE_STEPS = FastSlamSteps()


@dataclass(frozen=True, eq=False)
class Particles:
    """A materialised copy of the particle set (for tests and diagnostics).

    Attributes
    ----------
    poses : ndarray, shape (N, 3)
    weights : ndarray, shape (N,)
        Normalised weights.
    landmark_ids : ndarray of int64, shape (C,)
        Ids in column order (order of first observation).
    means : ndarray, shape (N, C, 2)
    covariances : ndarray, shape (N, C, 2, 2)
    """

    poses: np.ndarray
    weights: np.ndarray
    landmark_ids: np.ndarray
    means: np.ndarray
    covariances: np.ndarray


class FastSlam(UnitSlam):
    """Reference FastSLAM 1.0 (known correspondences) as a :class:`SlamAdapter`.

    Parameters
    ----------
    config : FastSlamConfig
    steps : FastSlamSteps
        The units; :data:`REFERENCE_STEPS` or a copy with one unit replaced (a fault).
    """

    name = "fastslam1"
    config_type = FastSlamConfig
    steps_type = FastSlamSteps
    reference_steps = REFERENCE_STEPS

    def __init__(self, config: FastSlamConfig | None = None, *, steps: FastSlamSteps | None = None):
        super().__init__(config, steps=steps)
        self._Q = self._config.Q
        self._state: ParticleState | None = None
        self._streams: dict[str, np.random.Generator] = {}

    # -- SlamAdapter -----------------------------------------------------------------------------

    def reset(self, pose: np.ndarray, *, rng: np.random.Generator) -> None:
        p = self._start_pose(pose, rng)
        self._streams = unit_streams(rng, self._steps.stream_units)
        self._state = ParticleState.initial(p, self._config.n_particles)
        self._sorted_ids = np.empty(0, dtype=np.int64)  # lookup: sorted ids ...
        self._sorted_cols = np.empty(0, dtype=np.intp)  # ... and their columns
        self._t = 0
        self._n_resamples = 0
        self._ident = self._state.owner  # the identity map arange(N); lineage starts as the same object

    def update(self, control: np.ndarray, observations: Observations) -> None:
        if self._state is None:
            raise SlamInputError(f"{self.name}: update() called before reset()")
        steps, cfg, streams = self._steps, self._config, self._streams
        st = self._state
        n = st.n_particles
        k = len(observations)
        u = np.asarray(control, dtype=float)
        empty = k == 0 and u[0] == 0.0 and u[1] == 0.0
        # prediction (Table 13.1, line 4); an empty update adds no control noise
        u_i = np.broadcast_to(u, (n, 2)) if empty else steps.sample_controls(u, n, streams["sample_controls"], cfg)
        poses = steps.motion_model(st.poses, u_i, wrap=steps.wrap_heading)
        logw = st.logw
        if k:
            st, cols, seen = self._columns(st, observations.ids)
            st, logw = self._correct(st, poses, cols, seen, observations)
        st = st.replace(poses=poses, logw=logw)
        # resampling (Table 13.1, lines 24-28)
        w = np.exp(logw)
        n_eff = steps.effective_sample_size(w)
        idx = steps.resample(w, n_eff, empty, streams["resample"], cfg)
        if idx is not None:
            st = steps.apply_resample(st, np.asarray(idx))
            self._n_resamples += 1
        self._state = st
        self._t += 1

    def estimate(self) -> Estimate:
        st = self._require_state()
        ids, xy = self._steps.extract_map(st)
        i = int(np.argmax(st.logw))
        return Estimate(st.poses[i].copy(), np.asarray(ids, dtype=np.int64), np.asarray(xy, dtype=float))

    # -- diagnostics -----------------------------------------------------------------------------

    @property
    def n_resamples(self) -> int:
        """How many updates since :meth:`reset` resampled."""
        self._require_state()
        return self._n_resamples

    @property
    def streams(self) -> Mapping[str, np.random.Generator]:
        """The random stream of each unit in :attr:`FastSlamSteps.stream_units` (read-only mapping).

        The generators are the filter's own: drawing from them changes the run.
        """
        self._require_state()
        return MappingProxyType(self._streams)

    @property
    def state(self) -> ParticleState:
        """The current particle state (read-only use: its arrays are the filter's own)."""
        return self._require_state()

    def particles(self) -> Particles:
        """A materialised copy of all particles (means and covariances in column order)."""
        st = self._require_state()
        C = st.n_landmarks
        rows = landmark_rows(st, np.arange(C))
        cols = np.arange(C)[None, :]
        return Particles(st.poses.copy(), np.exp(st.logw), st.ids.copy(), st.mu[rows, cols].copy(),
                         st.P[rows, cols].copy())

    # -- internals -------------------------------------------------------------------------------

    def _require_state(self) -> ParticleState:
        if self._state is None:
            raise SlamInputError(f"{self.name}: reset() must be called first")
        return self._state

    def _columns(self, st: ParticleState, ids: np.ndarray) -> tuple[ParticleState, np.ndarray, np.ndarray]:
        """Columns of ``ids`` (k,), adding columns for unseen ids; returns (state, cols, seen)."""
        sid, scol = self._sorted_ids, self._sorted_cols
        if sid.size:
            pos = np.searchsorted(sid, ids)
            np.minimum(pos, sid.size - 1, out=pos)
            seen = sid[pos] == ids
            cols = scol[pos]  # valid where seen
        else:
            seen = np.zeros(ids.size, dtype=bool)
            cols = np.empty(ids.size, dtype=np.intp)
        if not seen.all():
            new_ids = ids[~seen]
            C = st.n_landmarks
            new_cols = np.arange(C, C + new_ids.size, dtype=np.intp)
            cols[~seen] = new_cols
            st = self._grow(st, C + new_ids.size)
            st = st.replace(ids=np.concatenate([st.ids, new_ids]))
            allid = np.concatenate([sid, new_ids])
            allcol = np.concatenate([scol, new_cols])
            order = np.argsort(allid, kind="stable")
            self._sorted_ids, self._sorted_cols = allid[order], allcol[order]
        return st, cols, seen

    @staticmethod
    def _grow(st: ParticleState, needed: int) -> ParticleState:
        cap = st.mu.shape[1]
        if needed <= cap:
            return st
        new_cap = max(2 * cap, needed)
        n = st.n_particles
        C = st.n_landmarks
        mu = _units.empty_means(n, new_cap)
        P = _units.empty_covariances(n, new_cap)
        anc = _units.initial_ancestry(n, new_cap)
        mu[:, :C] = st.mu[:, :C]
        P[:, :C] = st.P[:, :C]
        anc[:, :C] = st.anc[:, :C]
        return st.replace(mu=mu, P=P, anc=anc)

    @staticmethod
    def _storage(st: ParticleState) -> tuple[ParticleState, np.ndarray, np.ndarray, np.ndarray]:
        """Views of the storage: (state, mu (2, cap, N), P (2, 2, cap, N), anc (N, cap)).

        The reference keeps this layout (see :func:`faultlab.slam.units.empty_means`);
        storage that a replaced unit re-allocated in another layout is copied into it once.
        """
        n, cap = st.mu.shape[:2]
        mb = st.mu.transpose(2, 1, 0)
        pb = st.P.transpose(2, 3, 1, 0)
        ab = st.anc
        if not (mb.flags.c_contiguous and pb.flags.c_contiguous and ab.flags.c_contiguous
                and st.mu.dtype == np.float64 and st.P.dtype == np.float64 and st.anc.dtype == np.int32):
            mu = _units.empty_means(n, cap)
            P = _units.empty_covariances(n, cap)
            anc = _units.initial_ancestry(n, cap)
            mu[...] = st.mu
            P[...] = st.P
            anc[...] = st.anc
            st = st.replace(mu=mu, P=P, anc=anc)
            mb = st.mu.transpose(2, 1, 0)
            pb = st.P.transpose(2, 3, 1, 0)
            ab = st.anc
        return st, mb, pb, ab

    def _correct(self, st: ParticleState, poses: np.ndarray, cols: np.ndarray, seen: np.ndarray,
                 obs: Observations) -> tuple[ParticleState, np.ndarray]:
        """Correction for the step's observations; updates the storage in place.

        Returns the state (storage possibly re-laid out) and the normalised log weights.
        Internally the (particle, observation) arrays are handled as (k, N) blocks
        (the transpose of the units' (N, k) views), matching the storage layout.
        """
        steps, Q = self._steps, self._Q
        st, mu_store, P_store, anc = self._storage(st)
        n, cap = st.mu.shape[:2]
        k = cols.size
        # materialise pending resamplings (lineage -> identity), O(N C) ints, only after a resampling
        if st.lineage is not self._ident:
            C = st.n_landmarks
            anc[:, :C] = anc[st.lineage, :C]
            st = st.replace(lineage=self._ident)
        z = np.empty((k, 2))
        z[:, 0] = obs.ranges
        z[:, 1] = obs.bearings
        base = (cols * n)[:, None]
        flat = anc[:, cols].T + base  # (k, N) positions in the flattened storage
        mb = np.take(mu_store.reshape(2, cap * n), flat, axis=1)  # (2, k, N), a fresh copy
        pb = np.take(P_store.reshape(4, cap * n), flat, axis=1).reshape(2, 2, k, n)
        mu = mb.transpose(2, 1, 0)  # (N, k, 2) view
        P = pb.transpose(3, 2, 0, 1)  # (N, k, 2, 2) view
        if st.sequential_sharers and np.unique(st.owner).size < n:
            return self._correct_in_sharer_order(st, poses, cols, seen, z, mu, P, mu_store, P_store, anc)
        new = np.asarray(steps.classify_new(seen, mu), dtype=bool)
        new_cols = np.flatnonzero(new.any(axis=0)) if new.any() else None
        if new_cols is not None:
            # initialise where new (only the observations with at least one new pair)
            mu_i, P_i = steps.init_landmarks(poses, z[new_cols], Q, wrap=steps.wrap_bearing)
            mi = np.asarray(mu_i, dtype=float).transpose(2, 1, 0)
            pi = np.asarray(P_i, dtype=float).transpose(2, 3, 1, 0)
            m = new[:, new_cols].T
            mb[:, new_cols] = np.where(m, mi, mb[:, new_cols])
            pb[:, :, new_cols] = np.where(m, pi, pb[:, :, new_cols])
        zhat, H = steps.predict_measurement(poses, mu)
        nu = steps.innovation(z, zhat, wrap=steps.wrap_bearing)
        S = steps.innovation_covariance(H, P, Q)
        loglik = steps.log_likelihood(nu, S)
        logw = np.asarray(steps.combine_weights(st.logw, loglik, ~new), dtype=float)
        # normalise (log-sum-exp)
        top = logw.max()
        if not math.isfinite(top):
            raise SlamOutputError(f"{self.name}: particle weights are not finite at step {self._t}")
        logw = logw - top
        logw -= math.log(np.exp(logw).sum())
        mu_new, P_new = steps.ekf_update(mu, P, H, S, nu)
        mu_new = np.asarray(mu_new, dtype=float).transpose(2, 1, 0)  # (2, k, N)
        P_new = np.asarray(P_new, dtype=float).transpose(2, 3, 1, 0)  # (2, 2, k, N)
        if new_cols is not None:
            # new pairs keep their initial values
            mu_new = mu_new.copy()
            P_new = P_new.copy()
            m = new[:, new_cols].T
            mu_new[:, new_cols] = np.where(m, mb[:, new_cols], mu_new[:, new_cols])
            P_new[:, :, new_cols] = np.where(m, pb[:, :, new_cols], P_new[:, :, new_cols])
        # write every particle's estimate of the observed columns into its own storage row
        owner = st.owner
        if owner is self._ident or np.array_equal(owner, self._ident):
            # rows of the (component, column) x particle views of the storage: contiguous row copies
            rows = cols + (cap * np.arange(4))[:, None]
            mu_store.reshape(2 * cap, n)[rows[:2].ravel()] = mu_new.reshape(2 * k, n)
            P_store.reshape(4 * cap, n)[rows.ravel()] = P_new.reshape(4 * k, n)
        else:
            wflat = owner[None, :] + base
            mu_store.reshape(2, cap * n)[:, wflat] = mu_new
            P_store.reshape(4, cap * n)[:, wflat] = P_new.reshape(4, k, n)
        anc[:, cols] = owner[:, None]
        return st, logw

    def _correct_in_sharer_order(self, st: ParticleState, poses: np.ndarray, cols: np.ndarray, seen: np.ndarray,
                                 z: np.ndarray, mu: np.ndarray, P: np.ndarray, mu_store: np.ndarray,
                                 P_store: np.ndarray, anc: np.ndarray) -> tuple[ParticleState, np.ndarray]:
        """Correction when particles share storage rows and update them one after another.

        Only reached with ``state.sequential_sharers`` (shallow-copy resampling) and at least
        two particles on one row; see :mod:`faultlab.slam.sharing`.
        """
        n, cap = st.mu.shape[:2]
        k = cols.size
        logw, mu_new, P_new = correct_in_sharer_order(self._steps, st.logw, st.owner, poses, z, seen, mu, P,
                                                      self._Q)
        top = logw.max()
        if not math.isfinite(top):
            raise SlamOutputError(f"{self.name}: particle weights are not finite at step {self._t}")
        logw = logw - top
        logw -= math.log(np.exp(logw).sum())
        owner = np.asarray(st.owner)
        wflat = owner[None, :] + (cols * n)[:, None]  # sharers write equal values to their common row
        mu_store.reshape(2, cap * n)[:, wflat] = mu_new.transpose(2, 1, 0)
        P_store.reshape(4, cap * n)[:, wflat] = P_new.transpose(2, 3, 1, 0).reshape(4, k, n)
        anc[:, cols] = owner[:, None]
        return st, logw
