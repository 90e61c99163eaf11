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
:data:`faultlab.slam.contract.STREAM_UNITS` (``sample_controls`` and ``resample``).
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
When every unit is the reference and the compiled twins are on, the filter does this work in a
few compiled passes per step instead (:meth:`FastSlam._update_reference`,
:func:`faultlab.slam.twins.correct_observed`), bit for bit the same.

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
row gather of O(N C) int16, only after a resampling), and after the update it
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

Batched repetitions
-------------------
:meth:`FastSlam.reset_batch` starts ``K`` independent filters (repetitions), one
per generator, and every :meth:`~FastSlam.update` advances all of them;
:meth:`FastSlam.estimates` returns one estimate per repetition
(:func:`faultlab.slam.protocol.run_slam_batch` drives a whole scenario).  All
repetitions of a test case see the same controls and observations, so the
``K`` filters are stored as one particle set of ``K N`` particles whose
landmark columns align: filter ``b`` is rows ``b N .. (b + 1) N - 1`` of the
poses and weights and particles ``b N ..`` of the storage buffers, with its own
ancestry rows (numbered from 0 within the filter), lineage and owner.  The
particle units (:data:`faultlab.slam.contract.PARTICLE_UNITS`) run once per step
on all ``K N`` particles (in blocks of at most :attr:`FastSlam.block_pairs`
particle-observation pairs), which removes the per-call overhead of ``K``
small calls; the per-filter units
(:data:`faultlab.slam.contract.FILTER_UNITS`: ``sample_controls``,
``combine_weights``, ``effective_sample_size``, ``resample``,
``apply_resample``, ``extract_map``) and the weight normalisation run once per
filter, each filter with its own streams derived from its own generator.  Every
elementwise result is computed by the same operations on the same values as in
a single filter, so repetition ``b`` is bit-identical to a filter reset with
the same generator (tested for the reference and every built-in fault).
:meth:`FastSlam.reset` is the batch of one: the single-filter path is this
same code.  Which units see which particles, and the :func:`~faultlab.slam.contract.filter_wise`
fallback for a particle unit that looks across particles, are documented in
:mod:`faultlab.slam.units`.

A failure that belongs to one filter -- non-finite weights, or an exception in
a unit called for that filter alone -- ends that repetition only (its entry of
:meth:`~FastSlam.estimates` is the exception a single run would raise) and its
particles leave the batch.  An exception in a unit that sees several filters
propagates: the caller reruns the repetitions one at a time
(:class:`BatchUnsupported` is raised when a replaced per-filter unit returns
an output that cannot be stacked).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Callable, ClassVar

import numpy as np

from faultlab.config import Option
from faultlab.errors import SlamInputError, SlamOutputError
from faultlab.slam import associationunits as _associationunits
from faultlab.slam import units as _units
from faultlab.slam.bookkeeping import (TrajectoryLog, UnitSlam, UnitTable, best_estimate, best_pose, grown_capacity,
                                      normalise_log_weights,
                                       resample_tail, step_kind)
from faultlab.slam.contract import STREAM_UNITS
from faultlab.slam.noise import NoiseConfig
from faultlab.slam.sharing import correct_in_sharer_order
from faultlab.slam import particles as _particles
from faultlab.slam.particles import ParticleState, landmark_rows
from faultlab.slam.protocol import Estimate, Observations
from faultlab.slam.streams import unit_streams
from faultlab.slam import twins as _twins
from faultlab.vocabulary import ASSOCIATIONS, KNOWN_ASSOCIATION, PAPER_PROTOCOL

__all__ = ["FastSlamConfig", "FastSlamSteps", "REFERENCE_STEPS", "FastSlam", "Particles", "ParticleState",
           "landmark_rows", "materialise_particles", "BatchUnsupported"]


@dataclass(frozen=True)
class FastSlamConfig(NoiseConfig):
    """Settings of the reference FastSLAM 1.0 (defaults: the paper's setup, Sec. VII-A).

    The noise fields (``std_v``, ``std_omega``, ``std_range``, ``std_bearing``) are those of
    :class:`~faultlab.slam.noise.NoiseConfig`.

    Attributes
    ----------
    particles : int
        Number of particles N (>= 1).
    resample_ratio : float
        Resample when ``N_eff < N / resample_ratio`` (>= 1).
    association : {"known", "unknown"}
        ``"known"``: observations carry landmark ids (this module's filter); ``"unknown"``: the ids
        are hidden and every particle associates observations by maximum likelihood
        (:mod:`faultlab.slam.association`).  Left out of the options while ``"known"``.
    new_landmark_sigmas : float
        Unknown association only: an observation starts a new landmark when its best landmark's
        likelihood is below that of an innovation this many standard deviations long under the
        measurement noise (:func:`faultlab.slam.associationunits.new_landmark_log_likelihood`), >= 0.
        Left out of the options while at its default.
    """

    particles: int = PAPER_PROTOCOL["particles"]
    resample_ratio: float = 1.5
    association: str = KNOWN_ASSOCIATION
    new_landmark_sigmas: float = 3.0

    #: field -> its setting in an experiment's ``[slam]`` table (angles in degrees there).
    OPTIONS: ClassVar[dict[str, Option]] = {
        "particles": Option("particles", integer=True, bounds={"minimum": 1}),
        **NoiseConfig.OPTIONS,
        "resample_ratio": Option("resample_ratio", bounds={"minimum": 1.0}),
        "association": Option("association", choices=ASSOCIATIONS, omit_default=True),
        "new_landmark_sigmas": Option("new_landmark_sigmas", bounds={"minimum": 0.0}, omit_default=True),
    }

    @property
    def log_p0(self) -> float:
        """The new-landmark log likelihood of unknown association (:func:`~faultlab.slam.associationunits.new_landmark_log_likelihood`)."""
        return _associationunits.new_landmark_log_likelihood(self.Q, self.new_landmark_sigmas)


@dataclass(frozen=True)
class FastSlamSteps(UnitTable):
    """The replaceable units of FastSLAM 1.0 (see the table in the module docstring).

    Every field is a plain function; :data:`REFERENCE_STEPS` holds the reference
    implementations from :mod:`faultlab.slam.units`.  Replace one unit with
    ``dataclasses.replace(steps, unit=new_function)``.  The units named in
    :attr:`stream_units` receive their own random stream as ``rng`` (see
    "Random streams" in the module docstring).
    """

    #: Units that draw random numbers, each from its own stream (:data:`faultlab.slam.contract.STREAM_UNITS`).
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


