"""A third-party SLAM: an odometry-only mapper that puts each landmark where it was first seen.

faultlab finds it through the entry point declared in ``pyproject.toml``::

    [project.entry-points."faultlab.slams"]
    first_sighting = "faultlab_example_plugin.slam:FIRST_SIGHTING"

An experiment then names it like a built-in (``[slam] name = "first_sighting"``), in every worker
process of a parallel campaign too: each process reads the installed entry points.
"""

from __future__ import annotations

import numpy as np

from faultlab.slam import Estimate, SlamAdapter
from faultlab.slam.registry import SlamKind

__all__ = ["FirstSighting", "FIRST_SIGHTING"]


class FirstSighting(SlamAdapter):
    """Integrates the odometry and puts each landmark where it was first seen."""

    name = "first_sighting"

    def reset(self, pose, *, rng):
        self.pose = np.array(pose, dtype=float)
        self.ids = np.empty(0, dtype=np.int64)
        self.xy = np.empty((0, 2))

    def update(self, control, observations):
        v, omega = control
        x, y, th = self.pose
        x, y = x + v * np.cos(th), y + v * np.sin(th)
        th = (th + omega + np.pi) % (2 * np.pi) - np.pi
        self.pose = np.array([x, y, th])
        ids = np.asarray(observations.ids)
        unseen = ~np.isin(ids, self.ids)
        new, first = np.unique(ids[unseen], return_index=True)
        r = np.asarray(observations.ranges)[unseen][first]
        b = np.asarray(observations.bearings)[unseen][first]
        xy = np.column_stack([x + r * np.cos(th + b), y + r * np.sin(th + b)])
        self.ids, self.xy = np.concatenate([self.ids, new]), np.concatenate([self.xy, xy])

    def estimate(self):
        return Estimate(self.pose.copy(), self.ids.copy(), self.xy.copy())


#: The SLAM as faultlab's catalogue sees it: name, one-line description, adapter factory.
FIRST_SIGHTING = SlamKind("first_sighting", "odometry only, landmarks where first seen", FirstSighting)
