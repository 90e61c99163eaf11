"""Black-box SLAMs written as a user would, each with one planted bug and its fixed twin.

Plain adapters (no faultlab unit): a small EKF-SLAM and an odometry mapper.  The bugs:

* ``wrap``: the bearing innovation is never wrapped to [-pi, pi);
* ``jacobian``: the heading entry of the bearing Jacobian has the wrong sign;
* ``symmetry``: a new landmark's cross-covariance is written into one triangle of P only, so P loses
  its symmetry and, on long runs, turns NaN;
* ``off_by_one``: the odometry mapper's slot of a landmark is 1-based where its arrays are 0-based;
* ``turn_first`` (the process program ``blackbox_process.py``): the motion turns before it drives.
"""

from __future__ import annotations

import numpy as np

from faultlab.slam import Estimate, SlamAdapter

BUGS = ("wrap", "jacobian", "symmetry", "turn_first")


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


class PlainEkf(SlamAdapter):
    """EKF-SLAM with known correspondences; ``bug`` plants one of :data:`BUGS` (None: correct)."""

    name = "plain_ekf"

    def __init__(self, bug: str | None = None):
        self.bug = bug

    def reset(self, pose, *, rng):
        self.x = np.array(pose, dtype=float)
        self.x[2] = _wrap(self.x[2])
        self.P = np.zeros((3, 3))
        self.slot = {}

    def update(self, control, observations):
        v, w = control
        th = self.x[2] + (w if self.bug == "turn_first" else 0.0)
        self.x[0] += v * np.cos(th)
        self.x[1] += v * np.sin(th)
        self.x[2] = _wrap(self.x[2] + w)
        F = np.eye(3)
        F[0, 2], F[1, 2] = -v * np.sin(th), v * np.cos(th)
        n = self.x.size
        self.P[:3, :] = F @ self.P[:3, :]
        self.P[:, :3] = self.P[:, :3] @ F.T
        self.P[:3, :3] += np.diag([(0.05 * abs(v) + 0.01) ** 2, (0.05 * abs(v) + 0.01) ** 2,
                                   (0.05 * abs(w) + 0.02) ** 2])
        R = np.diag([0.1 ** 2, 0.05 ** 2])
        seen = [k for k, i in enumerate(observations.ids) if int(i) in self.slot]
        if seen:
            self._correct(observations.ranges[seen], observations.bearings[seen], observations.ids[seen], R)
        for k in np.argsort(observations.ids):  # new landmarks in id order
            i = int(observations.ids[k])
            if i not in self.slot:
                self._add(observations.ranges[k], observations.bearings[k], i, R)

    def _correct(self, ranges, bearings, ids, R):
        """One joint update with every re-observed landmark."""
        n, m = self.x.size, len(ids)
        H = np.zeros((2 * m, n))
        innovation = np.zeros(2 * m)
        for row, (r, b, i) in enumerate(zip(ranges, bearings, ids)):
            j = self.slot[int(i)]
            dx, dy = self.x[j] - self.x[0], self.x[j + 1] - self.x[1]
            q = dx * dx + dy * dy
            sq = np.sqrt(q)
            innovation[2 * row:2 * row + 2] = [r - sq, b - (np.arctan2(dy, dx) - self.x[2])]
            if self.bug != "wrap":
                innovation[2 * row + 1] = _wrap(innovation[2 * row + 1])
            H[2 * row:2 * row + 2, :3] = [[-dx / sq, -dy / sq, 0.0],
                                          [dy / q, -dx / q, 1.0 if self.bug == "jacobian" else -1.0]]
            H[2 * row:2 * row + 2, j:j + 2] = [[dx / sq, dy / sq], [-dy / q, dx / q]]
        S = H @ self.P @ H.T + np.kron(np.eye(m), R)
        K = np.linalg.solve(S, H @ self.P).T if self.bug == "symmetry" else self.P @ H.T @ np.linalg.inv(S)
        self.x = self.x + K @ innovation
        self.x[2] = _wrap(self.x[2])
        self.P = self.P - K @ (H @ self.P)
        if self.bug != "symmetry":
            self.P = 0.5 * (self.P + self.P.T)

    def _add(self, r, b, i, R):
        x, y, th = self.x[:3]
        a = th + b
        n = self.x.size
        self.x = np.concatenate([self.x, [x + r * np.cos(a), y + r * np.sin(a)]])
        G = np.array([[1.0, 0.0, -r * np.sin(a)], [0.0, 1.0, r * np.cos(a)]])
        Gz = np.array([[np.cos(a), -r * np.sin(a)], [np.sin(a), r * np.cos(a)]])
        P = np.zeros((n + 2, n + 2))
        P[:n, :n] = self.P
        P[n:, :n] = G @ self.P[:3, :n]
        if self.bug != "symmetry":
            P[:n, n:] = P[n:, :n].T
        P[n:, n:] = G @ self.P[:3, :3] @ G.T + Gz @ R @ Gz.T
        self.P = P
        self.slot[i] = n

    def estimate(self):
        ids = np.array(sorted(self.slot), dtype=np.int64)
        xy = np.array([self.x[self.slot[i]:self.slot[i] + 2] for i in ids], dtype=float).reshape(-1, 2)
        return Estimate(self.x[:3].copy(), ids, xy)


