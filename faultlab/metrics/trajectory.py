"""Absolute trajectory error (ATE): the translational error of an estimated trajectory after alignment.

The convention of the TUM RGB-D benchmark and of evo's APE on the translation part: the estimated
positions ``q_i`` are moved by the rigid motion ``(R, t)`` that minimises ``sum |R q_i + t - p_i|^2``
against the reference positions ``p_i`` (Umeyama's least-squares method without scale: a proper
rotation, ``det R = +1``), and the error of pose ``i`` is ``|R q_i + t - p_i|``.  Poses are matched by
index (the trajectories must be sampled at the same times).

With centred points ``P`` and ``Q`` (N, d) and the SVD ``P^T Q / N = U S V^T``, the rotation is
``R = U diag(1, ..., 1, det(U V^T)) V^T`` and ``t = mean(p) - R mean(q)`` (Umeyama 1991, without the
scale factor).  ``d = 2`` aligns planar trajectories in SE(2), ``d = 3`` in SE(3).

A SLAM's estimate may carry its trajectory (:attr:`faultlab.slam.Estimate.trajectory`, one pose
per step); :func:`trajectory_error_mm` scores it against the scenario's true poses after each step
(``true_poses[1:]``), as the results table's ``ate_mm`` column.  :func:`absolute_trajectory_error`
also scores trajectories from elsewhere (e.g. TUM files of a SLAM's own log, :mod:`faultlab.scenario.tum`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from faultlab.errors import SlamOutputError

__all__ = ["TrajectoryError", "absolute_trajectory_error", "align_rigid", "trajectory_error_mm"]

_MM_PER_M = 1000.0


@dataclass(frozen=True, eq=False)
class TrajectoryError:
    """Result of :func:`absolute_trajectory_error`.

    Attributes
    ----------
    rmse, mean, median, max : float
        Statistics of the per-pose errors, m.
    errors : ndarray, shape (N,)
        Per-pose translational error after alignment, m.
    rotation : ndarray, shape (d, d)
        Proper rotation of the alignment.
    translation : ndarray, shape (d,)
        Translation; the aligned estimate is ``est @ rotation.T + translation``.
    """

    rmse: float
    mean: float
    median: float
    max: float
    errors: np.ndarray
    rotation: np.ndarray
    translation: np.ndarray


def _positions(xy, *, what: str) -> np.ndarray:
    p = np.asarray(xy, dtype=float)
    if p.ndim != 2 or p.shape[1] not in (2, 3):
        raise SlamOutputError(f"{what}: positions must have shape (N, 2) or (N, 3), got {p.shape}")
    if not np.all(np.isfinite(p)):
        raise SlamOutputError(f"{what}: positions are not finite")
    return p


def align_rigid(reference, estimate) -> tuple[np.ndarray, np.ndarray]:
    """The rotation (d, d) and translation (d,) that best map ``estimate`` (N, d) onto ``reference`` (N, d).

    Least squares over proper rigid motions (module docstring); ``d`` is 2 or 3.
    """
    p = _positions(reference, what="reference trajectory")
    q = _positions(estimate, what="estimated trajectory")
    if p.shape != q.shape:
        raise SlamOutputError(f"trajectories must have the same shape, got {p.shape} (reference) and {q.shape}")
    if p.shape[0] < 1:
        raise SlamOutputError("trajectories are empty")
    mp, mq = p.mean(axis=0), q.mean(axis=0)
    u, _, vt = np.linalg.svd((p - mp).T @ (q - mq) / p.shape[0])
    s = np.ones(p.shape[1])
    s[-1] = np.sign(np.linalg.det(u @ vt)) or 1.0
    rotation = (u * s) @ vt
    return rotation, mp - rotation @ mq


def absolute_trajectory_error(reference, estimate) -> TrajectoryError:
    """ATE of ``estimate`` against ``reference`` after rigid alignment without scale.

    Parameters
    ----------
    reference, estimate : array_like, shape (N, d)
        Positions (m) of the same N time steps; ``d`` = 2 (planar, SE(2)) or 3 (SE(3)).  Planar poses
        ``(x, y, theta)`` are passed as their first two columns.

    Returns
    -------
    TrajectoryError
    """
    rotation, translation = align_rigid(reference, estimate)
    aligned = np.asarray(estimate, dtype=float) @ rotation.T + translation
    errors = np.linalg.norm(aligned - np.asarray(reference, dtype=float), axis=1)
    return TrajectoryError(rmse=float(np.sqrt(np.mean(errors ** 2))), mean=float(errors.mean()),
                           median=float(np.median(errors)), max=float(errors.max()), errors=errors,
                           rotation=rotation, translation=translation)


def trajectory_error_mm(scenario, estimate) -> float:
    """The ATE (root mean square, mm) of an estimate's trajectory against the scenario's true poses.

    Row ``t`` of ``estimate.trajectory`` (the pose after step ``t``) is matched with
    ``scenario.true_poses[t + 1]``; the positions (x, y) are aligned in SE(2) as in
    :func:`absolute_trajectory_error` and the RMSE of the per-pose errors is returned in mm (the
    results table's ``ate_mm``).

    Parameters
    ----------
    scenario : faultlab.scenario.Scenario
        Provides ``true_poses`` (T + 1, 3), m and rad.
    estimate : faultlab.slam.Estimate
        Its ``trajectory`` (T, 3) or None.

    Returns
    -------
    float
        NaN when the estimate has no trajectory, when it has a non-finite pose (a diverged
        filter: no alignment exists) or when the scenario has no step.

    Raises
    ------
    SlamOutputError
        The trajectory does not have one pose (x, y, theta) per step of the scenario.
    """
    if hasattr(scenario, "require_truth"):
        scenario.require_truth("the absolute trajectory error")
    traj = getattr(estimate, "trajectory", None)
    if traj is None:
        return float("nan")
    traj = np.asarray(traj, dtype=float)
    truth = np.asarray(scenario.true_poses, dtype=float)[1:]
    if traj.ndim != 2 or traj.shape != (truth.shape[0], 3):
        raise SlamOutputError(f"trajectory: expected one pose (x, y, theta) per step, shape ({truth.shape[0]}, 3), "
                              f"got {traj.shape}")
    if not truth.shape[0] or not np.all(np.isfinite(traj)):
        return float("nan")
    return absolute_trajectory_error(truth[:, :2], traj[:, :2]).rmse * _MM_PER_M
