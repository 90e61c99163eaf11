"""roboticstoolbox-python's EKF in SLAM mode (``roboticstoolbox.EKF``) as a faultlab SLAM under test.

The Robotics Toolbox for Python (P. Corke) ships an EKF that runs EKF-SLAM when it is given a vehicle
with an odometry covariance ``V_est`` and a range-bearing sensor with a covariance ``W_est`` but no
map.  It is written around its own simulator: every ``EKF.step()`` asks the vehicle to move
(``robot.step()`` returns the odometry) and the sensor for one reading (``sensor.reading()`` returns
one ``(z, id)`` or ``(None, None)``).  This adapter feeds faultlab's controls and observations through
those two calls and leaves the filter itself -- prediction, Jacobians, state augmentation, Joseph-form
update, angle wrapping -- untouched.

Conventions mapped (faultlab's on the left, the toolbox's on the right)
---------------------------------------------------------------------
motion model
    control ``(v, omega)``: drive ``v`` along the heading, then turn ``omega`` (dt = 1) ==
    the toolbox's odometry ``(delta_d, delta_theta)`` in ``VehicleBase.f``:
    ``x + (delta_d cos theta, delta_d sin theta, delta_theta)``.  Passed through unchanged.
motion noise
    ``std_v`` (m) and ``std_omega`` (rad) per step == ``V_est = diag(std_v^2, std_omega^2)`` on
    ``(delta_d, delta_theta)``, mapped by the toolbox's ``Fv``.
sensor model
    range (m) and bearing relative to the heading (rad) == ``RangeBearingSensor.h``'s ``(r, beta)``;
    ``W_est = diag(std_range^2, std_bearing^2)``.  Bearings are passed unwrapped: the toolbox wraps
    the innovation (``wrap_mpi_pi``) and uses the bearing only through cos/sin otherwise.
observations per step
    faultlab gives ``k >= 0`` observations per step, the toolbox's filter takes at most one per
    ``EKF.step()``.  A step with ``k`` observations is ``max(k, 1)`` toolbox steps: the first with
    the step's odometry and its first observation, the others with odometry ``(0, 0)`` and no motion
    noise (the vehicle's ``Fv`` is zero for them: the motion noise of a step is added once).  The
    observations are processed in the order given, each linearised at the state the previous one
    left (the textbook's sequential update).
landmark ids
    faultlab's ids (any integers) are the toolbox's ``lm_id`` keys (a dict), unchanged.
start pose
    known exactly: ``x0 = start pose``, ``P0 = 0``.
heading
    the toolbox wraps the heading into [-pi, pi) after each update, not after a prediction; faultlab
    compares headings modulo 2 pi.
the sensor's map
    ``EKF.step`` evaluates ``sensor.h(x, lm_id)`` against the simulator's true map before it
    branches, then overwrites that prediction (seen landmark) or ignores it (new landmark; it is only
    kept in the history, which this adapter switches off).  This sensor has no true map, so for an
    integer id ``h`` returns NaN, a value the filter never uses.

Cost: the toolbox's filter is dense -- adding a landmark multiplies ``(n, n)`` matrices
(``Yz @ blkdiag(P, W) @ Yz.T``) and each update forms ``(I - K H) P (I - K H)^T`` -- so one
observation costs O(n^3) in the state size ``n = 3 + 2L``.

Run it in-process (``[slam] name = "faultlab_rtb_ekf_slam:RtbEkfSlam"``) or as a process
(``python -m faultlab_rtb_ekf_slam``, which ``faultlab adapter check`` can judge).
"""

from __future__ import annotations

import math

import numpy as np

from faultlab.slam.protocol import Estimate, Observations, SlamAdapter

__all__ = ["RtbEkfSlam"]


