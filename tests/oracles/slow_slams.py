"""A user's odometry mapper that keeps its map as a list and, every step, compares each landmark with
every other in Python to merge near-duplicates (quadratic in the map, slow), and its fixed twin."""

from __future__ import annotations

import numpy as np

from faultlab.slam import Estimate, SlamAdapter


class ListMapper(SlamAdapter):
    name = "list_mapper"

    def __init__(self, quadratic: bool = True):
        self.quadratic = quadratic

    def reset(self, pose, *, rng):
        self.pose = np.array(pose, dtype=float)
        self.map: list[tuple[int, float, float]] = []

    def update(self, control, observations):
        v, w = control
        x, y, th = self.pose
        x, y = x + v * np.cos(th), y + v * np.sin(th)
        self.pose = np.array([x, y, th + w])
        known = {i for i, _, _ in self.map}
        for r, b, i in zip(observations.ranges, observations.bearings, observations.ids):
            if int(i) not in known:
                self.map.append((int(i), x + r * np.cos(th + w + b), y + r * np.sin(th + w + b)))
        if self.quadratic:  # the slow part: all pairs, in Python, every step, many times over
            for _ in range(20):
                for a in self.map:
                    for b in self.map:
                        if a[0] != b[0] and (a[1] - b[1]) ** 2 + (a[2] - b[2]) ** 2 < 0.0:
                            pass

    def estimate(self):
        ids = np.array([i for i, _, _ in self.map], dtype=np.int64)
        xy = np.array([(px, py) for _, px, py in self.map], dtype=float).reshape(-1, 2)
        return Estimate(self.pose.copy(), ids, xy)


def make_slow():
    return ListMapper()


def make_fast():
    return ListMapper(quadratic=False)