def materialise_particles(st: ParticleState) -> Particles:
    """A materialised copy of the particles of ``st`` (means and covariances in column order)."""
    C = st.n_landmarks
    rows = landmark_rows(st, np.arange(C))
    cols = np.arange(C)[None, :]
    return Particles(st.poses.copy(), np.exp(st.logw), st.ids.copy(), st.mu[rows, cols].copy(),
                     st.P[rows, cols].copy())


#: Positions of the per-particle arguments (leading axis = particles) of each particle unit; the
#: batched filter slices these when a replacement is marked :func:`~faultlab.slam.contract.filter_wise`.
_PARTICLE_ARGS: dict[str, tuple[int, ...]] = {
    "motion_model": (0, 1),
    "init_landmarks": (0,),
    "classify_new": (1,),
    "predict_measurement": (0, 1),
    "innovation": (1,),
    "innovation_covariance": (0, 1),
    "log_likelihood": (0, 1),
    "ekf_update": (0, 1, 2, 3, 4),
}

_FAILED = object()  # a per-filter call that raised (the filter is dropped at the end of the step)


def _is_f64(a, shape: tuple[int, ...]) -> bool:
    """Whether ``a`` is a float64 ndarray of ``shape`` (what the reference step's kernels read)."""
    return type(a) is np.ndarray and a.dtype == np.float64 and a.shape == shape


def _looped(unit: Callable, positions: tuple[int, ...], n: int) -> Callable:
    """``unit`` called once per filter on its ``n`` particles, outputs stacked along the particle axis."""

    def per_filter(*args, **kwargs):
        n_filters = len(args[positions[0]]) // n
        if n_filters == 1:
            return unit(*args, **kwargs)
        outs = []
        for j in range(n_filters):
            part = list(args)
            for p in positions:
                part[p] = args[p][j * n:(j + 1) * n]
            outs.append(unit(*part, **kwargs))
        if isinstance(outs[0], tuple):
            return tuple(np.concatenate([np.asarray(o[i]) for o in outs]) for i in range(len(outs[0])))
        return np.concatenate([np.asarray(o) for o in outs])

    per_filter.filter_wise = True
    return per_filter


class BatchUnsupported(SlamOutputError):
    """A replaced unit did something the batched filter cannot reproduce filter by filter.

    Raised only with several filters in one batch; the repetitions must then be run one at a
    time (what :func:`faultlab.slam.protocol.run_slam_batch`'s callers do with any exception
    that escapes a batch).
    """