def _toolbox():
    """The toolbox's classes, imported on first use (the import takes seconds)."""
    import roboticstoolbox as rtb
    from roboticstoolbox.mobile import RangeBearingSensor, Unicycle

    class OdometryVehicle(Unicycle):
        """A vehicle whose ``step()`` returns faultlab's control as odometry (no simulation)."""

        def __init__(self, **kwargs):
            super().__init__(**kwargs)
            self.odometry = np.zeros(2)
            self.moving = True

        def step(self, u=None, animate=True, pause=True):
            return self.odometry.copy()

        def Fv(self, x, odo):
            return super().Fv(x, odo) if self.moving else np.zeros((3, 2))

    class ReplaySensor(RangeBearingSensor):
        """A range-bearing sensor whose ``reading()`` returns the next of faultlab's observations."""

        def __init__(self, robot, **kwargs):
            super().__init__(robot, None, **kwargs)
            self.next = (None, None)

        def reading(self):
            z, self.next = self.next, (None, None)
            return z

        def h(self, x, landmark=None):
            if isinstance(landmark, (int, np.integer)):
                return np.full(2, np.nan)  # the simulator's true map: absent here, unused by the SLAM filter
            return super().h(x, landmark)

    return rtb.EKF, OdometryVehicle, ReplaySensor


class RtbEkfSlam(SlamAdapter):
    """roboticstoolbox-python's ``EKF`` in SLAM mode, driven by faultlab's controls and observations.

    Parameters
    ----------
    std_v, std_omega_deg, std_range, std_bearing_deg : float
        The noise the filter assumes (faultlab's :class:`~faultlab.slam.noise.NoiseConfig` names and
        units; defaults: the paper's setup).
    """

    name = "rtb_ekf"

    def __init__(self, *, std_v: float = 0.1, std_omega_deg: float = 20.0, std_range: float = 0.3,
                 std_bearing_deg: float = 10.0):
        self.V = np.diag([std_v ** 2, math.radians(std_omega_deg) ** 2])
        self.W = np.diag([std_range ** 2, math.radians(std_bearing_deg) ** 2])
        self._ekf = None
        self._classes = _toolbox()  # at construction: the toolbox's modules as the SLAM is built

    def reset(self, pose, *, rng):
        EKF, OdometryVehicle, ReplaySensor = self._classes
        pose = np.asarray(pose, dtype=float)
        self._vehicle = OdometryVehicle(x0=pose.copy())
        self._sensor = ReplaySensor(self._vehicle)
        self._ekf = EKF(robot=(self._vehicle, self.V), sensor=(self._sensor, self.W), P0=np.zeros((3, 3)),
                        x0=pose.copy(), animate=False, history=False)
        self._trajectory = []

    def update(self, control, observations: Observations):
        ekf, vehicle, sensor = self._ekf, self._vehicle, self._sensor
        vehicle.odometry = np.asarray(control, dtype=float)
        vehicle.moving = True
        z = np.column_stack([observations.ranges, observations.bearings])
        for i in range(max(len(observations), 1)):
            if i < len(observations):
                sensor.next = (z[i].copy(), int(observations.ids[i]))
            if i == 1:
                vehicle.odometry = np.zeros(2)
                vehicle.moving = False
            ekf.step()
        self._trajectory.append(np.asarray(ekf.x_est[:3], dtype=float).copy())

    def estimate(self) -> Estimate:
        ekf = self._ekf
        ids = np.fromiter(ekf.landmarks.keys(), dtype=np.int64, count=len(ekf.landmarks))
        lm = np.array([ekf.landmark_x(int(i)) for i in ids], dtype=float).reshape(-1, 2)
        traj = np.array(self._trajectory, dtype=float).reshape(-1, 3)
        return Estimate(np.asarray(ekf.x_est[:3], dtype=float).copy(), ids, lm, trajectory=traj)

    @property
    def covariance(self) -> np.ndarray:
        """The filter's joint covariance (pose, then landmarks in :meth:`estimate`'s order)."""
        return np.asarray(self._ekf.P_est, dtype=float).copy()
