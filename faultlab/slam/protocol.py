"""The adapter protocol every SLAM under test implements.

A SLAM adapter is driven step by step with the generator's controls and
observations (see :class:`faultlab.scenario.model.Scenario`):

>>> slam.reset(scenario.start_pose, rng=rng)            # doctest: +SKIP
>>> for t in range(scenario.n_steps):                   # doctest: +SKIP
...     slam.step(scenario.controls[t], Observations(*scenario.observations(t)))
>>> est = slam.estimate()                               # doctest: +SKIP

Subclasses implement :meth:`SlamAdapter.reset`, :meth:`SlamAdapter.update`
and :meth:`SlamAdapter.estimate`; :meth:`SlamAdapter.step` validates the input
first so that bad input raises :class:`SlamInputError` instead of corrupting
the estimate.

Data association
----------------
A SLAM declares :attr:`SlamAdapter.association`.  ``"known"`` (the default): every observation
carries its landmark's id, and the estimate names its landmarks by those ids.  ``"unknown"``: the
driver (:func:`run_slam`, :func:`run_slam_batch`) hides the ids -- it passes
``Observations.without_ids(ranges, bearings)``, whose ``ids`` are all :data:`HIDDEN_ID` and whose
``hidden`` flag is set -- so the SLAM must associate observations with landmarks itself; its
estimate labels the landmarks with its own ids (any distinct integers, e.g. 0, 1, ... in order of
creation), which correspond to nothing in the ground truth.  Such a map is scored by the earth
mover's distance (:func:`faultlab.metrics.map_errors` with ``association="unknown"``).  The
scenario files keep the true ids either way (the metrics need them): hiding is the driver's job,
so one case serves both kinds of SLAM.  A known-association SLAM given hidden ids raises
:class:`SlamInputError`.
"""

from __future__ import annotations

import abc
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from faultlab.errors import SlamInputError, SlamOutputError
from faultlab.vocabulary import ASSOCIATIONS, KNOWN_ASSOCIATION, UNKNOWN_ASSOCIATION

__all__ = ["HIDDEN_ID", "Observations", "Estimate", "COVARIANCE_RTOL", "covariance_problem", "SlamAdapter", "run_slam",
           "run_slam_batch", "as_control",
           "as_start_pose", "check_generator", "association_of"]

#: The id every observation carries when the driver hides the ids (unknown data association).
HIDDEN_ID = -1


