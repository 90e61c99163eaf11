"""Integrates the odometry and puts each landmark where it was first seen (the tutorial's SLAM)."""

import numpy as np

from faultlab.slam import Estimate, SlamAdapter


class OdometryMapper(SlamAdapter):
    """Integrates the odometry and puts each landmark where it was first seen."""

    name = "odometry_mapper"

    def reset(self, pose, *, rng):
        self.pose = np.array(pose, dtype=float)  # (x, y, theta); rng unused: deterministic
        self.map = {}                            # landmark id -> (x, y)

    def update(self, control, observations):
        v, omega = control                       # drive v along the heading, then turn omega
        x, y, th = self.pose
        x, y = x + v * np.cos(th), y + v * np.sin(th)
        th = (th + omega + np.pi) % (2 * np.pi) - np.pi
        self.pose = np.array([x, y, th])
        for r, b, i in zip(observations.ranges, observations.bearings, observations.ids):
            self.map.setdefault(int(i), (x + r * np.cos(th + b), y + r * np.sin(th + b)))

    def estimate(self):
        ids = np.array(sorted(self.map), dtype=np.int64)
        xy = np.array([self.map[i] for i in ids], dtype=float).reshape(-1, 2)
        return Estimate(self.pose.copy(), ids, xy)


def make():  # faultlab: no mutate
    """The factory an experiment's [slam] table names: ``odometry_mapper.mapper:make``."""
    return OdometryMapper()
