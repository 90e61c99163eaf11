"""A deliberately simple EKF-SLAM: the test oracle for faultlab.slam.EkfSlam.

Written from *Probabilistic Robotics* (Table 10.1, known correspondences) with dense matrices:
the projection matrix ``F_x``, the full (D, D) motion Jacobian, a full (2m, D) measurement
Jacobian assembled observation by observation, ``np.linalg.inv`` for the gain, the textbook
covariance update ``(I - K H) Sigma``, and landmark initialisation as an explicit state
augmentation ``Sigma' = T Sigma T^T + J Q J^T`` with the landmark Jacobian of the inverse
measurement model obtained by inverting the measurement Jacobian numerically.  It shares no code
with faultlab.slam.

It transcribes the same variant as EkfSlam: each step the re-observed landmarks are corrected
jointly (one stacked measurement), then the step's new landmarks are added from the corrected
pose, in observation order.  EKF-SLAM draws no random numbers, so nothing is shared but the input.
"""

from __future__ import annotations

import math

import numpy as np


def wrap(a: float) -> float:
    """Wrap an angle to [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


class OracleEkfSlam:
    """Dense-matrix EKF-SLAM with the settings of :class:`faultlab.slam.EkfSlamConfig`."""

    def __init__(self, std_v=0.1, std_omega=math.radians(20.0), std_range=0.3, std_bearing=math.radians(10.0)):
        self.M = np.diag([std_v ** 2, std_omega ** 2])
        self.Q = np.diag([std_range ** 2, std_bearing ** 2])

    def reset(self, pose):
        self.mu = np.array(pose, dtype=float)
        self.mu[2] = wrap(self.mu[2])
        self.Sigma = np.zeros((3, 3))
        self.index: dict[int, int] = {}  # landmark id -> state index of its x coordinate

    @property
    def D(self) -> int:
        return self.mu.shape[0]

    def step(self, control, ranges, bearings, ids):
        v, omega = float(control[0]), float(control[1])
        empty = len(ids) == 0 and v == 0.0 and omega == 0.0
        D = self.D
        x, y, th = self.mu[:3]
        # prediction (Table 10.1, lines 2-5) with the drive-then-turn motion model
        Fx = np.zeros((3, D))
        Fx[:, :3] = np.eye(3)
        g = np.array([v * math.cos(th), v * math.sin(th), omega])
        self.mu = self.mu + Fx.T @ g
        self.mu[2] = wrap(self.mu[2])
        dg = np.array([[0.0, 0.0, -v * math.sin(th)], [0.0, 0.0, v * math.cos(th)], [0.0, 0.0, 0.0]])
        Gt = np.eye(D) + Fx.T @ dg @ Fx
        Vt = np.array([[math.cos(th), 0.0], [math.sin(th), 0.0], [0.0, 1.0]])
        R = np.zeros((3, 3)) if empty else Vt @ self.M @ Vt.T
        self.Sigma = Gt @ self.Sigma @ Gt.T + Fx.T @ R @ Fx
        # correction with the re-observed landmarks, stacked
        known = [(r, b, int(i)) for r, b, i in zip(ranges, bearings, ids) if int(i) in self.index]
        if known:
            m = len(known)
            H = np.zeros((2 * m, D))
            nu = np.zeros(2 * m)
            x, y, th = self.mu[:3]
            for row, (r, b, lm_id) in enumerate(known):
                j = self.index[lm_id]
                dx, dy = self.mu[j] - x, self.mu[j + 1] - y
                q = dx * dx + dy * dy
                sq = math.sqrt(q)
                zhat = np.array([sq, math.atan2(dy, dx) - th])
                low = np.array([[-sq * dx, -sq * dy, 0.0, sq * dx, sq * dy],
                                [dy, -dx, -q, -dy, dx]]) / q  # Table 10.1, line 16
                Fxj = np.zeros((5, D))
                Fxj[:3, :3] = np.eye(3)
                Fxj[3:, j:j + 2] = np.eye(2)
                H[2 * row:2 * row + 2] = low @ Fxj
                nu[2 * row] = r - zhat[0]
                nu[2 * row + 1] = wrap(b - zhat[1])
            S = H @ self.Sigma @ H.T + np.kron(np.eye(m), self.Q)
            K = self.Sigma @ H.T @ np.linalg.inv(S)
            self.mu = self.mu + K @ nu
            self.mu[2] = wrap(self.mu[2])
            self.Sigma = (np.eye(D) - K @ H) @ self.Sigma
        # new landmarks: augment the state by the inverse measurement model
        for r, b, lm_id in zip(ranges, bearings, ids):
            lm_id = int(lm_id)
            if lm_id in self.index:
                continue
            D = self.D
            x, y, th = self.mu[:3]
            a = th + b
            m_xy = np.array([x + r * math.cos(a), y + r * math.sin(a)])
            dx, dy = m_xy[0] - x, m_xy[1] - y
            q = dx * dx + dy * dy
            H_lm = np.array([[dx / math.sqrt(q), dy / math.sqrt(q)], [-dy / q, dx / q]])
            J_z = np.linalg.inv(H_lm)  # d landmark / d (range, bearing)
            J_x = np.array([[1.0, 0.0, -r * math.sin(a)], [0.0, 1.0, r * math.cos(a)]])
            T = np.zeros((D + 2, D))
            T[:D, :D] = np.eye(D)
            T[D:, :3] = J_x
            noise = np.zeros((D + 2, D + 2))
            noise[D:, D:] = J_z @ self.Q @ J_z.T
            self.Sigma = T @ self.Sigma @ T.T + noise
            self.mu = np.concatenate([self.mu, m_xy])
            self.index[lm_id] = D

    def landmark_ids(self) -> list[int]:
        """Ids in state order."""
        return sorted(self.index, key=self.index.get)


def run_oracle(oracle: OracleEkfSlam, scenario, *, n_steps=None, callback=None) -> OracleEkfSlam:
    """Drive ``oracle`` through the first ``n_steps`` steps of ``scenario``; ``callback(t)`` after each."""
    oracle.reset(scenario.start_pose)
    T = scenario.n_steps if n_steps is None else min(n_steps, scenario.n_steps)
    for t in range(T):
        r, b, ids = scenario.observations(t)
        oracle.step(scenario.controls[t], r, b, ids)
        if callback is not None:
            callback(t)
    return oracle