class OdometryMapper(SlamAdapter):
    """Integrates the odometry; each landmark at the mean of its observations.  ``bug="off_by_one"``
    looks a seen landmark's slot up 1-based in 0-based arrays."""

    name = "odometry_mapper"

    def __init__(self, bug: str | None = None):
        self.bug = bug

    def reset(self, pose, *, rng):
        self.pose = np.array(pose, dtype=float)
        self.slot, self.sum, self.count = {}, np.zeros((16, 2)), np.zeros(16)

    def update(self, control, observations):
        v, w = control
        x, y, th = self.pose
        x, y = x + v * np.cos(th), y + v * np.sin(th)
        th = _wrap(th + w)
        self.pose = np.array([x, y, th])
        for r, b, i in zip(observations.ranges, observations.bearings, observations.ids):
            i = int(i)
            if i not in self.slot:
                self.slot[i] = len(self.slot)
                if len(self.slot) > self.sum.shape[0]:
                    self.sum = np.vstack([self.sum, np.zeros_like(self.sum)])
                    self.count = np.concatenate([self.count, np.zeros_like(self.count)])
                k = self.slot[i]
            else:
                k = self.slot[i] + (1 if self.bug == "off_by_one" else 0)
            self.sum[k] += (x + r * np.cos(th + b), y + r * np.sin(th + b))
            self.count[k] += 1

    def estimate(self):
        ids = np.array(sorted(self.slot), dtype=np.int64)
        k = np.array([self.slot[i] for i in ids], dtype=np.int64)
        xy = (self.sum[k] / np.maximum(self.count[k], 1)[:, None]).reshape(-1, 2)
        return Estimate(self.pose.copy(), ids, xy)


def make_ekf(bug: str | None = None) -> PlainEkf:
    return PlainEkf(bug)


def make_mapper(bug: str | None = None) -> OdometryMapper:
    return OdometryMapper(bug)


# The factories a check names ("tests.oracles.blackbox:ekf_wrap"), each bug and its fixed twin.
def ekf_fixed() -> PlainEkf:
    return PlainEkf()


def ekf_wrap() -> PlainEkf:
    return PlainEkf("wrap")


def ekf_jacobian() -> PlainEkf:
    return PlainEkf("jacobian")


def ekf_symmetry() -> PlainEkf:
    return PlainEkf("symmetry")


def mapper_fixed() -> OdometryMapper:
    return OdometryMapper()


def mapper_off_by_one() -> OdometryMapper:
    return OdometryMapper("off_by_one")