@dataclass(frozen=True, eq=False)
class Observations:
    """The range-bearing observations of one step (known correspondences).

    Parameters
    ----------
    ranges : array_like, shape (k,)
        Measured ranges, m, finite and >= 0.
    bearings : array_like, shape (k,)
        Measured bearings relative to the heading, rad, finite (any multiple of 2 pi allowed).
    ids : array_like of int, shape (k,)
        Landmark ids.  ``k`` may be 0.
    hidden : bool
        The ids are hidden (unknown data association): ``ids`` are all :data:`HIDDEN_ID`.  Build
        such observations with :meth:`without_ids`.
    """

    ranges: np.ndarray
    bearings: np.ndarray
    ids: np.ndarray
    hidden: bool = False

    def __post_init__(self) -> None:
        r = np.asarray(self.ranges, dtype=float)
        b = np.asarray(self.bearings, dtype=float)
        ids = np.asarray(self.ids)
        if r.ndim != 1 or b.shape != r.shape or ids.shape != r.shape:
            raise SlamInputError(
                f"observations: ranges, bearings and ids must be 1-d of equal length, got shapes "
                f"{r.shape}, {b.shape}, {ids.shape}")
        if ids.dtype != np.int64:
            if ids.size and not np.issubdtype(ids.dtype, np.integer):
                if not np.all(np.isfinite(ids.astype(float))) or np.any(ids != np.round(ids)):
                    raise SlamInputError("observations: landmark ids must be integers")
            ids = ids.astype(np.int64)
        if r.size:
            if not (np.isfinite(r).all() and np.isfinite(b).all()):
                raise SlamInputError("observations: NaN or infinite range or bearing")
            if r.min() < 0:
                raise SlamInputError(f"observations: negative range {r[r < 0][0]!r} for landmark "
                                     f"{ids[r < 0][0]}")
            if self.hidden:
                if np.any(ids != HIDDEN_ID):
                    raise SlamInputError(f"observations: hidden ids must all be {HIDDEN_ID}")
            elif ids.size > 1:
                s = np.sort(ids)
                if (s[1:] == s[:-1]).any():
                    raise SlamInputError("observations: a landmark id appears twice in one step")
        object.__setattr__(self, "ranges", r)
        object.__setattr__(self, "bearings", b)
        object.__setattr__(self, "ids", ids)

    def __len__(self) -> int:
        return int(self.ranges.shape[0])

    @classmethod
    def _checked(cls, ranges: np.ndarray, bearings: np.ndarray, ids: np.ndarray) -> "Observations":
        """Observations of arrays that are known to pass the checks of ``__post_init__`` (float64,
        float64 and int64 of one length, see :func:`_all_valid`), built without repeating them."""
        obs = object.__new__(cls)
        object.__setattr__(obs, "ranges", ranges)
        object.__setattr__(obs, "bearings", bearings)
        object.__setattr__(obs, "ids", ids)
        object.__setattr__(obs, "hidden", False)
        return obs

    @classmethod
    def empty(cls) -> "Observations":
        return cls(np.empty(0), np.empty(0), np.empty(0, dtype=np.int64))

    @classmethod
    def without_ids(cls, ranges, bearings) -> "Observations":
        """Observations whose landmark ids are hidden (unknown data association)."""
        r = np.asarray(ranges, dtype=float)
        return cls(r, bearings, np.full(r.shape, HIDDEN_ID, dtype=np.int64), hidden=True)


@dataclass(frozen=True, eq=False)
class Estimate:
    """A SLAM's current belief.

    Attributes
    ----------
    pose : ndarray, shape (3,)
        Vehicle pose (x, y, theta), m and rad.
    landmark_ids : ndarray of int64, shape (M,)
        Ids of the mapped landmarks (unmapped ones are absent).
    landmarks : ndarray, shape (M, 2)
        Estimated positions, m, row i for ``landmark_ids[i]``.
    trajectory : ndarray, shape (T, 3), optional
        The estimated vehicle pose (x, y, theta), m and rad, after each of the ``T`` steps the SLAM
        was driven through: row ``t`` is the estimate, once step ``t`` (control ``controls[t]``
        and the observations made after it) is processed, of the true pose
        ``scenario.true_poses[t + 1]`` (the known start pose ``true_poses[0]`` is not repeated).
        None when the SLAM does not report its trajectory; the absolute trajectory error
        (:func:`faultlab.metrics.trajectory_error_mm`) is then NaN, as it is for a trajectory
        with a non-finite pose (:meth:`validate` checks its shape only: a diverged trajectory
        does not make the map unscorable).  Which pose a SLAM reports
        per step (a particle filter's highest-weight particle, a smoother's smoothed pose) is
        its own choice, documented by the SLAM.
    covariance : ndarray, shape (3 + 2M, 3 + 2M), optional
        The SLAM's covariance of its final state, in m and rad: the pose (x, y, theta) first, then
        landmark ``i``'s (x, y) at rows ``3 + 2i`` and ``4 + 2i`` (the order of ``landmark_ids``).
        Finite, symmetric and positive semi-definite (:meth:`validate`, to rounding:
        :func:`covariance_problem`).  None when the SLAM does not report one; the consistency oracle
        of ``faultlab check`` (NEES) then cannot judge it.
    """

    pose: np.ndarray
    landmark_ids: np.ndarray
    landmarks: np.ndarray
    trajectory: np.ndarray | None = None
    covariance: np.ndarray | None = None

    def validate(self, *, where: str = "estimate") -> "Estimate":
        """Raise :class:`SlamOutputError` unless shapes are right and values finite."""
        pose = np.asarray(self.pose, dtype=float)
        ids = np.asarray(self.landmark_ids)
        lm = np.asarray(self.landmarks, dtype=float)
        if pose.shape != (3,):
            raise SlamOutputError(f"{where}: pose must have shape (3,), got {pose.shape}")
        if ids.ndim != 1 or lm.shape != (ids.shape[0], 2):
            raise SlamOutputError(f"{where}: landmarks must have shape (M, 2) matching landmark_ids (M,), "
                                  f"got {lm.shape} and {ids.shape}")
        if ids.size and not np.issubdtype(ids.dtype, np.integer):
            raise SlamOutputError(f"{where}: landmark ids must be integers, got dtype {ids.dtype}")
        if len(np.unique(ids)) != ids.size:
            raise SlamOutputError(f"{where}: duplicate landmark ids")
        if not np.all(np.isfinite(pose)):
            raise SlamOutputError(f"{where}: pose is not finite: {pose}")
        bad = ~np.all(np.isfinite(lm), axis=1)
        if np.any(bad):
            raise SlamOutputError(f"{where}: landmark {ids[bad][0]} has a non-finite position "
                                  f"({int(bad.sum())} of {ids.size} landmarks)")
        if self.trajectory is not None:
            traj = np.asarray(self.trajectory)
            if traj.ndim != 2 or traj.shape[1] != 3 or not np.issubdtype(traj.dtype, np.number):
                raise SlamOutputError(f"{where}: trajectory must be numbers of shape (T, 3) = one pose "
                                      f"(x, y, theta) per step, got shape {traj.shape} of dtype {traj.dtype}")
        if self.covariance is not None:
            problem = covariance_problem(self.covariance, 3 + 2 * ids.size)
            if problem:
                raise SlamOutputError(f"{where}: covariance {problem}")
        return self

    def as_dict(self) -> dict[int, tuple[float, float]]:
        """The map as ``{id: (x, y)}``."""
        return {int(i): (float(p[0]), float(p[1])) for i, p in zip(self.landmark_ids, self.landmarks)}


