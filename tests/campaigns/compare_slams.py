"""SLAMs for the tests of ``faultlab compare``, written as a user would: factories and a wrapper adapter.

* ``fastslam20``: faultlab's FastSLAM 1.0 with 20 particles (a cheap stochastic SLAM);
* ``miscalibrated``: the same SLAM behind a wrapper whose range sensor reads 3 % long (a calibration
  regression: the map error grows by about a tenth, measured in ``benchmarks/compare-calibration.md``);
* ``slightly_miscalibrated``: the range sensor 2 % long;
* ``odometry`` / ``odometry_crashing``: a deterministic odometry mapper, and the same one raising on
  any case with more than 3 landmarks (a crash the baseline does not have).
"""

from __future__ import annotations

import numpy as np

from faultlab.slam import Estimate, SlamAdapter
from faultlab.slam.protocol import Observations
from faultlab.slam.registry import build_slam

RANGE_FACTOR = 1.03


class RangeScaled(SlamAdapter):
    """Passes every observation on with its range multiplied by ``factor``."""

    name = "range_scaled"

    def __init__(self, inner: SlamAdapter, factor: float = RANGE_FACTOR):
        self.inner, self.factor = inner, factor

    def reset(self, pose, *, rng):
        self.inner.reset(pose, rng=rng)

    def update(self, control, observations):
        self.inner.update(control, Observations(observations.ranges * self.factor, observations.bearings,
                                                observations.ids))

    def estimate(self) -> Estimate:
        return self.inner.estimate()


class Odometry(SlamAdapter):
    """Integrates the controls and maps each landmark where it was first seen; ``crash_above`` landmarks raise."""

    name = "odometry_mapper"

    def __init__(self, crash_above: int | None = None):
        self.crash_above = crash_above

    def reset(self, pose, *, rng):
        self.pose = np.asarray(pose, dtype=float).copy()
        self.map: dict[int, np.ndarray] = {}

    def update(self, control, observations):
        v, w = control
        x, y, th = self.pose
        self.pose = np.array([x + v * np.cos(th), y + v * np.sin(th), th + w])
        for r, b, i in zip(observations.ranges, observations.bearings, observations.ids):
            if int(i) not in self.map:
                a = self.pose[2] + b
                self.map[int(i)] = self.pose[:2] + r * np.array([np.cos(a), np.sin(a)])
        if self.crash_above is not None and len(self.map) > self.crash_above:
            raise IndexError("landmark table full")

    def estimate(self) -> Estimate:
        ids = np.array(sorted(self.map), dtype=np.int64)
        lm = np.array([self.map[i] for i in ids]).reshape(-1, 2)
        return Estimate(self.pose.copy(), ids, lm)


def fastslam20() -> SlamAdapter:
    return build_slam("fastslam", {"particles": 20})


def miscalibrated() -> SlamAdapter:
    return RangeScaled(fastslam20())


def slightly_miscalibrated() -> SlamAdapter:
    """The range sensor reads 2 % long (a smaller degradation)."""
    return RangeScaled(fastslam20(), 1.02)


def odometry() -> SlamAdapter:
    return Odometry()


def odometry_crashing() -> SlamAdapter:
    return Odometry(crash_above=3)
