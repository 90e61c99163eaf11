"""EKF-SLAM with known correspondences, structured for fault injection like the reference FastSLAM 1.0.

The algorithm is EKF-SLAM (Thrun, Burgard & Fox, *Probabilistic Robotics*, Tables 10.1/10.2) for
range-bearing landmarks: one Gaussian over the state ``(x, y, theta, m_1, ..., m_L)`` of dimension
``D = 3 + 2L``.  The motion and measurement models, the noise settings and the conventions are those
of :class:`faultlab.slam.FastSlam`: drive ``v`` along the heading, then turn ``omega``; control
noise ``M = diag(std_v^2, std_omega^2)`` mapped into pose space by the control Jacobian;
measurement noise ``Q = diag(std_range^2, std_bearing^2)``; an *empty update* (control exactly
(0, 0) and no observation) adds no control noise, so it leaves the belief unchanged.

One update (:meth:`EkfSlam.update`) runs::

    G, V   = motion_jacobians(pose, u)                       # at the old pose
    pose   = motion_model(pose, u, wrap=wrap_heading)
    Sxx, Sxm = predict_covariance(Sxx, Sxm, G, V, M)         # M = 0 for an empty update
    # the step's observations of landmarks already in the state, all at once:
    z_hat, Hm = predict_measurement(pose, m)                 # (1, k, 2), (1, k, 2, 2)
    Hx     = pose_jacobian(Hm)
    nu     = innovation(z, z_hat, wrap=wrap_bearing)
    PHt    = cross_covariance(Sigma, idx, Hx, Hm)            # Sigma H^T, O(D k)
    S      = joint_innovation_covariance(PHt, idx, Hx, Hm, Q)
    mu, Sigma = kalman_update(mu, Sigma, PHt, S, nu)         # O(D^2 k)
    theta  = wrap_heading(theta)
    # then the step's first sightings, from the corrected pose:
    m0, P0 = init_landmarks(pose, z_new, Q, wrap=wrap_bearing)
    mu, Sigma = augment_state(mu, Sigma, m0, P0)

Variant: the textbook processes a step's observations one at a time, each linearised at the state
updated by the previous ones.  Here the re-observed landmarks of a step are processed *jointly*
(one stacked measurement, linearised at the predicted state; identical for a linear model) and
the step's new landmarks are then added by the inverse measurement model with its full Jacobian
(state augmentation: exact cross covariances with the pose and map) instead of Table 10.1's
initialisation of the mean alone with an infinite prior.  The joint update costs one rank-2k
covariance update per step instead of k rank-2 updates.

The units are the fields of :class:`EkfSlamSteps`; the ones shared with FastSLAM 1.0 have its
signatures, called with ``N = 1`` (see :mod:`faultlab.slam.units`), the others are documented in
:mod:`faultlab.slam.ekfunits`.  EKF-SLAM is deterministic: ``reset`` accepts an ``rng`` for the
protocol and draws nothing from it.  Memory is O(L^2) (one (D, D) covariance) and a step with
``k`` observations costs O(L^2 k): the largest Table I maps (6000 landmarks) are out of reach.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np
from threadpoolctl import ThreadpoolController

from faultlab.errors import SlamInputError, SlamOutputError
from faultlab.slam import units as _units
from faultlab.slam import ekfunits as _ekfunits
from faultlab.slam.bookkeeping import LandmarkIndex, TrajectoryLog, UnitSlam, UnitTable, step_kind
from faultlab.slam.noise import NoiseConfig
from faultlab.slam.protocol import Estimate, Observations

__all__ = ["EkfSlamConfig", "EkfSlamSteps", "REFERENCE_STEPS", "EkfSlam"]

_blas: ThreadpoolController | None = None


def _one_blas_thread():
    """Context manager: BLAS limited to one thread (threadpoolctl; restored on exit).

    The EKF's BLAS calls are of medium size (D up to ~1000, 2k up to ~100): a second thread
    gains little on an idle machine, and on a busy one (other jobs, the runner's threading
    backend) the BLAS threads wait for each other and one update was measured 10-40x slower.
    """
    global _blas
    if _blas is None:  # created at first use, when scipy's BLAS is loaded too
        _blas = ThreadpoolController()
    return _blas.limit(limits=1, user_api="blas")


@dataclass(frozen=True)
class EkfSlamConfig(NoiseConfig):
    """Noise settings of EKF-SLAM: exactly :class:`~faultlab.slam.noise.NoiseConfig` (Sec. VII-A defaults)."""


@dataclass(frozen=True)
class EkfSlamSteps(UnitTable):
    """The replaceable units of EKF-SLAM (see the module docstring for the call order).

    Replace one unit with ``dataclasses.replace(steps, unit=new_function)``.
    """

    motion_model: Callable = _units.motion_model
    wrap_heading: Callable = _units.wrap_heading
    wrap_bearing: Callable = _units.wrap_bearing
    motion_jacobians: Callable = _ekfunits.motion_jacobians
    predict_covariance: Callable = _ekfunits.predict_covariance
    predict_measurement: Callable = _units.predict_measurement
    pose_jacobian: Callable = _ekfunits.pose_jacobian
    innovation: Callable = _units.innovation
    cross_covariance: Callable = _ekfunits.cross_covariance
    joint_innovation_covariance: Callable = _ekfunits.joint_innovation_covariance
    kalman_update: Callable = _ekfunits.kalman_update
    init_landmarks: Callable = _units.init_landmarks
    augment_state: Callable = _ekfunits.augment_state


#: The reference EKF-SLAM units.
REFERENCE_STEPS = EkfSlamSteps()


class EkfSlam(UnitSlam):
    """EKF-SLAM (known correspondences) as a :class:`SlamAdapter`.

    Parameters
    ----------
    config : EkfSlamConfig
    steps : EkfSlamSteps
        The units; :data:`REFERENCE_STEPS` or a copy with one unit replaced (a fault).
    """

    name = "ekf"
    config_type = EkfSlamConfig
    steps_type = EkfSlamSteps
    reference_steps = REFERENCE_STEPS

    def __init__(self, config: EkfSlamConfig | None = None, *, steps: EkfSlamSteps | None = None):
        super().__init__(config, steps=steps)
        self._Q = self._config.Q
        self._M = self._config.M
        self._no_noise = np.zeros((2, 2))
        self._mu: np.ndarray | None = None

    # -- SlamAdapter -----------------------------------------------------------------------------

    def reset(self, pose: np.ndarray, *, rng: np.random.Generator) -> None:
        p = self._start_pose(pose, rng)
        self._mu = p
        self._Sigma = np.zeros((3, 3))  # the start pose is known
        self._index = LandmarkIndex()
        self._trajectory = TrajectoryLog()
        self._t = 0

    def update(self, control: np.ndarray, observations: Observations) -> None:
        if self._mu is None:
            raise SlamInputError(f"{self.name}: update() called before reset()")
        with _one_blas_thread():
            self._update(control, observations)

    def _update(self, control: np.ndarray, observations: Observations) -> None:
        steps, Q = self._run_steps, self._Q
        u, k, empty = step_kind(control, observations)
        mu, Sigma = self._mu, self._Sigma
        # prediction (Table 10.1, lines 2-5); an empty update adds no control noise
        pose, u1 = mu[None, :3], u[None, :]
        G, V = steps.motion_jacobians(pose, u1)
        mu = mu.copy()
        mu[:3] = np.asarray(steps.motion_model(pose, u1, wrap=steps.wrap_heading), dtype=float)[0]
        Sxx, Sxm = steps.predict_covariance(Sigma[:3, :3], Sigma[:3, 3:], np.asarray(G)[0], np.asarray(V)[0],
                                            self._no_noise if empty else self._M)
        Sxm = np.array(Sxm, dtype=float)  # own copy: Sigma is written below
        Sigma[:3, :3] = Sxx
        Sigma[:3, 3:] = Sxm
        Sigma[3:, :3] = Sxm.T
        if k:
            cols, seen = self._index.lookup(observations.ids)
            z = np.column_stack([observations.ranges, observations.bearings])
            if seen.any():
                mu, Sigma = self._correct(mu, Sigma, cols[seen], z[seen])
            if not seen.all():
                new = ~seen
                m0, P0 = steps.init_landmarks(mu[None, :3], z[new], Q, wrap=steps.wrap_bearing)
                mu, Sigma = steps.augment_state(mu, Sigma, np.asarray(m0, dtype=float)[0],
                                                np.asarray(P0, dtype=float)[0])
                self._index.add(observations.ids[new])
        mu = np.asarray(mu, dtype=float)
        if not np.all(np.isfinite(mu[:3])):
            raise SlamOutputError(f"{self.name}: the pose estimate is not finite at step {self._t}")
        self._mu, self._Sigma = mu, np.asarray(Sigma, dtype=float)
        self._trajectory.append(mu[:3])
        self._t += 1

    def estimate(self) -> Estimate:
        """The state mean: pose, landmarks and, as the trajectory, the pose mean after every step; its
        covariance (pose, then landmarks in the order of the ids)."""
        mu = self._require_state()
        return Estimate(mu[:3].copy(), self._index.ids.copy(), mu[3:].reshape(-1, 2).copy(),
                        trajectory=self._trajectory.poses(), covariance=self._Sigma.copy())

    # -- diagnostics -----------------------------------------------------------------------------

    @property
    def mean(self) -> np.ndarray:
        """A copy of the state mean (D,): pose, then landmarks in order of first observation."""
        return self._require_state().copy()

    @property
    def covariance(self) -> np.ndarray:
        """A copy of the state covariance (D, D)."""
        self._require_state()
        return self._Sigma.copy()

    @property
    def landmark_ids(self) -> np.ndarray:
        """Ids of the state's landmarks in state order, (L,)."""
        self._require_state()
        return self._index.ids.copy()

    # -- internals -------------------------------------------------------------------------------

    def _require_state(self) -> np.ndarray:
        if self._mu is None:
            raise SlamInputError(f"{self.name}: reset() must be called first")
        return self._mu

    def _correct(self, mu: np.ndarray, Sigma: np.ndarray, cols: np.ndarray,
                 z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Joint correction with the re-observed landmarks in state columns ``cols`` (k,), z (k, 2)."""
        steps = self._run_steps
        idx = 3 + 2 * cols
        lm = mu[idx[:, None] + np.arange(2)]  # (k, 2)
        zhat, Hm = steps.predict_measurement(mu[None, :3], lm[None])
        Hm = np.asarray(Hm, dtype=float)[0]
        Hx = np.asarray(steps.pose_jacobian(Hm), dtype=float)
        nu = np.asarray(steps.innovation(z, zhat, wrap=steps.wrap_bearing), dtype=float)[0]
        PHt = steps.cross_covariance(Sigma, idx, Hx, Hm)
        S = steps.joint_innovation_covariance(PHt, idx, Hx, Hm, self._Q)
        mu, Sigma = steps.kalman_update(mu, Sigma, PHt, S, nu.reshape(-1))
        mu = np.array(mu, dtype=float)
        mu[2] = steps.wrap_heading(mu[2])
        return mu, Sigma