#: Relative rounding allowed in a covariance's symmetry and its smallest eigenvalue
#: (times the largest absolute entry): what an EKF's float updates leave, far below any real asymmetry.
COVARIANCE_RTOL = 1e-9


def covariance_problem(covariance, dim: int) -> str:
    """What is wrong with ``covariance`` as the covariance of a state of ``dim`` numbers ("" when nothing).

    It must be a finite (dim, dim) matrix, symmetric and positive semi-definite to within
    :data:`COVARIANCE_RTOL` times its largest absolute entry.
    """
    try:
        c = np.asarray(covariance, dtype=float)
    except (TypeError, ValueError):
        return "is not a matrix of numbers"
    if c.shape != (dim, dim):
        return f"must have shape ({dim}, {dim}) (the pose, then 2 per landmark), got {c.shape}"
    if not np.all(np.isfinite(c)):
        return "is not finite"
    tol = COVARIANCE_RTOL * max(float(np.max(np.abs(c))), np.finfo(float).tiny)
    asym = float(np.max(np.abs(c - c.T)))
    if asym > tol:
        return f"is not symmetric (largest |C - C^T| = {asym:.3g})"
    low = float(np.linalg.eigvalsh(0.5 * (c + c.T))[0])
    if low < -tol:
        return f"is not positive semi-definite (smallest eigenvalue {low:.3g})"
    return ""


def as_control(control) -> np.ndarray:
    """Validate one control ``(v, omega)``; return it as a float array of shape (2,)."""
    u = np.asarray(control, dtype=float)
    if u.shape != (2,):
        raise SlamInputError(f"control must have shape (2,) = (v, omega), got {u.shape}")
    if not np.all(np.isfinite(u)):
        raise SlamInputError(f"control is not finite: {u}")
    return u


def as_start_pose(pose, *, where: str) -> np.ndarray:
    """Validate a start pose ``(x, y, theta)`` given to ``where``; return it as a new float array (3,).

    Raises
    ------
    SlamInputError
        Not 3 finite numbers.
    """
    p = np.array(pose, dtype=float)
    if p.shape != (3,) or not np.all(np.isfinite(p)):
        raise SlamInputError(f"{where}: start pose must be 3 finite numbers (x, y, theta), got {pose!r}")
    return p


