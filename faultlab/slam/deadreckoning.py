"""Dead reckoning: the no-SLAM baseline a SLAM under test should beat.

The pose is the integral of the measured controls (the reference motion model,
no noise, no correction).  Each landmark is placed at the mean of all its
observations, each projected from the odometry pose at which it was made.
"""

from __future__ import annotations

import numpy as np

from faultlab.errors import SlamInputError
from faultlab.slam import units as _units
from faultlab.slam.protocol import Estimate, Observations, SlamAdapter, as_start_pose

__all__ = ["DeadReckoning"]


class DeadReckoning(SlamAdapter):
    """Odometry-only baseline (deterministic; ``rng`` is accepted and unused)."""

    name = "dead_reckoning"

    def reset(self, pose: np.ndarray, *, rng: np.random.Generator | None = None) -> None:
        self._pose = as_start_pose(pose, where=self.name).reshape(1, 3)
        self._pose[0, 2] = _units.wrap_heading(self._pose[0, 2])
        self._ids = np.empty(0, dtype=np.int64)  # sorted
        self._sum = np.empty((0, 2))
        self._count = np.empty(0, dtype=np.int64)
        self._trajectory: list[np.ndarray] = []

    def update(self, control: np.ndarray, observations: Observations) -> None:
        if not hasattr(self, "_pose"):
            raise SlamInputError(f"{self.name}: update() called before reset()")
        u = np.asarray(control, dtype=float).reshape(1, 2)
        self._pose = _units.motion_model(self._pose, u, wrap=_units.wrap_heading)
        self._trajectory.append(self._pose[0].copy())
        if len(observations) == 0:
            return
        x, y, th = self._pose[0]
        a = th + observations.bearings
        xy = np.stack([x + observations.ranges * np.cos(a), y + observations.ranges * np.sin(a)], axis=1)
        ids = observations.ids
        pos = np.searchsorted(self._ids, ids)
        known = pos < self._ids.size
        known[known] = self._ids[pos[known]] == ids[known]
        if not known.all():
            self._ids = np.concatenate([self._ids, ids[~known]])
            self._sum = np.concatenate([self._sum, np.zeros((int((~known).sum()), 2))])
            self._count = np.concatenate([self._count, np.zeros(int((~known).sum()), dtype=np.int64)])
            order = np.argsort(self._ids, kind="stable")
            self._ids, self._sum, self._count = self._ids[order], self._sum[order], self._count[order]
            pos = np.searchsorted(self._ids, ids)
        # ids are unique within a step (Observations checks), so plain fancy += is exact
        self._sum[pos] += xy
        self._count[pos] += 1

    def estimate(self) -> Estimate:
        if not hasattr(self, "_pose"):
            raise SlamInputError(f"{self.name}: reset() must be called first")
        trajectory = np.array(self._trajectory).reshape(-1, 3)  # the odometry pose after every step
        return Estimate(self._pose[0].copy(), self._ids.copy(), self._sum / self._count[:, None], trajectory=trajectory)
