"""Smoothing SLAM with GTSAM's iSAM2 over range-bearing factors (an optional SLAM under test).

A factor-graph SLAM as a :class:`~faultlab.slam.SlamAdapter`: where FastSLAM and EKF-SLAM filter
(keep only the current pose), this one keeps every pose of the trajectory and re-solves the whole
graph incrementally with iSAM2 (Kaess et al., *iSAM2: Incremental smoothing and mapping using the
Bayes tree*, IJRR 2012), the back end most modern SLAM systems use.  It needs the ``gtsam``
package (``pip install "faultlab[gtsam]"``), which is imported only when the SLAM is built:
building it without gtsam raises :class:`~faultlab.errors.ConfigError` naming the extra.

The graph, for the conventions of :class:`faultlab.scenario.model.Scenario`:

* a ``Pose2`` node ``x0`` with a tight prior (std :data:`PRIOR_STD`) on the known start pose;
* per step with a control ``(v, omega)`` a new node ``x_t`` and a ``BetweenFactorPose2`` from
  ``x_{t-1}`` with the measured relative pose ``Pose2(v, 0, omega)`` (drive ``v`` along the heading,
  then turn ``omega``: the motion model of FastSLAM).  Its noise is the control noise
  ``M = diag(std_v^2, std_omega^2)`` carried into the relative pose's local coordinates,
  ``J M J^T`` with ``J = [[cos omega, 0], [-sin omega, 0], [0, 1]]``, plus ``REGULARISER^2 I``:
  the control noise has rank 2 in the three pose coordinates and GTSAM needs a full-rank model;
* per observation a ``BearingRangeFactor2D`` from ``x_t`` to the ``Point2`` node ``l<id>``
  (noise ``diag(std_range^2, std_bearing^2)``).  The bearing enters as ``Rot2.fromAngle(b)``, a
  point on the circle, so bearings offset by any multiple of 2 pi give the same factor.  A
  landmark's first observation also initialises its node from the current pose guess (inverse
  measurement model).  Observations with a range below :data:`MIN_RANGE` (1 mm) are ignored: the
  bearing of a landmark at the sensor is undefined (its factor's Jacobian is singular);
* an *empty update* (control exactly (0, 0) and no observation, as during inactivity) adds
  nothing: no node, no factor.

New nodes are initialised from the last iSAM2 estimate composed with the odometry.  iSAM2 is
updated with the new factors every ``update_every`` steps (default 1: every step, and then its
solution agrees with a batch Levenberg-Marquardt optimisation of the whole graph to a fraction of
a mm).  Larger values batch several steps into one update: faster, but the nodes of a batch start
from dead-reckoned guesses and one iSAM2 step does not always reach the optimum (on 150-step
fixed-suite cases ``update_every = 7`` ran about 3x faster and its map error was up to 40 % larger).
:meth:`GtsamSlam.estimate` first flushes the factors not yet added.  The estimate is iSAM2's current solution: the last pose and every mapped
landmark; its trajectory is the *smoothed* one, the solution's pose node of every step (an empty
update adds no node: its row repeats the previous step's).  Everything is deterministic: ``reset`` accepts an ``rng`` for the protocol and draws
nothing from it.

iSAM2 relinearises only the variables whose update exceeds GTSAM's default threshold (0.1), and
only at every 10th update, so its solution is not fully converged and depends slightly on the frame
of the problem: the ``rigid_motion`` metamorphic relation (:mod:`faultlab.metamorphic`) finds that
rotating and shifting the world moves this SLAM's map by about 1 mm more than the motion itself
(0.0018 m median on a 100-step case), against 4e-7 m with relinearisation of every variable at every
update.  The defaults are kept: they are how iSAM2 is used.

The adapter has no replaceable units (no steps table), so no fault applies to it.  Factors are
built one per observation in a Python loop: GTSAM's Python API has no vectorised factor
constructor; the cost is dominated by iSAM2 itself.
"""

from __future__ import annotations

import importlib.util
import math
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from faultlab.config import Option
from faultlab.errors import ConfigError, SlamInputError, SlamOutputError
from faultlab.slam.noise import NoiseConfig
from faultlab.slam.protocol import Estimate, Observations, SlamAdapter, as_start_pose, check_generator

__all__ = ["GTSAM_EXTRA", "PRIOR_STD", "REGULARISER", "MIN_RANGE", "GtsamSlamConfig", "GtsamSlam", "gtsam_available",
           "gtsam_version"]