def check_generator(rng, *, where: str) -> None:
    """Raise :class:`SlamInputError` (naming ``where``) unless ``rng`` is a :class:`numpy.random.Generator`."""
    if not isinstance(rng, np.random.Generator):
        raise SlamInputError(f"{where}: rng must be a numpy.random.Generator, got {type(rng).__name__}")


class SlamAdapter(abc.ABC):
    """Base class of every SLAM under test.

    Implement :meth:`reset`, :meth:`update` and :meth:`estimate`.  The driver
    calls :meth:`step`, which validates the input and forwards it.
    """

    #: Short name used in results tables.
    name: str = "slam"

    #: Whether :meth:`reset_batch` and :meth:`estimates` run several repetitions at once
    #: (:func:`run_slam_batch`); a SLAM without it is run one repetition at a time.
    supports_batch: ClassVar[bool] = False

    #: ``"known"``: observations carry landmark ids; ``"unknown"``: the driver hides them and the SLAM
    #: associates observations itself (see "Data association" in the module docstring).
    association: ClassVar[str] = KNOWN_ASSOCIATION

    @abc.abstractmethod
    def reset(self, pose: np.ndarray, *, rng: np.random.Generator) -> None:
        """Start from the known pose (x, y, theta), forgetting any map.

        All randomness must come from ``rng``.
        """

    @abc.abstractmethod
    def update(self, control: np.ndarray, observations: Observations) -> None:
        """Process one validated step: control (2,) then the observations from the new pose."""

    @abc.abstractmethod
    def estimate(self) -> Estimate:
        """The current pose and landmark map."""

    def reset_batch(self, pose: np.ndarray, *, rngs: Sequence[np.random.Generator]) -> None:
        """Start ``len(rngs)`` independent repetitions from the same pose, one per generator.

        Only for SLAMs with :attr:`supports_batch`.  Repetition ``i`` must behave exactly as
        :meth:`reset` with ``rng=rngs[i]`` followed by the same steps: same seed, same estimate.
        """
        raise NotImplementedError(f"{type(self).__name__} does not run repetitions in a batch")

    def estimates(self) -> list:
        """After :meth:`reset_batch`: per repetition, its :class:`Estimate` or the exception that stopped it."""
        raise NotImplementedError(f"{type(self).__name__} does not run repetitions in a batch")

    def step(self, control, observations: Observations | None = None) -> None:
        """Validate ``control`` and ``observations`` and call :meth:`update`."""
        u = as_control(control)
        if observations is None:
            observations = Observations.empty()
        elif not isinstance(observations, Observations):
            observations = Observations(*observations)
        if observations.hidden and len(observations) and association_of(self) != UNKNOWN_ASSOCIATION:
            raise SlamInputError(f"{_label(self)} needs landmark ids "
                                 f"(association {association_of(self)!r}) but the observations hide them")
        self.update(u, observations)


def association_of(slam) -> str:
    """The data association a SLAM declares (:attr:`SlamAdapter.association`; ``"known"`` if it declares none)."""
    value = getattr(slam, "association", KNOWN_ASSOCIATION)
    if value not in ASSOCIATIONS:
        raise SlamInputError(f"{_label(slam)}: association must be one of {', '.join(map(repr, ASSOCIATIONS))}, "
                             f"got {value!r}")
    return value


def _label(slam) -> str:
    """The SLAM's name for messages (its class name if it has none)."""
    return getattr(slam, "name", type(slam).__name__)


