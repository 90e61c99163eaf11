"""g2o's batch least squares over the whole pose-landmark graph: a smoothing reference for faultlab.

Every pose and every landmark is a vertex (``VertexSE2``, ``VertexPointXY``); every control an
``EdgeSE2`` between consecutive poses, every observation an ``EdgeSE2PointXY``.  The graph is built
while the SLAM is stepped and optimised once, in :meth:`G2oSmoother.estimate`, from the dead-reckoning
initial guess (landmarks at their first sighting), with the start pose fixed: Levenberg-Marquardt until
it converges, then Gauss-Newton from there (on a flat, badly conditioned cost, such as a long idle
phase with few sightings, Levenberg-Marquardt alone stops centimetres short of the optimum after a
thousand iterations, and the map then depends on the frame the world is written in).

Conventions mapped (faultlab's on the left, g2o's on the right)
-------------------------------------------------------------
motion
    control ``(v, omega)``: drive ``v`` along the heading, then turn ``omega`` == the relative pose
    ``SE2(v, 0, omega)`` between consecutive poses, exactly.  Its information is the inverse of
    ``diag(std_v^2, r, std_omega^2)``: faultlab's control noise has no sideways component, so the
    sideways variance is the small regulariser ``r`` (:data:`SIDEWAYS_VARIANCE`, m^2) that keeps the
    information finite.
observation
    range ``r`` and bearing ``b`` relative to the heading == the landmark's position in the robot
    frame ``(r cos b, r sin b)`` (``EdgeSE2PointXY``), with the covariance ``J Q J^T`` of that point
    (``J`` the Jacobian of the polar-to-Cartesian map, ``Q = diag(std_range^2, std_bearing^2)``), the
    usual first-order mapping.
ids
    landmark ``i`` of faultlab is vertex ``T + 1 + k`` where ``k`` is its order of first sighting.
trajectory
    the smoothed pose after every step.

Building the graph is one Python call per edge (g2o's binding has no batch insertion).
"""

from __future__ import annotations

import math

import numpy as np

from faultlab.slam.protocol import Estimate, Observations, SlamAdapter

__all__ = ["G2oSmoother", "SIDEWAYS_VARIANCE", "BLOCK", "RTOL", "GAUSS_NEWTON_ITERATIONS"]

#: Variance of the sideways motion each control edge allows, m^2 (faultlab's motion has none).
SIDEWAYS_VARIANCE = 1e-6
#: Iterations per convergence test.
BLOCK = 10
#: Relative chi2 decrease over a block below which the optimisation has converged.
RTOL = 1e-12


#: Gauss-Newton iterations at most after Levenberg-Marquardt (a converged finish takes a few).
GAUSS_NEWTON_ITERATIONS = 100


def _iterate(opt, iterations: int) -> int:
    """Optimise in blocks of :data:`BLOCK` until a block lowers the chi2 by less than :data:`RTOL` of it."""
    done, chi2 = 0, float("inf")
    while done < iterations:
        ran = opt.optimize(min(BLOCK, iterations - done))
        done += min(BLOCK, iterations - done)
        now = float(opt.chi2())
        if ran <= 0 or chi2 - now <= RTOL * max(now, 1e-300):
            break
        chi2 = now
    return done