#: The optional extra (and module) the adapter needs.
GTSAM_EXTRA = "gtsam"
#: Std of the prior on the known start pose (m for x and y, rad for theta).
PRIOR_STD = 1e-4
#: Std added to every coordinate of the odometry noise so that its covariance has full rank (m, rad).
REGULARISER = 1e-3
#: Observations with a shorter range (m) are ignored: a landmark at the sensor has no bearing, and
#: the bearing factor's Jacobian is singular there (the generator clamps noisy ranges at 0).
MIN_RANGE = 1e-3
#: Largest landmark id a GTSAM symbol can hold (56 bits for the index).
_MAX_ID = (1 << 56) - 1


def gtsam_available() -> bool:
    """True if the ``gtsam`` package can be imported (checked without importing it)."""
    return importlib.util.find_spec(GTSAM_EXTRA) is not None


def gtsam_version() -> str | None:
    """The installed gtsam distribution's version, or None if it is not installed."""
    from importlib import metadata

    try:
        return metadata.version(GTSAM_EXTRA)
    except metadata.PackageNotFoundError:
        return None


def _import_gtsam() -> Any:
    """The gtsam module (an optional, heavy dependency: imported only when the SLAM is built)."""
    try:
        import gtsam
    except ImportError as exc:
        raise ConfigError(f"SLAM 'gtsam' needs the gtsam package, which is not installed "
                          f"({type(exc).__name__}: {exc}); install it with pip install 'faultlab[gtsam]'") from exc
    return gtsam


@dataclass(frozen=True)
class GtsamSlamConfig(NoiseConfig):
    """Settings of the iSAM2 SLAM: the noise of :class:`~faultlab.slam.noise.NoiseConfig` and the batching.

    Attributes
    ----------
    update_every : int
        Steps whose factors are added to iSAM2 in one update (>= 1).
    """

    update_every: int = 1

    #: field -> its setting in an experiment's ``[slam]`` table (angles in degrees there).
    OPTIONS: ClassVar[dict[str, Option]] = {
        **NoiseConfig.OPTIONS,
        "update_every": Option("update_every", integer=True, bounds={"minimum": 1}),
    }

    def odometry_covariance(self, omega: float) -> np.ndarray:
        """Covariance (3, 3) of the relative pose ``Pose2(v, 0, omega)`` in its local coordinates.

        ``J diag(std_v^2, std_omega^2) J^T + REGULARISER^2 I`` with the Jacobian ``J`` (3, 2) of the
        local coordinates with respect to the control noise (module docstring).
        """
        c, s = math.cos(omega), math.sin(omega)
        J = np.array([[c, 0.0], [-s, 0.0], [0.0, 1.0]])
        M = np.diag([self.std_v ** 2, self.std_omega ** 2])
        return J @ M @ J.T + REGULARISER ** 2 * np.eye(3)


