"""A user's EKF-SLAM that reports its covariance (the black-box ``PlainEkf`` plus the covariance),
and its overconfident twin: the Joseph-form covariance update without its ``K R K^T`` term, so
the covariance shrinks faster than the error does."""

from __future__ import annotations

import numpy as np

from blackbox import PlainEkf, _wrap
from faultlab.slam import Estimate


class CovarianceEkf(PlainEkf):
    """``PlainEkf`` reporting the covariance of its final state; ``forget_r`` plants the bug."""

    name = "covariance_ekf"

    def __init__(self, forget_r: bool = False):
        super().__init__()
        self.forget_r = forget_r

    def _correct(self, ranges, bearings, ids, R):
        n, m = self.x.size, len(ids)
        H = np.zeros((2 * m, n))
        innovation = np.zeros(2 * m)
        for row, (r, b, i) in enumerate(zip(ranges, bearings, ids)):
            j = self.slot[int(i)]
            dx, dy = self.x[j] - self.x[0], self.x[j + 1] - self.x[1]
            q = dx * dx + dy * dy
            sq = np.sqrt(q)
            innovation[2 * row:2 * row + 2] = [r - sq, _wrap(b - (np.arctan2(dy, dx) - self.x[2]))]
            H[2 * row:2 * row + 2, :3] = [[-dx / sq, -dy / sq, 0.0], [dy / q, -dx / q, -1.0]]
            H[2 * row:2 * row + 2, j:j + 2] = [[dx / sq, dy / sq], [-dy / q, dx / q]]
        Rm = np.kron(np.eye(m), R)
        S = H @ self.P @ H.T + Rm
        K = self.P @ H.T @ np.linalg.inv(S)
        self.x = self.x + K @ innovation
        self.x[2] = _wrap(self.x[2])
        A = np.eye(n) - K @ H
        self.P = A @ self.P @ A.T + (0.0 if self.forget_r else K @ Rm @ K.T)  # Joseph form
        self.P = 0.5 * (self.P + self.P.T)

    def estimate(self):
        est = super().estimate()
        rows = [0, 1, 2] + [self.slot[int(i)] + d for i in est.landmark_ids for d in (0, 1)]
        return Estimate(est.pose, est.landmark_ids, est.landmarks, covariance=self.P[np.ix_(rows, rows)].copy())


def make():
    return CovarianceEkf()


def make_overconfident():
    return CovarianceEkf(forget_r=True)