def _all_valid(scenario) -> bool:
    """Whether the observations of every step of ``scenario`` pass the checks of :class:`Observations`
    as float64 ranges and bearings and int64 ids (one vectorised pass over the whole scenario).

    If not, the driver builds each step's observations with the checks, which raise at the step
    concerned with the message of that step.
    """
    r, b, ids = scenario.obs_range, scenario.obs_bearing, scenario.obs_ids
    offsets = np.asarray(scenario.obs_offsets)
    if not all(type(a) is np.ndarray and a.ndim == 1 and a.shape == r.shape for a in (r, b, ids)):
        return False
    if r.dtype != np.float64 or b.dtype != np.float64 or ids.dtype != np.int64:
        return False
    if not r.size:
        return True
    if not (np.isfinite(r).all() and np.isfinite(b).all() and r.min() >= 0):
        return False
    step = np.repeat(np.arange(offsets.size - 1), np.diff(offsets))
    if step.size != ids.size:
        return False
    order = np.lexsort((ids, step))
    s_ids, s_step = ids[order], step[order]
    return not ((s_ids[1:] == s_ids[:-1]) & (s_step[1:] == s_step[:-1])).any()


def _feed(slam: SlamAdapter, scenario) -> None:
    """Step ``slam`` through the scenario: each step's control and the observations made after it, with
    the ids hidden if the SLAM associates observations itself."""
    offsets = scenario.obs_offsets
    controls = scenario.controls
    hide = association_of(slam) == UNKNOWN_ASSOCIATION
    checked = not hide and _all_valid(scenario)
    make = Observations._checked if checked else Observations
    # step() only checks the control and the observations: with every one known to pass, update() is called
    controls_ok = (type(controls) is np.ndarray and controls.dtype == np.float64
                   and controls.shape == (scenario.n_steps, 2) and bool(np.isfinite(controls).all()))
    advance = slam.update if checked and controls_ok and type(slam).step is SlamAdapter.step else slam.step
    for t in range(scenario.n_steps):
        a, b = offsets[t], offsets[t + 1]
        if hide:
            obs = Observations.without_ids(scenario.obs_range[a:b], scenario.obs_bearing[a:b])
        else:
            obs = make(scenario.obs_range[a:b], scenario.obs_bearing[a:b], scenario.obs_ids[a:b])
        advance(controls[t], obs)


def run_slam(slam: SlamAdapter, scenario, *, rng: np.random.Generator) -> Estimate:
    """Drive ``slam`` through every step of ``scenario`` and return its validated final estimate.

    Parameters
    ----------
    slam : SlamAdapter
    scenario : faultlab.scenario.model.Scenario
    rng : numpy.random.Generator
        The SLAM's own randomness (repetition seed).

    Raises
    ------
    SlamOutputError
        If the final estimate is malformed or not finite.
    """
    slam.reset(scenario.start_pose, rng=rng)
    _feed(slam, scenario)
    return slam.estimate().validate(where=f"{_label(slam)} estimate")


def run_slam_batch(slam: SlamAdapter, scenario, *, rngs: Sequence[np.random.Generator]) -> list:
    """Run several repetitions of ``scenario`` in one batched SLAM (:attr:`SlamAdapter.supports_batch`).

    Repetition ``i`` gives exactly what ``run_slam(fresh_slam, scenario, rng=rngs[i])`` gives:
    the same validated estimate, or the same exception.

    Parameters
    ----------
    slam : SlamAdapter
        A SLAM whose ``supports_batch`` is true.
    scenario : faultlab.scenario.model.Scenario
    rngs : sequence of numpy.random.Generator
        One generator per repetition.

    Returns
    -------
    list
        Per repetition, its validated :class:`Estimate` or the exception that ended it (a
        failure in one repetition leaves the others running).  An exception that the SLAM
        cannot attribute to one repetition propagates: rerun the repetitions one at a time.
    """
    if not getattr(slam, "supports_batch", False):
        raise SlamInputError(f"{_label(slam)} does not run repetitions in a batch; use run_slam for each "
                             "repetition")
    slam.reset_batch(scenario.start_pose, rngs=rngs)
    _feed(slam, scenario)
    where = f"{_label(slam)} estimate"
    out = []
    for est in slam.estimates():
        if not isinstance(est, BaseException):
            try:
                est = est.validate(where=where)
            except SlamOutputError as exc:
                est = exc
        out.append(est)
    return out