class FastSlam(UnitSlam):
    """Reference FastSLAM 1.0 (known correspondences) as a :class:`SlamAdapter`.

    Runs one filter (:meth:`reset`) or several independent repetitions in one vectorised filter
    (:meth:`reset_batch`, :meth:`estimates`; see "Batched repetitions" in the module docstring).

    Parameters
    ----------
    config : FastSlamConfig
    steps : FastSlamSteps
        The units; :data:`REFERENCE_STEPS` or a copy with one unit replaced (a fault).
    """

    name = "fastslam1"
    supports_batch: ClassVar[bool] = True
    #: Particle-observation pairs per call of a particle unit: the particles of a step (of one filter
    #: or of a batch) are corrected in blocks of at most about this many pairs, which bounds the
    #: units' work arrays (2 MiB each).  Smaller blocks do not pay: on the benchmark machine the
    #: per-call overhead they add outweighs what the smaller arrays gain in cache.
    block_pairs: ClassVar[int] = 1 << 18
    config_type = FastSlamConfig
    steps_type = FastSlamSteps
    reference_steps = REFERENCE_STEPS

    def __init__(self, config: FastSlamConfig | None = None, *, steps: FastSlamSteps | None = None):
        super().__init__(config, steps=steps)
        self._Q = self._config.Q
        self._started = False
        self._batched_steps: FastSlamSteps | None = None
        self._single_steps: FastSlamSteps | None = None
        self._jit = _twins.JIT_ENABLED  # compiled twins and bookkeeping (FAULTLAB_JIT)
        self._fused = self._jit and _twins.fused(self._steps)
        # decided once per filter: which per-step units are the references, so that the compiled
        # path may do their work directly (same operations on the same values, no unit call)
        ref = REFERENCE_STEPS
        self._ref_classify = self._jit and self._steps.classify_new is ref.classify_new
        self._ref_resample = self._jit and all(getattr(self._steps, name) is getattr(ref, name) for name in
                                               ("effective_sample_size", "resample", "apply_resample"))
        # every unit the reference: a whole step in a few compiled passes (:meth:`_update_reference`)
        self._ref_step = self._jit and type(self._steps) is FastSlamSteps and not self._steps.replaced()
        # a partial reference step: the stages whose units are all references run as in the reference
        # step, the others call their units (:meth:`update`)
        self._ref_predict = self._jit and all(getattr(self._steps, name) is getattr(ref, name) for name in
                                              ("sample_controls", "motion_model", "wrap_heading"))
        self._ref_correct = self._fused and self._ref_classify  # then combine_weights is called if replaced
        self._ref_combine = self._steps.combine_weights is ref.combine_weights
        self._ref_apply = self._jit and self._steps.apply_resample is ref.apply_resample
        self._q_entries = _twins.noise_entries(self._Q) if self._jit else None
        # one correction unit replaced: the others compiled around it (:meth:`_correct_staged`)
        self._stage = _twins.staged(self._steps) if self._jit and self._ref_classify and not self._fused else None

    # -- SlamAdapter -----------------------------------------------------------------------------

    def reset(self, pose: np.ndarray, *, rng: np.random.Generator) -> None:
        self._start(self._start_pose(pose, rng), [rng], isolate=False)

    def reset_batch(self, pose: np.ndarray, *, rngs: Sequence[np.random.Generator]) -> None:
        """Start one independent filter per generator (repetition ``i`` uses ``rngs[i]``).

        Each filter derives its unit streams from its own generator exactly as :meth:`reset`
        does, so repetition ``i`` gives bit for bit what a separate filter reset with
        ``rngs[i]`` gives.  A failure that belongs to one filter (non-finite weights, an
        exception in a unit called for that filter alone) ends that repetition only; see
        :meth:`estimates`.
        """
        try:
            rngs = list(rngs)
        except TypeError:
            raise SlamInputError(f"{self.name}: rngs must be a sequence of numpy.random.Generator, "
                                 f"got {type(rngs).__name__}") from None
        if not rngs:
            raise SlamInputError(f"{self.name}: rngs is empty: a batch needs at least one repetition")
        for i, rng in enumerate(rngs):
            if not isinstance(rng, np.random.Generator):
                raise SlamInputError(f"{self.name}: rngs[{i}] must be a numpy.random.Generator, "
                                     f"got {type(rng).__name__}")
        self._start(self._start_pose(pose, rngs[0]), rngs, isolate=True)

    def update(self, control: np.ndarray, observations: Observations) -> None:
        if not self._started:
            raise SlamInputError(f"{self.name}: update() called before reset()")
        slots = len(self._reps)
        if slots == 0:  # every repetition of the batch has failed
            self._record_poses()
            self._t += 1
            return
        if self._ref_step:
            self._update_reference(control, observations)
            return
        steps, cfg, n = self._units(slots), self._config, self._n
        u, k, empty = step_kind(control, observations)
        # prediction (Table 13.1, line 4); an empty update adds no control noise
        ref_predict = self._ref_predict and _is_f64(self._poses, (slots * n, 3))
        if ref_predict:
            poses = self._predict_reference(u, empty)
        elif empty:
            u_i = np.broadcast_to(u, (slots * n, 2))
        elif slots == 1:
            u_i = self._call(0, steps.sample_controls, u, n, self._streams[0]["sample_controls"], cfg)
            if u_i is _FAILED:
                u_i = np.broadcast_to(u, (n, 2))
        else:
            parts = []
            for j in range(slots):
                part = self._call(j, steps.sample_controls, u, n, self._streams[j]["sample_controls"], cfg)
                part = np.broadcast_to(u, (n, 2)) if part is _FAILED else np.asarray(part)
                if part.shape != (n, 2):
                    raise BatchUnsupported(f"{self.name}: sample_controls returned shape {part.shape}, "
                                           f"expected ({n}, 2); run the repetitions one at a time")
                parts.append(part)
            u_i = np.concatenate(parts)
        if not ref_predict:
            poses = steps.motion_model(self._poses, u_i, wrap=steps.wrap_heading)
        if k:
            cols, seen = self._columns(observations.ids)
            logw = None
            if ((self._ref_correct or self._stage is not None) and _is_f64(poses, (slots * n, 3))
                    and _is_f64(self._logw, (slots * n,))
                    and all(o is self._ident or np.array_equal(o, self._ident) for o in self._owner)):
                if self._ref_correct:
                    logw = self._correct_reference(steps, poses, cols, seen, observations)
                elif slots * n * k <= self.block_pairs:  # the unit-by-unit path's single block
                    logw = self._correct_staged(steps, poses, cols, seen, observations)
                    if logw is None:  # a unit's output the stages do not take: unit by unit from now on
                        self._stage = None
            if logw is None:
                logw = self._correct(steps, poses, cols, seen, observations)
        else:
            logw = self._logw
        self._poses, self._logw = poses, logw
        # resampling (Table 13.1, lines 24-28), filter by filter
        self._end_step(self._resample, empty)

    def estimate(self) -> Estimate:
        self._require_started()
        if self._n_reps != 1:
            raise SlamInputError(f"{self.name}: estimate() of a batch of {self._n_reps} repetitions; "
                                 f"use estimates()")
        if self._failures:
            raise self._failures[0]
        return self._estimate(0)

    def estimates(self) -> list[Estimate | BaseException]:
        """Per repetition (in the order of the generators), its estimate or the exception that ended it."""
        self._require_started()
        out: list[Estimate | BaseException | None] = [None] * self._n_reps
        for rep, exc in self._failures.items():
            out[rep] = exc
        for j, rep in enumerate(self._reps):
            try:
                out[rep] = self._estimate(j)
            except (Exception, SystemExit) as exc:
                out[rep] = exc
        return out  # type: ignore[return-value]

    # -- diagnostics -----------------------------------------------------------------------------

    @property
    def n_resamples(self) -> int:
        """How many updates since :meth:`reset` resampled (the first repetition of a batch)."""
        self._require_started()
        return self._n_resampled[0]

    @property
    def streams(self) -> Mapping[str, np.random.Generator]:
        """The random stream of each unit in :attr:`FastSlamSteps.stream_units` (read-only mapping).

        The generators are the filter's own (the first repetition's in a batch): drawing from
        them changes the run.
        """
        self._require_started()
        return MappingProxyType(self._all_streams[0])

    @property
    def state(self) -> ParticleState:
        """The current particle state of the first repetition (its arrays are the filter's own)."""
        return self.filter_state(0)

    def filter_state(self, rep: int) -> ParticleState:
        """The particle state of repetition ``rep`` (read-only use: its arrays are views of the batch's)."""
        self._require_started()
        if rep in self._failures:
            raise SlamInputError(f"{self.name}: repetition {rep} failed: {self._failures[rep]!r}")
        if rep not in self._reps:
            raise SlamInputError(f"{self.name}: no repetition {rep} (batch of {self._n_reps})")
        return self._filter_state(self._reps.index(rep))

    def particles(self, rep: int = 0) -> Particles:
        """A materialised copy of the particles of repetition ``rep`` (means and covariances in column order)."""
        return materialise_particles(self.filter_state(rep))

    # -- internals: set-up and bookkeeping ---------------------------------------------------------

    def _unit_streams(self, rng: np.random.Generator) -> dict[str, np.random.Generator]:
        """One stream per random unit, keyed by name (common random numbers that survive a fault)."""
        return unit_streams(rng, self._steps.stream_units)

    def _start(self, p: np.ndarray, rngs: list[np.random.Generator], *, isolate: bool) -> None:
        """Set up ``len(rngs)`` filters at the validated start pose ``p``."""
        n, b = self._config.particles, len(rngs)
        cap = 16
        self._n = n
        self._n_reps = b
        self._isolate = isolate
        self._all_streams = [self._unit_streams(rng) for rng in rngs]
        self._streams = list(self._all_streams)  # streams of the active filters, by slot
        self._reps = list(range(b))  # repetition of each active filter (slot)
        self._failures: dict[int, BaseException] = {}
        self._dead: list[int] = []  # slots that failed during the current step
        self._n_resampled = [0] * b
        self._ident = np.arange(n, dtype=np.intp)  # identity lineage / owner of every filter
        self._ident.flags.writeable = False
        self._poses = np.tile(p, (b * n, 1))
        self._logw = np.full(b * n, -math.log(n))
        self._ids = np.empty(0, dtype=np.int64)
        self._mu = np.zeros((2, cap, b * n))  # storage buffers (see "Storage and resampling")
        self._P = np.zeros((2, 2, cap, b * n))
        self._anc = self._local_ancestry(b, cap)
        self._anc_spare = None  # the second ancestry buffer of _materialise
        self._lineage = [self._ident] * b
        self._owner = [self._ident] * b
        self._sharers = [False] * b  # ParticleState.sequential_sharers of each filter
        self._sorted_ids = np.empty(0, dtype=np.intp)  # lookup: sorted ids ...
        self._sorted_cols = np.empty(0, dtype=np.intp)  # ... and their columns
        self._offsets = None  # storage offset of each particle's filter, (B N,), when B > 1
        self._views = None  # per-slot views of the storage buffers (see _filter_state)
        self._trajectory = TrajectoryLog((b, 3))  # every repetition's mean pose after each step
        self._t = 0
        self._started = True

    def _local_ancestry(self, b: int, cap: int) -> np.ndarray:
        """Identity ancestry (B N, cap) of :func:`~faultlab.slam.particles.ancestry_dtype`, with each
        filter's rows numbered from 0 (its own storage)."""
        rows = np.tile(np.arange(self._n, dtype=_particles.ancestry_dtype(self._n)), b)
        return np.ascontiguousarray(np.broadcast_to(rows[:, None], (b * self._n, cap)))

    def _require_started(self) -> None:
        if not self._started:
            raise SlamInputError(f"{self.name}: reset() must be called first")

    def _units(self, slots: int) -> FastSlamSteps:
        """The units the filter calls for ``slots`` filters: the reference units' compiled twins
        (:func:`~faultlab.slam.twins.twinned`), every other unit as given, particle units marked
        filter-wise looped per filter."""
        if slots == 1:
            if self._single_steps is None:
                self._single_steps = _twins.twinned(self._steps) if self._jit else self._steps
            return self._single_steps
        if self._batched_steps is None:
            looped = {name: _looped(getattr(self._steps, name), pos, self._n)
                      for name, pos in _PARTICLE_ARGS.items()
                      if getattr(getattr(self._steps, name), "filter_wise", False)}
            steps = dataclasses.replace(self._steps, **looped) if looped else self._steps
            self._batched_steps = _twins.twinned(steps) if self._jit else steps
        return self._batched_steps

    def _call(self, j: int, fn: Callable, *args, **kwargs):
        """Call ``fn`` on behalf of the filter in slot ``j``; in a batch, its failure ends only that filter."""
        if not self._isolate:
            return fn(*args, **kwargs)
        try:
            return fn(*args, **kwargs)
        except (Exception, SystemExit) as exc:
            self._failures[self._reps[j]] = exc
            self._dead.append(j)
            return _FAILED

    def _slice(self, j: int) -> slice:
        return slice(j * self._n, (j + 1) * self._n)

    def _filter_state(self, j: int) -> ParticleState:
        """The :class:`ParticleState` of the filter in slot ``j``: views of the batch's arrays."""
        sl = self._slice(j)
        if self._views is None:  # storage views of every slot, until the buffers change
            self._views = [(self._mu[:, :, s].transpose(2, 1, 0), self._P[:, :, :, s].transpose(3, 2, 0, 1),
                            self._anc[s]) for s in map(self._slice, range(len(self._reps)))]
        mu, P, anc = self._views[j]
        return ParticleState(poses=self._poses[sl], logw=self._logw[sl], ids=self._ids, mu=mu, P=P, anc=anc,
                             lineage=self._lineage[j], owner=self._owner[j], sequential_sharers=self._sharers[j])

    def _store(self, j: int, given: ParticleState, st: ParticleState) -> None:
        """Write the state a per-filter unit returned for slot ``j`` back into the batch's arrays."""
        n, slots = self._n, len(self._reps)
        if not isinstance(st, ParticleState):
            raise SlamOutputError(f"{self.name}: apply_resample returned {type(st).__name__}, not a ParticleState")
        for name, shape in (("poses", (n, 3)), ("logw", (n,)), ("lineage", (n,)), ("owner", (n,))):
            if np.shape(getattr(st, name)) != shape:
                raise SlamOutputError(f"{self.name}: apply_resample returned {name} of shape "
                                      f"{np.shape(getattr(st, name))}, expected {shape}")
        if slots == 1:
            self._poses, self._logw = st.poses, st.logw
        else:
            sl = self._slice(j)
            if not self._poses.flags.writeable:
                self._poses = self._poses.copy()
            if st.poses is not given.poses:
                self._poses[sl] = st.poses
            if st.logw is not given.logw:
                self._logw[sl] = st.logw
        self._lineage[j] = st.lineage
        self._owner[j] = st.owner
        self._sharers[j] = bool(st.sequential_sharers)
        if st.mu is given.mu and st.P is given.P and st.anc is given.anc and st.ids is given.ids:
            return
        if st.ids is not given.ids and not np.array_equal(st.ids, given.ids):
            raise SlamOutputError(f"{self.name}: apply_resample changed the landmark ids of the storage columns")
        # landmark storage that the unit replaced (another layout, a deep copy) is copied back into the batch's
        cap = self._mu.shape[1]
        for name, shape in (("mu", (n, cap, 2)), ("P", (n, cap, 2, 2)), ("anc", (n, cap))):
            new = getattr(st, name)
            if new is getattr(given, name):
                continue
            if np.shape(new) != shape:
                raise SlamOutputError(f"{self.name}: apply_resample returned landmark storage {name} of shape "
                                      f"{np.shape(new)}, expected {shape}")
            sl = self._slice(j)
            if name == "mu":
                self._mu[:, :, sl] = np.asarray(new, dtype=float).transpose(2, 1, 0)
            elif name == "P":
                self._P[:, :, :, sl] = np.asarray(new, dtype=float).transpose(2, 3, 1, 0)
            else:
                new = np.asarray(new)  # row numbers; negative ones count from the end, as numpy indexes
                if new.size and (new.min() < -n or new.max() >= n):
                    raise SlamOutputError(f"{self.name}: apply_resample returned an ancestry with row numbers "
                                          f"outside [-{n}, {n})")
                self._anc[sl] = new

    def _drop_failed(self) -> None:
        """Remove the filters that failed in this step from the batch (their rows of every array)."""
        keep = [j for j in range(len(self._reps)) if j not in set(self._dead)]
        n = self._n
        rows = np.concatenate([np.arange(j * n, (j + 1) * n) for j in keep]) if keep else np.empty(0, np.intp)
        self._poses = np.asarray(self._poses)[rows]
        self._logw = np.asarray(self._logw)[rows]
        self._mu = self._mu[:, :, rows]
        self._P = self._P[:, :, :, rows]
        self._anc = self._anc[rows]
        for name in ("_reps", "_streams", "_lineage", "_owner", "_sharers"):
            setattr(self, name, [getattr(self, name)[j] for j in keep])
        self._dead = []
        self._offsets = None
        self._views = None

    def _estimate(self, j: int) -> Estimate:
        """The map and pose of slot ``j``'s highest-weight particle; its trajectory is the pose of the
        filter's highest-weight particle after every step (:func:`~faultlab.slam.bookkeeping.best_pose`)."""
        return best_estimate(self._steps.extract_map, self._filter_state(j),
                             trajectory=self._trajectory.poses()[:, self._reps[j]])

    def _record_poses(self) -> None:
        """Log every active filter's best pose at the end of a step (NaN for a failed repetition)."""
        slots = len(self._reps)
        if slots == self._n_reps == 1:
            self._trajectory.append(self._poses[self._logw.argmax()])
            return
        row = np.full((self._n_reps, 3), np.nan)
        if slots:
            poses = np.asarray(self._poses).reshape(slots, self._n, 3)
            row[self._reps] = best_pose(poses, np.asarray(self._logw).reshape(slots, self._n))
        self._trajectory.append(row)

    def _resample(self, j: int, empty: bool) -> None:
        """Effective sample size, resampling decision and resampling of the filter in slot ``j``."""
        if self._ref_resample:
            self._resample_reference(j, empty)
            return
        steps = self._units(1)  # per-filter units: never looped
        if self._ref_apply:  # the decision by the units, the reference apply_resample's work directly
            sl = self._slice(j)
            w = np.exp(self._logw[sl])
            idx = steps.resample(w, steps.effective_sample_size(w), empty, self._streams[j]["resample"],
                                 self._config)
            if idx is None:
                return
            idx = np.asarray(idx)
            if idx.shape == (self._n,) and idx.dtype.kind in "iu":
                self._apply_indices(j, idx)
                return
            given = self._filter_state(j)
            self._store(j, given, steps.apply_resample(given, idx))
            self._n_resampled[self._reps[j]] += 1
            return
        given = self._filter_state(j)
        st, resampled = resample_tail(steps, given, empty, self._streams[j]["resample"], self._config,
                                      apply=steps.apply_resample)
        if resampled:
            self._store(j, given, st)
            self._n_resampled[self._reps[j]] += 1

    def _apply_indices(self, j: int, idx: np.ndarray) -> None:
        """What the reference ``apply_resample`` does to slot ``j`` with the indices ``idx`` (N,) of
        integers, by the same indexing, written into the batch's arrays."""
        n = self._n
        sl = self._slice(j)
        if len(self._reps) == 1:
            poses = self._poses[idx]
            self._lineage[j] = self._lineage[j][idx]
            self._poses = poses
            self._logw = np.full(n, -math.log(n))
        else:
            poses = self._poses[sl][idx]
            self._lineage[j] = self._lineage[j][idx]
            if not self._poses.flags.writeable:
                self._poses = self._poses.copy()
            self._poses[sl] = poses
            self._logw[sl] = np.full(n, -math.log(n))
        self._n_resampled[self._reps[j]] += 1

    def _update_reference(self, control: np.ndarray, observations: Observations) -> None:
        """:meth:`update` when every unit is the reference: the same operations on the same values,
        done by the kernels of :mod:`faultlab.slam.twins` (:func:`~faultlab.slam.twins.predict_poses`,
        :func:`~faultlab.slam.twins.correct_observed`) instead of one call per unit.

        The numpy functions the units call (``cos``, ``sin``, ``arctan2``, ``log``, ``exp``, the
        weights' sum and dot product) are called once per step on all particles, and the random
        draws are the units' own, from their streams.
        """
        u, k, empty = step_kind(control, observations)
        poses = self._predict_reference(u, empty)
        logw = self._correct_reference(self._steps, poses, *self._columns(observations.ids),
                                       observations) if k else self._logw
        self._poses, self._logw = poses, logw
        self._end_step(self._resample_reference, empty)

    def _predict_reference(self, u: np.ndarray, empty: bool) -> np.ndarray:
        """The prediction when ``sample_controls``, ``motion_model`` and ``wrap_heading`` are the
        references: each filter's draw from its ``sample_controls`` stream, then one kernel
        (:func:`~faultlab.slam.twins.predict_poses`).  Returns the predicted poses."""
        slots, n = len(self._reps), self._n
        if empty:
            eps = None
        elif slots == 1:
            eps = self._streams[0]["sample_controls"].standard_normal((n, 2))
        else:
            eps = np.empty((slots * n, 2))
            for j in range(slots):
                eps[j * n:(j + 1) * n] = self._streams[j]["sample_controls"].standard_normal((n, 2))
        return _twins.predict_poses(self._poses, u, eps, self._config)

    def _correct_reference(self, steps: FastSlamSteps, poses: np.ndarray, cols: np.ndarray, seen: np.ndarray,
                           observations: Observations) -> np.ndarray | None:
        """The correction when the correction units and ``classify_new`` are the references and every
        particle owns its storage row: the kernels of :func:`~faultlab.slam.twins.correct_observed`
        around ``init_landmarks`` (the unit of ``steps``, called once on all particles as by
        :meth:`_correct_rows`) and, if it is not the reference, ``combine_weights`` (filter by filter,
        as by :meth:`_combine`).  Returns the
        normalised log weights, or None (nothing written) when ``init_landmarks`` returned arrays
        of other shapes, which :meth:`_correct` then handles as the unit-by-unit path does."""
        slots, n = len(self._reps), self._n
        prepared = self._observed_and_new(steps, poses, seen, observations)
        if prepared is None:
            return None
        z, init = prepared
        if not self._ref_combine:  # the log likelihoods by the kernels, combine_weights by its unit
            loglik, _ = _twins.correct_observed(poses, z, cols, seen, init, self._q_entries, None, n,
                                                self._mu, self._P, self._anc)
            known = np.empty(loglik.shape, dtype=bool)
            known[...] = seen
            logw = np.array(self._logw)
            self._combine(0, slots, 0, loglik, known, logw)
            return logw
        logw, tops = _twins.correct_observed(poses, z, cols, seen, init, self._q_entries, self._logw, n,
                                             self._mu, self._P, self._anc)
        return self._normalise_shifted(logw, tops)

    def _observed_and_new(self, steps: FastSlamSteps, poses: np.ndarray, seen: np.ndarray,
                          observations: Observations) -> tuple[np.ndarray, tuple | None] | None:
        """The common start of the compiled corrections: the storage materialised, the observations
        as ``z`` (k, 2) (range, bearing), and ``init_landmarks`` of ``steps`` on the unseen ones (None
        when every landmark is seen).  None (nothing written) when ``init_landmarks`` returned arrays
        of other shapes, which :meth:`_correct` then handles as the unit-by-unit path does."""
        slots, n = len(self._reps), self._n
        self._materialise()
        z = np.empty((seen.size, 2))
        z[:, 0] = observations.ranges
        z[:, 1] = observations.bearings
        init = None
        if not np.logical_and.reduce(seen):
            init = steps.init_landmarks(poses, z[np.flatnonzero(~seen)], self._Q, wrap=steps.wrap_bearing)
            k_new = int(np.count_nonzero(~seen))
            if not (np.shape(init[0]) == (slots * n, k_new, 2) and np.shape(init[1]) == (slots * n, k_new, 2, 2)):
                return None
        return z, init

    def _normalise_shifted(self, logw: np.ndarray, tops: np.ndarray) -> np.ndarray:
        """The second half of every filter's normalisation of ``logw`` (B N,), shifted by each
        filter's maximum ``tops`` (B,) where that is finite (:func:`~faultlab.slam.twins.combine_pairs`),
        in place; a filter whose maximum is not finite fails as :meth:`_normalise` fails and keeps
        its old weights.  Returns ``logw``."""
        slots, n = len(self._reps), self._n
        for j in range(slots):
            lw = logw[j * n:(j + 1) * n]
            if math.isfinite(tops[j]):
                lw -= math.log(np.add.reduce(np.exp(lw)))  # ``np.exp(lw).sum()``
            elif self._call(j, self._normalise, lw.copy()) is _FAILED:  # raises for one filter
                lw[...] = self._logw[j * n:(j + 1) * n]
        return logw

    def _correct_staged(self, steps: FastSlamSteps, poses: np.ndarray, cols: np.ndarray, seen: np.ndarray,
                        observations: Observations) -> np.ndarray | None:
        """The correction when one stage of the correction units is replaced (:func:`~faultlab.slam.twins.staged`)
        and ``classify_new`` is the reference, every particle owns its storage row and the pairs fit in
        one block: :func:`~faultlab.slam.twins.correct_staged` around the replaced unit of ``steps``
        (called once on all pairs, as by :meth:`_correct_rows`), ``init_landmarks`` as by
        :meth:`_correct_reference`, then ``combine_weights`` and the normalisation as by
        :meth:`_correct_reference` (the replaced ``log_likelihood``'s result: as by :meth:`_combine`).
        Returns the normalised log weights, or None (nothing written) when a unit returned arrays of
        other types or shapes, which :meth:`_correct` then hands to the units as the unit-by-unit
        path does."""
        slots, n = len(self._reps), self._n
        prepared = self._observed_and_new(steps, poses, seen, observations)
        if prepared is None:
            return None
        z, init = prepared
        stage, Q = self._stage, self._Q
        if stage == 0:
            unit = steps.predict_measurement
        elif stage == 1:
            def unit(z, zhat):
                return steps.innovation(z, zhat, wrap=steps.wrap_bearing)
        elif stage == 2:
            def unit(H, P):
                return steps.innovation_covariance(H, P, Q)
        elif stage == 3:
            unit = steps.log_likelihood
        else:
            unit = steps.ekf_update
        out = _twins.correct_staged(stage, unit, poses, z, cols, seen, init, self._q_entries, n, self._mu, self._P,
                                    self._anc)
        if out is None:
            return None
        t, det = out
        if det is not None:
            np.log(det, out=det)
            if self._ref_combine:
                return self._normalise_shifted(*_twins.combine_pairs(t, det, seen, self._logw, n))
            _twins.finish_log_likelihood(t, det)
            t = t.T
        known = np.empty(t.shape, dtype=bool)
        known[...] = seen
        logw = np.array(self._logw)
        self._combine(0, slots, 0, t, known, logw)
        return logw

    def _end_step(self, resample: Callable[[int, bool], None], empty: bool) -> None:
        """The end of a step: ``resample`` each filter, remove those that failed in the step, record
        the poses and advance the step count."""
        for j in range(len(self._reps)):
            self._call(j, resample, j, empty)
        if self._dead:
            self._drop_failed()
        self._record_poses()
        self._t += 1

    def _resample_reference(self, j: int, empty: bool) -> None:
        """:meth:`_resample` when ``effective_sample_size``, ``resample`` and ``apply_resample`` are
        the references: their work (the resampling by its twin) without building a particle state."""
        n = self._n
        sl = self._slice(j)
        w = np.exp(self._logw[sl])
        idx = _twins.resample(w, _units.effective_sample_size(w), empty, self._streams[j]["resample"],
                              self._config)
        if idx is None:
            return
        if len(self._reps) == 1:
            self._poses = self._poses.take(idx, axis=0)
            self._logw = np.empty(n)
            self._logw.fill(-math.log(n))
        else:
            if not self._poses.flags.writeable:
                self._poses = self._poses.copy()
            self._poses[sl] = self._poses[sl][idx]
            self._logw[sl] = -math.log(n)
        self._lineage[j] = self._lineage[j].take(idx)
        self._n_resampled[self._reps[j]] += 1

    def _normalise(self, logw: np.ndarray) -> np.ndarray:
        """Normalised log weights (log-sum-exp) of one filter."""
        return normalise_log_weights(logw, name=self.name, step=self._t)

    def _columns(self, ids: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Columns of ``ids`` (k,), adding columns for unseen ids; returns (cols, seen)."""
        sid, scol = self._sorted_ids, self._sorted_cols
        if sid.size:
            pos = sid.searchsorted(ids)
            np.minimum(pos, sid.size - 1, out=pos)
            seen = sid[pos] == ids
            cols = scol[pos]  # valid where seen
        else:
            seen = np.zeros(ids.size, dtype=bool)
            cols = np.empty(ids.size, dtype=np.intp)
        if not np.logical_and.reduce(seen):
            new_ids = ids[~seen]
            C = self._ids.size
            new_cols = np.arange(C, C + new_ids.size, dtype=np.intp)
            cols[~seen] = new_cols
            self._grow(C + new_ids.size)
            self._ids = np.concatenate([self._ids, new_ids])
            allid = np.concatenate([sid, new_ids])
            allcol = np.concatenate([scol, new_cols])
            order = np.argsort(allid, kind="stable")
            self._sorted_ids, self._sorted_cols = allid[order], allcol[order]
        return cols, seen

    def _grow(self, needed: int) -> None:
        new_cap = grown_capacity(self._mu.shape[1], needed)
        if new_cap is None:
            return
        C = self._ids.size
        bn = self._mu.shape[2]
        mu = np.zeros((2, new_cap, bn))
        P = np.zeros((2, 2, new_cap, bn))
        anc = self._local_ancestry(bn // self._n, new_cap)
        mu[:, :C] = self._mu[:, :C]
        P[:, :, :C] = self._P[:, :, :C]
        anc[:, :C] = self._anc[:, :C]
        self._mu, self._P, self._anc = mu, P, anc
        self._views = None

    # -- internals: the correction -------------------------------------------------------------

    def _correct(self, steps: FastSlamSteps, poses: np.ndarray, cols: np.ndarray, seen: np.ndarray,
                 obs: Observations) -> np.ndarray:
        """Correction for the step's observations; updates the storage in place.

        Returns the normalised log weights of all filters (B N,).  Consecutive filters are
        corrected together (:meth:`_correct_filters`); a filter whose particles share rows that
        they update in turn is corrected on its own (:meth:`_correct_in_sharer_order`).
        """
        n = self._n
        slots = len(self._reps)
        k = cols.size
        self._materialise()
        z = np.empty((k, 2))
        z[:, 0] = obs.ranges
        z[:, 1] = obs.bearings
        sharers = {j for j in range(slots) if self._sharers[j] and np.unique(self._owner[j]).size < n}
        logw = np.array(self._logw)
        start = 0
        while start < slots:
            if start in sharers:
                self._call(start, self._correct_in_sharer_order, start, poses, cols, seen, z, logw)
                start += 1
                continue
            stop = start + 1
            while stop < slots and stop not in sharers:
                stop += 1
            self._correct_filters(steps, start, stop, poses, cols, seen, z, logw)
            start = stop
        return logw

    def _materialise(self) -> None:
        """Apply the pending resamplings to the ancestry (lineage -> identity), O(N C) ints.

        The rows are gathered into a second ancestry buffer (one read and one write of the used
        columns), which then becomes the ancestry: the columns beyond C are identity in both.
        """
        pending = [j for j in range(len(self._reps)) if self._lineage[j] is not self._ident]
        if not pending:
            return
        C = self._ids.size
        anc = self._anc
        spare = self._anc_spare
        if spare is None or spare.shape != anc.shape:
            spare = self._local_ancestry(anc.shape[0] // self._n, anc.shape[1])
        for j in range(len(self._reps)):
            sl = self._slice(j)
            if self._lineage[j] is self._ident:
                spare[sl, :C] = anc[sl, :C]
            else:
                if self._jit:
                    _twins.take_rows(anc[sl], self._lineage[j], spare[sl], C)
                else:
                    spare[sl, :C] = anc[sl][self._lineage[j], :C]
                self._lineage[j] = self._ident
        self._anc, self._anc_spare = spare, anc
        self._views = None

    def _gather(self, start: int, stop: int, cols: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The stored landmarks of ``cols`` for the particles of slots ``start .. stop - 1``.

        Returns ``(mb (2, k, M), pb (2, 2, k, M))``, ``M`` the filters' particles: fresh copies of
        the means and covariances.
        """
        n = self._n
        p0, p1 = start * n, stop * n
        if self._jit:
            mb = np.empty((2, cols.size, p1 - p0))
            pb = np.empty((2, 2, cols.size, p1 - p0))
            _twins.gather_rows(self._mu, self._P, self._anc, cols, p0, n, mb, pb)
            return mb, pb
        bn = self._mu.shape[2]
        cap = self._mu.shape[1]
        flat = self._anc[p0:p1, cols].T + self._base(start, stop, cols)  # (k, M) positions in the flattened storage
        mb = np.take(self._mu.reshape(2, cap * bn), flat, axis=1)  # (2, k, M), a fresh copy
        pb = np.take(self._P.reshape(4, cap * bn), flat, axis=1).reshape(2, 2, cols.size, p1 - p0)
        return mb, pb

    def _base(self, start: int, stop: int, cols: np.ndarray) -> np.ndarray:
        """The storage offset of each (column of ``cols``, particle's filter) of slots ``start .. stop - 1``
        in the flattened (component, column x particle) storage, shape (k, M) or (k, 1)."""
        n = self._n
        bn = self._mu.shape[2]
        base = (cols * bn)[:, None]
        if bn > n:  # each filter's rows of the storage start at its slot's offset
            if self._offsets is None:
                self._offsets = np.repeat(np.arange(bn // n, dtype=np.intp) * n, n)
            base = base + self._offsets[start * n:stop * n]
        return base

    def _blocks(self, m_rows: int, k: int) -> list[tuple[int, int]]:
        """Row ranges that split ``m_rows`` particles into blocks of about :attr:`block_pairs` pairs.

        Blocks hold whole filters if a particle unit is declared filter-wise.
        """
        count = max(1, -(-m_rows * k // self.block_pairs))
        if count == 1:
            return [(0, m_rows)]
        size = -(-m_rows // count)
        if any(getattr(getattr(self._steps, name), "filter_wise", False) for name in _PARTICLE_ARGS):
            size = -(-size // self._n) * self._n
        return [(b, min(b + size, m_rows)) for b in range(0, m_rows, size)]

    def _correct_filters(self, steps: FastSlamSteps, start: int, stop: int, poses: np.ndarray, cols: np.ndarray,
                         seen: np.ndarray, z: np.ndarray, logw: np.ndarray) -> None:
        """The reference correction of the particles of slots ``start .. stop - 1``.

        Every particle is corrected from the values stored before the step (all are gathered
        first) and writes its own row (sharers of a row: the last particle's values win).  The
        particle units run on blocks of at most about :attr:`block_pairs` particle-observation
        pairs (:meth:`_correct_rows`); then ``combine_weights`` and the normalisation run filter
        by filter, writing each filter's
        weights into ``logw`` (a filter that fails keeps its old ones and leaves the batch after
        the step).  Internally the (particle, observation) arrays are handled as (k, M) blocks
        (the transpose of the units' (M, k) views), matching the storage layout.
        """
        n = self._n
        mu_store, P_store = self._mu, self._P
        bn = mu_store.shape[2]
        cap = mu_store.shape[1]
        k = cols.size
        p0, p1 = start * n, stop * n
        m_rows = p1 - p0
        x = poses if m_rows == poses.shape[0] else poses[p0:p1]
        blocks = self._blocks(m_rows, k)
        mb, pb = self._gather(start, stop, cols)
        if len(blocks) == 1:
            loglik, known, mu_new, P_new = self._correct_rows(steps, x, mb, pb, seen, z)
        else:
            loglik = np.empty((k, m_rows)).T
            known = np.empty((k, m_rows), dtype=bool).T
            mu_new = np.empty((2, k, m_rows))
            P_new = np.empty((2, 2, k, m_rows))
            for b0, b1 in blocks:
                ll, kn, mn, pn = self._correct_rows(steps, x[b0:b1], mb[:, :, b0:b1], pb[:, :, :, b0:b1], seen, z)
                loglik[b0:b1] = ll
                known[b0:b1] = kn
                mu_new[:, :, b0:b1] = mn
                P_new[:, :, :, b0:b1] = pn
        self._combine(start, stop, p0, loglik, known, logw)
        # write every particle's estimate of the observed columns into its own storage row
        owners = self._owner[start:stop]
        if all(o is self._ident or np.array_equal(o, self._ident) for o in owners):
            owner = owners[0] if len(owners) == 1 else np.tile(self._ident, len(owners))
            if self._jit:
                _twins.scatter_rows(mu_new, P_new, cols, p0, owner, mu_store, P_store, self._anc)
                return
            # rows of the (component, column) x particle views of the storage: contiguous row copies
            rows = cols + (cap * np.arange(4))[:, None]
            mu_store.reshape(2 * cap, bn)[rows[:2].ravel(), p0:p1] = mu_new.reshape(2 * k, m_rows)
            P_store.reshape(4 * cap, bn)[rows.ravel(), p0:p1] = P_new.reshape(4 * k, m_rows)
        else:
            owner = np.asarray(owners[0]) if len(owners) == 1 else np.concatenate(owners)
            wflat = owner[None, :] + self._base(start, stop, cols)  # sharers of a row: the last particle's values win
            mu_store.reshape(2, cap * bn)[:, wflat] = mu_new
            P_store.reshape(4, cap * bn)[:, wflat] = P_new.reshape(4, k, m_rows)
        self._anc[p0:p1, cols] = owner[:, None]

    def _combine(self, start: int, stop: int, p0: int, loglik: np.ndarray, known: np.ndarray,
                 logw: np.ndarray) -> None:
        """The weights of slots ``start .. stop - 1`` (particles from ``p0``), filter by filter:
        ``combine_weights``, then the normalisation (log-sum-exp), written into ``logw``."""
        n = self._n
        for j in range(start, stop):
            sl = self._slice(j)
            local = slice(sl.start - p0, sl.stop - p0)
            lw = self._call(j, self._weights, self._logw[sl], loglik[local], known[local])
            if lw is _FAILED:
                continue
            if self._mu.shape[2] > n and np.shape(lw) != (n,):
                raise BatchUnsupported(f"{self.name}: combine_weights returned shape {np.shape(lw)}, expected "
                                       f"({n},); run the repetitions one at a time")
            logw[sl] = lw

    def _correct_rows(self, steps: FastSlamSteps, x: np.ndarray, mb: np.ndarray, pb: np.ndarray,
                      seen: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """The particle units on one block of particles (M' rows).

        ``x`` (M', 3) are the predicted poses, ``mb`` (2, k, M') and ``pb`` (2, 2, k, M') the
        gathered landmarks (new pairs are initialised in place).  Returns the log likelihoods
        (M', k), which pairs are known (M', k), and the new means (2, k, M') and covariances
        (2, 2, k, M') (the initial values where new).
        """
        Q = self._Q
        mu = mb.transpose(2, 1, 0)  # (M', k, 2) view
        P = pb.transpose(3, 2, 0, 1)  # (M', k, 2, 2) view
        if self._ref_classify:  # the reference: the never-seen ids are new for every particle
            known = np.empty(mu.shape[:2], dtype=bool)
            known[...] = seen
            new_cols = None if seen.all() else np.flatnonzero(~seen)
            new = ~known if new_cols is not None else None
        else:
            new = np.asarray(steps.classify_new(seen, mu), dtype=bool)
            new_cols = np.flatnonzero(new.any(axis=0)) if new.any() else None
            known = ~new
        if new_cols is not None:
            # initialise where new (only the observations with at least one new pair)
            mu_i, P_i = steps.init_landmarks(x, z[new_cols], Q, wrap=steps.wrap_bearing)
            mi = np.asarray(mu_i, dtype=float).transpose(2, 1, 0)
            pi = np.asarray(P_i, dtype=float).transpose(2, 3, 1, 0)
            m = new[:, new_cols].T
            mb[:, new_cols] = np.where(m, mi, mb[:, new_cols])
            pb[:, :, new_cols] = np.where(m, pi, pb[:, :, new_cols])
        if self._fused:  # every correction unit is the reference: their work in one compiled pass
            loglik, mu_new, P_new = _twins.correct_pairs(x, z, mb, pb, Q)
        else:
            zhat, H = steps.predict_measurement(x, mu)
            nu = steps.innovation(z, zhat, wrap=steps.wrap_bearing)
            S = steps.innovation_covariance(H, P, Q)
            loglik = steps.log_likelihood(nu, S)
            mu_new, P_new = steps.ekf_update(mu, P, H, S, nu)
            mu_new = np.asarray(mu_new, dtype=float).transpose(2, 1, 0)  # (2, k, M')
            P_new = np.asarray(P_new, dtype=float).transpose(2, 3, 1, 0)  # (2, 2, k, M')
            if new_cols is not None:  # the unit's output may share memory with its inputs
                mu_new = mu_new.copy()
                P_new = P_new.copy()
        if new_cols is not None:
            # new pairs keep their initial values
            m = new[:, new_cols].T
            mu_new[:, new_cols] = np.where(m, mb[:, new_cols], mu_new[:, new_cols])
            P_new[:, :, new_cols] = np.where(m, pb[:, :, new_cols], P_new[:, :, new_cols])
        return loglik, known, mu_new, P_new

    def _correct_in_sharer_order(self, j: int, poses: np.ndarray, cols: np.ndarray, seen: np.ndarray,
                                 z: np.ndarray, logw: np.ndarray) -> None:
        """Correction of the filter in slot ``j``, whose particles share rows and update them in turn.

        Only reached with ``sequential_sharers`` (shallow-copy resampling) and at least two
        particles on one row; see :mod:`faultlab.slam.sharing`.  Writes the filter's normalised
        log weights into ``logw`` and its landmarks into the storage.
        """
        n = self._n
        sl = self._slice(j)
        mu_store, P_store = self._mu, self._P
        bn = mu_store.shape[2]
        cap = mu_store.shape[1]
        k = cols.size
        mb, pb = self._gather(j, j + 1, cols)
        owner = np.asarray(self._owner[j])
        correct = _twins.correct_in_sharer_order if self._jit else correct_in_sharer_order
        lw, mu_new, P_new = correct(self._units(1), self._logw[sl], owner, poses[sl], z, seen,
                                    mb.transpose(2, 1, 0), pb.transpose(3, 2, 0, 1), self._Q)
        logw[sl] = self._normalise(np.asarray(lw, dtype=float))
        wflat = owner[None, :] + self._base(j, j + 1, cols)  # sharers write equal values to their common row
        mu_store.reshape(2, cap * bn)[:, wflat] = np.asarray(mu_new).transpose(2, 1, 0)
        P_store.reshape(4, cap * bn)[:, wflat] = np.asarray(P_new).transpose(2, 3, 1, 0).reshape(4, k, n)
        self._anc[sl, cols] = owner[:, None]

    def _weights(self, logw: np.ndarray, loglik: np.ndarray, known: np.ndarray) -> np.ndarray:
        """One filter's new normalised log weights: ``combine_weights``, then log-sum-exp."""
        return self._normalise(np.asarray(self._steps.combine_weights(logw, loglik, known), dtype=float))
