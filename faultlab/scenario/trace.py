"""Sensor traces (Sec. VI-B) and observation simulation (Sec. VI-C).

The vehicle starts at the centre ``(0, 0)`` with heading 0.  Every active step
applies a control ``u = (v, omega)``: drive ``v`` along the heading, then turn
by ``omega`` (FastSLAM's motion model with dt = 1), and then observes from the
new pose.

Steering (Sec. VI-B): the vehicle drives towards a *target* landmark.  ``v``
is always the step size (the "measurement step size" is the distance between
updates, so it is never shortened).  ``omega`` is the bearing of the target
seen from the position after driving, wrapped to [-pi, pi), with no turn-rate
limit, so after the step the vehicle faces the target; a small Gaussian
perturbation (``path_turn_std``, default 0.05 rad) is added to every true
turn: the "noise added to the simulated vehicle path" that keeps the
traversal from being deterministic.  A landmark is *seen* when it is within
sensor range and field of view after a step; every landmark seen counts, not
only the target.  When the target has been seen, the next target is an unseen
landmark: uniformly at random (``random`` class), or (``loop`` class) the
unseen landmark with the smallest counter-clockwise polar-angle increment from
the previous target's polar angle around the map centre (starting from angle
0), so targets go round the centre in angular order.  When every landmark has
been seen, all are marked unseen again (a new *round*); a loop round starts
with the landmark after the last target (which itself comes last).

Inactivity (Sec. VI-B): ``inactivity`` steps with control exactly (0, 0) and no
observations are inserted after ``n_steps // 2`` active steps.

Field of view: a landmark is within the field of view iff ``|bearing| <= fov / 2`` (``fov`` is the
full opening angle, Table I).  ``fov_bug=True`` reproduces a *defect* of the paper's replication
package instead (``simulator.py``): it tests ``min(angle, 2 pi - angle) < sensor_fov`` with
``angle`` in [-pi, pi) and ``sensor_fov`` the half opening (its FoV classes span [pi/4, pi], half of
Table I's [pi/2, 2 pi]).  For a left-side bearing (``angle >= 0``) that is the intended half-angle
test; for a right-side bearing ``min`` returns the negative angle itself, so *every* landmark on the
right passes whatever the opening.  With the defect the visible region is
``bearing < 0 or bearing <= fov / 2``; it decides both what is observed and which landmarks count as
seen for the steering, as in the package.  Off by default.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from faultlab.errors import ScenarioError

__all__ = ["Drive", "Measurements", "drive", "measure_controls", "measure_observations", "wrap_angle",
           "in_field_of_view", "DEFAULT_PATH_TURN_STD"]

DEFAULT_PATH_TURN_STD = 0.05  # rad, perturbation of every true turn ("noise on the path", Sec. VI-B)
_TWO_PI = 2.0 * math.pi


def wrap_angle(a):
    """Wrap angles to [-pi, pi)."""
    return (np.asarray(a) + math.pi) % _TWO_PI - math.pi


def in_field_of_view(bearing: np.ndarray, fov: float, *, fov_bug: bool = False) -> np.ndarray:
    """Which bearings lie within the field of view.

    Parameters
    ----------
    bearing : ndarray
        Bearings relative to the heading, wrapped to [-pi, pi), rad.
    fov : float
        Full opening angle, rad.
    fov_bug : bool
        Reproduce the replication package's defect (see the module docstring): every
        negative (right-side) bearing is visible, the left side up to ``fov / 2``.

    Returns
    -------
    ndarray of bool, same shape as ``bearing``
        ``|bearing| <= fov / 2``, or with the defect ``bearing < 0 or bearing <= fov / 2``.
    """
    b = np.asarray(bearing)
    visible = np.abs(b) <= fov / 2.0
    if fov_bug:
        visible |= b < 0.0
    return visible


@dataclass(frozen=True, eq=False)
class Drive:
    """The true motion of one trace and what is visible after every step.

    Attributes
    ----------
    poses : ndarray, shape (T + 1, 3)
        True poses (x, y, theta), theta in [-pi, pi); ``poses[0] = (0, 0, 0)``.
    controls : ndarray, shape (T, 2)
        True controls (v, omega) (zero in inactive steps).
    active : ndarray, shape (T,), bool
        False for the inserted inactivity steps.
    vis_offsets : ndarray, shape (T + 1,), int64
        CSR offsets into ``vis_index``.
    vis_index : ndarray, shape (M,), int64
        Row indices into the landmark array of the landmarks within range and
        FoV after each step, sorted by landmark id within a step.
    targets : ndarray, shape (K,), int64
        Row index of every target in the order chosen.
    target_steps : ndarray, shape (K,), int64
        Step at which each target was chosen (the first step driving to it).
    target_rounds : ndarray, shape (K,), int64
        Round (0-based) in which each target was chosen.
    inactivity_start : int
        First inactive step (``n_steps // 2``).
    """

    poses: np.ndarray
    controls: np.ndarray
    active: np.ndarray
    vis_offsets: np.ndarray
    vis_index: np.ndarray
    targets: np.ndarray
    target_steps: np.ndarray
    target_rounds: np.ndarray
    inactivity_start: int


def drive(landmarks: np.ndarray, landmark_ids: np.ndarray | None = None, *, rng: np.random.Generator,
          n_steps: int, step: float, fov: float, sensor_range: float, loop: bool, inactivity: int = 0,
          path_turn_std: float = DEFAULT_PATH_TURN_STD, fov_bug: bool = False) -> Drive:
    """Simulate the true path and the visible landmarks (Sec. VI-B).

    Parameters
    ----------
    landmarks : ndarray, shape (L, 2)
        Landmark positions, m (L >= 1).
    landmark_ids : ndarray, shape (L,), optional
        Ids used to sort the visible landmarks of a step; row order if None.
    rng : numpy.random.Generator
    n_steps : int
        Active steps.
    step : float
        Forward distance per active step, m.
    fov : float
        Full opening angle, rad; visible iff ``|bearing| <= fov / 2`` (see :func:`in_field_of_view`).
    sensor_range : float
        Visible iff ``range <= sensor_range``, m.
    loop : bool
        Targets in polar-angle order (``loop`` class) instead of random order.
    inactivity : int
        Idle steps inserted after ``n_steps // 2`` active steps.
    path_turn_std : float
        Std of the Gaussian perturbation of every true turn, rad.
    fov_bug : bool
        Reproduce the replication package's field-of-view defect (right-side bearings always
        visible); False by default.

    Returns
    -------
    Drive
    """
    lm = np.asarray(landmarks, dtype=float)
    L = lm.shape[0]
    if L == 0:
        raise ScenarioError("trace: the map has no landmarks to steer towards "
                            "(map_size x landmark_density < 1)")
    if n_steps < 0 or inactivity < 0:
        raise ScenarioError(f"trace: n_steps ({n_steps}) and inactivity ({inactivity}) must be >= 0")
    ids = np.arange(L) if landmark_ids is None else np.asarray(landmark_ids)
    sort_ids = landmark_ids is not None and bool(np.any(np.diff(ids) < 0))
    tree = cKDTree(lm)
    turn_noise = rng.normal(0.0, path_turn_std, n_steps) if path_turn_std > 0 else np.zeros(n_steps)
    chooser = _TargetChooser(lm, loop=loop, rng=rng)

    poses = np.zeros((n_steps + 1, 3))
    controls = np.zeros((n_steps, 2))
    controls[:, 0] = step
    vis: list[np.ndarray] = []
    target = -1
    x = y = th = 0.0
    for t in range(n_steps):
        if target < 0:
            target = chooser.next(t)
        # drive v along the heading, then turn towards the target
        x += step * math.cos(th)
        y += step * math.sin(th)
        tx, ty = lm[target]
        omega = (math.atan2(ty - y, tx - x) - th + math.pi) % _TWO_PI - math.pi + turn_noise[t]
        th = (th + omega + math.pi) % _TWO_PI - math.pi
        poses[t + 1] = (x, y, th)
        controls[t, 1] = omega
        idx = _visible(lm, tree, (x, y, th), sensor_range=sensor_range, fov=fov, fov_bug=fov_bug,
                       ids=ids if sort_ids else None)
        chooser.unseen[idx] = False
        vis.append(idx)
        if not chooser.unseen[target]:
            target = -1
    return _with_inactivity(poses, controls, vis, chooser, n_steps=n_steps, inactivity=int(inactivity))


class _TargetChooser:
    """Sec. VI-B: the vehicle steers towards a not-yet-seen landmark, in random or polar-angle order.

    When every landmark has been seen, a new round starts with all of them unseen again.
    """

    def __init__(self, lm: np.ndarray, *, loop: bool, rng: np.random.Generator):
        self.polar = np.mod(np.arctan2(lm[:, 1], lm[:, 0]), _TWO_PI)
        self.loop, self.rng = loop, rng
        self.unseen = np.ones(lm.shape[0], dtype=bool)
        self.targets: list[int] = []
        self.steps: list[int] = []
        self.rounds: list[int] = []
        self.round = 0
        self.last = -1
        self.prev_angle = 0.0

    def next(self, t: int) -> int:
        """The target chosen at step ``t`` (recorded with its step and round)."""
        if not self.unseen.any():
            self.unseen[:] = True
            self.round += 1
        cand = np.flatnonzero(self.unseen)
        if self.loop:
            inc = np.mod(self.polar[cand] - self.prev_angle, _TWO_PI)
            inc[cand == self.last] = _TWO_PI  # after a reset, the last target comes last
            target = int(cand[np.argmin(inc)])
            self.prev_angle = self.polar[target]
        else:
            target = int(cand[self.rng.integers(cand.size)])
        self.last = target
        self.targets.append(target)
        self.steps.append(t)
        self.rounds.append(self.round)
        return target


def _visible(lm: np.ndarray, tree: cKDTree, pose: tuple[float, float, float], *, sensor_range: float,
             fov: float, fov_bug: bool, ids: np.ndarray | None) -> np.ndarray:
    """Indices of the landmarks visible from ``pose``: in range and in the field of view.

    Sorted by ``ids`` when given (stable), else by index.
    """
    x, y, th = pose
    idx = np.asarray(tree.query_ball_point((x, y), sensor_range), dtype=np.int64)
    if not idx.size:
        return idx
    d = lm[idx]
    b = (np.arctan2(d[:, 1] - y, d[:, 0] - x) - th + math.pi) % _TWO_PI - math.pi
    idx = idx[in_field_of_view(b, fov, fov_bug=fov_bug)]
    return idx[np.argsort(ids[idx], kind="stable")] if ids is not None else np.sort(idx)


def _with_inactivity(poses: np.ndarray, controls: np.ndarray, vis: list[np.ndarray], chooser: _TargetChooser, *,
                     n_steps: int, inactivity: int) -> Drive:
    """The :class:`Drive` with ``inactivity`` idle steps inserted in the middle (Sec. VI-B)."""
    mid, k = n_steps // 2, inactivity
    poses = np.concatenate([poses[: mid + 1], np.repeat(poses[mid: mid + 1], k, axis=0), poses[mid + 1:]])
    controls = np.concatenate([controls[:mid], np.zeros((k, 2)), controls[mid:]])
    active = np.concatenate([np.ones(mid, bool), np.zeros(k, bool), np.ones(n_steps - mid, bool)])
    empty = np.empty(0, dtype=np.int64)
    vis = vis[:mid] + [empty] * k + vis[mid:]
    counts = np.fromiter((v.size for v in vis), dtype=np.int64, count=len(vis))
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    vis_index = np.concatenate(vis).astype(np.int64) if vis else empty
    tsteps = np.asarray(chooser.steps, dtype=np.int64)
    tsteps = np.where(tsteps >= mid, tsteps + k, tsteps)
    return Drive(poses=poses, controls=controls, active=active, vis_offsets=offsets, vis_index=vis_index,
                 targets=np.asarray(chooser.targets, dtype=np.int64), target_steps=tsteps,
                 target_rounds=np.asarray(chooser.rounds, dtype=np.int64), inactivity_start=mid)


def measure_controls(true_controls: np.ndarray, active: np.ndarray, *, rng: np.random.Generator,
                     std_distance: float, std_angle: float, bias_distance: float, bias_angle: float,
                     rotation_error: float) -> np.ndarray:
    """Measured controls fed to the SLAM (Sec. VI-C), shape (T, 2).

    ``v + bias_distance + N(0, std_distance)`` and
    ``omega + bias_angle + N(0, std_angle) + rotation_error``; inactive steps
    are exactly (0, 0).
    """
    T = true_controls.shape[0]
    noise = rng.normal(0.0, 1.0, size=(T, 2)) * np.array([std_distance, std_angle])
    u = true_controls + noise + np.array([bias_distance, bias_angle + rotation_error])
    u[~active] = 0.0
    return u


@dataclass(frozen=True, eq=False)
class Measurements:
    """Simulated observations in CSR layout (offsets are those of the :class:`Drive`).

    Attributes
    ----------
    range, bearing : ndarray, shape (M,)
        Measured range (m, >= 0) and bearing (rad, not wrapped: the rotation
        error must survive).
    ids : ndarray, shape (M,), int64
    true_range, true_bearing : ndarray, shape (M,)
        Noise-free geometry (bearing wrapped to [-pi, pi)).
    outlier : ndarray, shape (M,), bool
        Observations replaced by an outlier range.
    """

    range: np.ndarray
    bearing: np.ndarray
    ids: np.ndarray
    true_range: np.ndarray
    true_bearing: np.ndarray
    outlier: np.ndarray


def measure_observations(landmarks: np.ndarray, landmark_ids: np.ndarray, drv: Drive, *,
                         rng: np.random.Generator, std_distance: float, std_angle: float, bias_distance: float,
                         bias_angle: float, outlier_probability: float, rotation_error: float,
                         sensor_range: float) -> Measurements:
    """Range-bearing observations of the visible landmarks (Sec. VI-C), vectorised over all steps.

    range = max(0, true + bias_distance + N(0, std_distance));
    bearing = true + bias_angle + N(0, std_angle) + rotation_error.
    With probability ``outlier_probability`` an observation is an outlier:
    half of them (each with probability 1/2) read the maximum range
    ``sensor_range``, the others a range uniform in [0, true range].
    """
    lm = np.asarray(landmarks, dtype=float)
    T = drv.vis_offsets.shape[0] - 1
    step_of = np.repeat(np.arange(T), np.diff(drv.vis_offsets))
    pose = drv.poses[step_of + 1]
    d = lm[drv.vis_index] - pose[:, :2]
    r = np.hypot(d[:, 0], d[:, 1])
    b = wrap_angle(np.arctan2(d[:, 1], d[:, 0]) - pose[:, 2])
    M = r.shape[0]
    noise = rng.normal(0.0, 1.0, size=(M, 2))
    rng_meas = np.maximum(r + bias_distance + std_distance * noise[:, 0], 0.0)
    bearing = b + bias_angle + std_angle * noise[:, 1] + rotation_error
    u = rng.random((M, 3))
    outlier = u[:, 0] < outlier_probability
    max_range = outlier & (u[:, 1] < 0.5)
    short = outlier & ~max_range
    rng_meas = np.where(max_range, sensor_range, rng_meas)
    rng_meas = np.where(short, u[:, 2] * r, rng_meas)
    return Measurements(range=rng_meas, bearing=bearing, ids=np.asarray(landmark_ids, np.int64)[drv.vis_index],
                        true_range=r, true_bearing=b, outlier=outlier)
