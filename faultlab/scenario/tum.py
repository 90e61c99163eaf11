"""Trajectories of a test case as TUM files (one pose per line: ``timestamp tx ty tz qx qy qz qw``).

The TUM RGB-D benchmark's format, read by evo (``evo_ape tum ...``) and most SLAM evaluation tools.
Timestamps are s; step ``t`` of a case (0-based) happens at ``(t + 1) * STEP_S`` and the start pose
at 0.  Planar poses ``(x, y, theta)`` are written with ``tz = 0`` and the rotation about z as a unit
quaternion (``qz = sin(theta / 2)``, ``qw = cos(theta / 2)``); every number with 17 significant
digits, so a file reads back to the same doubles (headings to within rounding of the quaternion).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from faultlab.errors import ScenarioError

__all__ = ["STEP_S", "step_times", "odometry_poses", "write_tum", "read_tum"]

#: Duration of one step, s (the motion model's dt = 1).
STEP_S = 1.0


def step_times(n_steps: int) -> np.ndarray:
    """Times (T + 1,) of the start pose and of the pose after every step, s."""
    return np.arange(n_steps + 1, dtype=float) * STEP_S


def odometry_poses(start_pose, controls) -> np.ndarray:
    """Poses (T + 1, 3) from integrating the measured ``controls`` (T, 2) from ``start_pose`` (3,).

    Drive ``v`` along the heading, then turn by ``omega`` (the scenario's motion model); headings
    are left unwrapped.
    """
    start = np.asarray(start_pose, dtype=float)
    u = np.asarray(controls, dtype=float).reshape(-1, 2)
    theta = start[2] + np.concatenate([[0.0], np.cumsum(u[:, 1])])
    x = start[0] + np.concatenate([[0.0], np.cumsum(u[:, 0] * np.cos(theta[:-1]))])
    y = start[1] + np.concatenate([[0.0], np.cumsum(u[:, 0] * np.sin(theta[:-1]))])
    return np.stack([x, y, theta], axis=1)


def write_tum(path: str | Path, times, poses) -> Path:
    """Write planar ``poses`` (N, 3) stamped ``times`` (N,) s as a TUM trajectory file at ``path``."""
    t = np.asarray(times, dtype=float)
    p = np.asarray(poses, dtype=float)
    if p.ndim != 2 or p.shape[1] != 3 or t.shape != (p.shape[0],):
        raise ScenarioError(f"TUM file {path}: poses must have shape (N, 3) and times (N,), got {p.shape} "
                            f"and {t.shape}")
    half = p[:, 2] / 2
    table = np.column_stack([t, p[:, 0], p[:, 1], np.zeros_like(t), np.zeros_like(t), np.zeros_like(t),
                             np.sin(half), np.cos(half)])
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savetxt(path, table, fmt="%.17g", header="timestamp tx ty tz qx qy qz qw")
    return path


def read_tum(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """A TUM file as ``(times (N,), poses (N, 3))``; the heading is the rotation about z (2 atan2(qz, qw))."""
    try:
        table = np.loadtxt(path, comments="#", ndmin=2)
    except (OSError, ValueError) as exc:
        raise ScenarioError(f"TUM file {path}: unreadable ({exc})") from exc
    if table.shape[1] != 8:
        raise ScenarioError(f"TUM file {path}: expected 8 columns per line, got {table.shape[1]}")
    return table[:, 0], np.column_stack([table[:, 1], table[:, 2], 2 * np.arctan2(table[:, 6], table[:, 7])])