class GtsamSlam(SlamAdapter):
    """iSAM2 SLAM over range-bearing factors (known correspondences) as a :class:`SlamAdapter`.

    Parameters
    ----------
    config : GtsamSlamConfig

    Raises
    ------
    ConfigError
        If gtsam is not installed (``pip install "faultlab[gtsam]"``).
    """

    name = "gtsam"

    def __init__(self, config: GtsamSlamConfig = GtsamSlamConfig()):
        if not isinstance(config, GtsamSlamConfig):
            raise ConfigError(f"GtsamSlam: config must be a GtsamSlamConfig, got {type(config).__name__}")
        self._gtsam = _import_gtsam()
        self._config = config
        g = self._gtsam
        self._meas_noise = g.noiseModel.Diagonal.Sigmas(np.array([config.std_bearing, config.std_range]))
        self._prior_noise = g.noiseModel.Diagonal.Sigmas(np.full(3, PRIOR_STD))
        self._isam = None

    @property
    def config(self) -> GtsamSlamConfig:
        return self._config

    def __repr__(self) -> str:
        return f"GtsamSlam({self._config!r})"

    # -- SlamAdapter -----------------------------------------------------------------------------

    def reset(self, pose: np.ndarray, *, rng: np.random.Generator) -> None:
        p = as_start_pose(pose, where=self.name)
        check_generator(rng, where=self.name)
        g = self._gtsam
        params = g.ISAM2Params()
        self._isam = g.ISAM2(params)
        self._graph = g.NonlinearFactorGraph()
        self._values = g.Values()
        self._t = 0  # index of the newest pose node
        self._step = 0  # steps seen (for messages)
        self._pending = 0  # steps whose factors are not in iSAM2 yet
        start = g.Pose2(float(p[0]), float(p[1]), float(p[2]))
        self._graph.add(g.PriorFactorPose2(g.symbol("x", 0), start, self._prior_noise))
        self._values.insert(g.symbol("x", 0), start)
        self._pose = start  # guess of the newest pose: the last iSAM2 estimate composed with the odometry
        self._known = np.empty(0, dtype=np.int64)  # sorted ids of the landmarks with a node
        self._nodes: list[int] = []  # the pose node of each step (an empty update adds none)

    def update(self, control: np.ndarray, observations: Observations) -> None:
        if self._isam is None:
            raise SlamInputError(f"{self.name}: update() called before reset()")
        g = self._gtsam
        k = len(observations)
        v, omega = (float(x) for x in control)
        self._step += 1
        if k == 0 and v == 0.0 and omega == 0.0:
            self._nodes.append(self._t)
            return  # an empty update adds nothing
        ids = observations.ids
        if k and (ids.min() < 0 or ids.max() > _MAX_ID):
            raise SlamInputError(f"{self.name}: landmark ids must be in [0, 2^56), got {ids.min()}..{ids.max()}")
        prev, self._t = g.symbol("x", self._t), self._t + 1
        self._nodes.append(self._t)
        key = g.symbol("x", self._t)
        odometry = g.Pose2(v, 0.0, omega)
        noise = g.noiseModel.Gaussian.Covariance(self._config.odometry_covariance(omega))
        self._graph.add(g.BetweenFactorPose2(prev, key, odometry, noise))
        self._pose = self._pose.compose(odometry)
        self._values.insert(key, self._pose)
        if k:
            r, b = observations.ranges, observations.bearings
            usable = r >= MIN_RANGE
            if not usable.all():  # a landmark at the sensor has no bearing
                r, b, ids = r[usable], b[usable], ids[usable]
                k = int(r.size)
            new = ~np.isin(ids, self._known, assume_unique=True)
            # first sightings: the inverse measurement model from the pose guess, all at once
            x, y, th = self._pose.x(), self._pose.y(), self._pose.theta()
            guess = np.column_stack([x + r * np.cos(th + b), y + r * np.sin(th + b)])
            for i in range(k):  # one factor object per observation (no vectorised constructor)
                lkey = g.symbol("l", int(ids[i]))
                self._graph.add(g.BearingRangeFactor2D(key, lkey, g.Rot2.fromAngle(float(b[i])), float(r[i]),
                                                       self._meas_noise))
                if new[i]:
                    self._values.insert(lkey, g.Point2(guess[i, 0], guess[i, 1]))
            if new.any():
                self._known = np.union1d(self._known, ids[new])
        self._pending += 1
        if self._pending >= self._config.update_every:
            self._flush()

    def estimate(self) -> Estimate:
        if self._isam is None:
            raise SlamInputError(f"{self.name}: reset() must be called first")
        self._flush()
        g = self._gtsam
        result = self._isam.calculateEstimate()
        pose = result.atPose2(g.symbol("x", self._t))
        # every Point2 of the solution, in key order = landmark id order (keys 'l' + id)
        xy = np.asarray(g.utilities.extractPoint2(result), dtype=float).reshape(-1, 2)
        # every Pose2, in key order = node order x0, x1, ...: the smoothed trajectory, one pose per step
        nodes = np.asarray(g.utilities.extractPose2(result), dtype=float).reshape(-1, 3)
        trajectory = nodes[np.asarray(self._nodes, dtype=np.intp)]
        return Estimate(np.array([pose.x(), pose.y(), pose.theta()]), self._known.copy(), xy, trajectory=trajectory)

    # -- internals -------------------------------------------------------------------------------

    def _flush(self) -> None:
        """Add the pending factors and nodes to iSAM2 and re-anchor the pose guess on its estimate."""
        if self._graph.size() == 0:
            return
        try:
            self._isam.update(self._graph, self._values)
            self._pose = self._isam.calculateEstimatePose2(self._gtsam.symbol("x", self._t))
        except RuntimeError as exc:  # gtsam's C++ exceptions (e.g. an indeterminant system)
            raise SlamOutputError(f"{self.name}: iSAM2 update failed at step {self._step}: {exc}") from exc
        self._graph = self._gtsam.NonlinearFactorGraph()
        self._values.clear()
        self._pending = 0