class G2oSmoother(SlamAdapter):
    """Batch least squares with g2o (Levenberg-Marquardt, then Gauss-Newton) over every pose and landmark.

    Parameters
    ----------
    std_v, std_omega_deg, std_range, std_bearing_deg : float
        The noise assumed (faultlab's names and units; defaults: the paper's setup).
    iterations : int
        Levenberg-Marquardt iterations at most; the optimisation stops earlier once a block of
        :data:`BLOCK` iterations lowers the chi2 by less than :data:`RTOL` of its value (converged).
        Up to :data:`GAUSS_NEWTON_ITERATIONS` Gauss-Newton iterations follow, from where it stopped.
    initial : Estimate, optional
        The initial guess (its ``trajectory`` and landmarks, e.g. a filter's estimate of the same run)
        instead of dead reckoning with landmarks at their first sighting; landmarks it lacks start at
        their first sighting from its trajectory.

    Attributes
    ----------
    chi2 : float
        The weighted squared error of the graph at the solution (after :meth:`estimate`).
    """

    name = "g2o"

    def __init__(self, *, std_v: float = 0.1, std_omega_deg: float = 20.0, std_range: float = 0.3,
                 std_bearing_deg: float = 10.0, iterations: int = 1000, initial: Estimate | None = None):
        self.std_v, self.std_omega = std_v, math.radians(std_omega_deg)
        self.std_range, self.std_bearing = std_range, math.radians(std_bearing_deg)
        self.iterations = int(iterations)
        self.initial = initial
        self.chi2 = float("nan")

    def reset(self, pose, *, rng):
        self._start = np.asarray(pose, dtype=float).copy()
        self._controls = []
        self._obs = []  # (step, ranges, bearings, ids)

    def update(self, control, observations: Observations):
        self._controls.append(np.asarray(control, dtype=float).copy())
        if len(observations):
            self._obs.append((len(self._controls), observations.ranges.copy(), observations.bearings.copy(),
                              observations.ids.copy()))

    def _dead_reckoning(self) -> np.ndarray:
        u = np.array(self._controls, dtype=float).reshape(-1, 2)
        theta = self._start[2] + np.r_[0.0, np.cumsum(u[:, 1])]
        xy = self._start[:2] + np.r_[np.zeros((1, 2)), np.cumsum(u[:, :1] * np.column_stack(
            [np.cos(theta[:-1]), np.sin(theta[:-1])]), axis=0)]
        return np.column_stack([xy, theta])

    def estimate(self) -> Estimate:
        import g2opy as g2o

        poses0 = self._dead_reckoning()
        T = len(self._controls)
        given = {}
        if self.initial is not None and self.initial.trajectory is not None and len(self.initial.trajectory) == T:
            poses0 = np.vstack([poses0[:1], np.asarray(self.initial.trajectory, dtype=float)])
            given = {int(i): np.asarray(xy, dtype=float) for i, xy in zip(self.initial.landmark_ids,
                                                                         self.initial.landmarks)}
        if not self._obs and T == 0:
            return Estimate(self._start.copy(), np.empty(0, np.int64), np.empty((0, 2)), np.empty((0, 3)))
        opt = g2o.SparseOptimizer()
        opt.set_algorithm(g2o.OptimizationAlgorithmLevenberg(g2o.BlockSolverX(g2o.LinearSolverEigenX())))
        poses = []
        for t, (x, y, th) in enumerate(poses0):
            v = g2o.VertexSE2()
            v.set_id(t)
            v.set_estimate(g2o.SE2(x, y, th))
            v.set_fixed(t == 0)
            opt.add_vertex(v)
            poses.append(v)
        info_u = np.linalg.inv(np.diag([self.std_v ** 2, SIDEWAYS_VARIANCE, self.std_omega ** 2]))
        for t, (v_, w_) in enumerate(self._controls):
            e = g2o.EdgeSE2()
            e.set_vertex(0, poses[t])
            e.set_vertex(1, poses[t + 1])
            e.set_measurement(g2o.SE2(v_, 0.0, w_))
            e.set_information(info_u)
            opt.add_edge(e)
        Q = np.diag([self.std_range ** 2, self.std_bearing ** 2])
        landmarks: dict[int, object] = {}
        for t, r, b, ids in self._obs:
            local = np.column_stack([r * np.cos(b), r * np.sin(b)])
            J = np.stack([np.column_stack([np.cos(b), -r * np.sin(b)]), np.column_stack([np.sin(b), r * np.cos(b)])],
                         axis=1)  # (k, 2, 2)
            cov = J @ Q @ J.transpose(0, 2, 1) + 1e-12 * np.eye(2)
            info = np.linalg.inv(cov)
            x, y, th = poses0[t]
            world = np.column_stack([x + local[:, 0] * math.cos(th) - local[:, 1] * math.sin(th),
                                     y + local[:, 0] * math.sin(th) + local[:, 1] * math.cos(th)])
            for k, i in enumerate(ids.tolist()):
                vertex = landmarks.get(i)
                if vertex is None:
                    vertex = g2o.VertexPointXY()
                    vertex.set_id(T + 1 + len(landmarks))
                    vertex.set_estimate(given.get(i, world[k]))
                    opt.add_vertex(vertex)
                    landmarks[i] = vertex
                e = g2o.EdgeSE2PointXY()
                e.set_vertex(0, poses[t])
                e.set_vertex(1, vertex)
                e.set_measurement(local[k])
                e.set_information(info[k])
                opt.add_edge(e)
        opt.initialize_optimization()
        done = _iterate(opt, self.iterations)
        # Levenberg-Marquardt crawls along a flat valley of the cost (a long idle phase, few sightings):
        # a thousand iterations can leave the poses centimetres short of the optimum.  From where it
        # stops, Gauss-Newton converges in a few steps; kept only if it does not raise the chi2.
        lm_chi2 = float(opt.chi2())
        opt.push()
        gauss_newton = g2o.OptimizationAlgorithmGaussNewton(g2o.BlockSolverX(g2o.LinearSolverEigenX()))
        opt.set_algorithm(gauss_newton)
        done += _iterate(opt, GAUSS_NEWTON_ITERATIONS)
        if np.isfinite(opt.chi2()) and float(opt.chi2()) <= lm_chi2:
            opt.discard_top()
        else:
            opt.pop()
        self.chi2 = float(opt.chi2())
        self.iterations_run = done
        traj = np.array([p.estimate().to_vector() for p in poses], dtype=float)
        ids = np.fromiter(landmarks.keys(), dtype=np.int64, count=len(landmarks))
        lm = np.array([landmarks[int(i)].estimate() for i in ids], dtype=float).reshape(-1, 2)
        return Estimate(traj[-1].copy(), ids, lm, trajectory=traj[1:])
