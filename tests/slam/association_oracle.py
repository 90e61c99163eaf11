"""A deliberately simple per-particle FastSLAM 1.0 with unknown data association: the test oracle.

Written from Montemerlo et al.'s FastSLAM with maximum-likelihood association and the
new-landmark likelihood ``p0`` (Probabilistic Robotics, Sec. 13.6), with one Python object per
particle holding a *list* of landmark EKFs and explicit loops over particles, observations and
landmarks: every landmark of a particle is compared with every observation (no gate), 2 x 2
algebra uses ``np.linalg``, the weights are linear and normalised every step.  The only rule
beyond the textbook is the one :func:`faultlab.slam.associationunits.associate` documents: a landmark takes
at most one observation per step (the most likely one, ties to the lowest index), the others
start new landmarks.

Randomness follows the unit contract, as :mod:`tests.slam.oracle` does: the control noise and the
resampling draw from the ``sample_controls`` and ``resample`` streams of
:func:`faultlab.slam.streams.unit_streams`, in the same order as the vectorised filter.
"""

from __future__ import annotations

import math

import numpy as np

from tests.slam.oracle import OracleFastSlam, landmark_ekf, measurement, new_landmark, wrap


def log_p0(Q: np.ndarray, sigmas: float) -> float:
    """Log density of N(0, Q) at a point ``sigmas`` Mahalanobis units from the mean."""
    return -0.5 * sigmas ** 2 - math.log(math.sqrt(np.linalg.det(2.0 * math.pi * Q)))


def pair_log_likelihood(pose, mu, P, z, Q) -> float:
    """log N(z - h(pose, mu); 0, H P H^T + Q) for one landmark and one observation (range, bearing)."""
    zhat, H = measurement(pose, mu)
    S = H @ P @ H.T + Q
    nu = np.array([z[0] - zhat[0], wrap(z[1] - zhat[1])])
    return float(-0.5 * nu @ np.linalg.inv(S) @ nu - 0.5 * math.log(np.linalg.det(2.0 * math.pi * S)))


def associate_particle(pose, landmarks, z, Q, lp0) -> list[int]:
    """One particle's association of the observations ``z`` (k, 2): landmark index or -1 (new)."""
    best = []
    for zm in z:
        lls = [pair_log_likelihood(pose, mu, P, zm, Q) for mu, P in landmarks]
        j = int(np.argmax(lls)) if lls else -1
        best.append((j, lls[j]) if j >= 0 and lls[j] >= lp0 else (-1, -math.inf))
    out = [j for j, _ in best]
    for m, (j, ll) in enumerate(best):  # mutual exclusion: the most likely observation keeps the landmark
        if j < 0:
            continue
        for m2, (j2, ll2) in enumerate(best):
            if m2 != m and j2 == j and (ll2 > ll or (ll2 == ll and m2 < m)):
                out[m] = -1
    return out


class Particle:
    def __init__(self, pose):
        self.pose = np.array(pose, dtype=float)
        self.w = 1.0
        self.lm: list[tuple[np.ndarray, np.ndarray]] = []

    def copy(self) -> "Particle":
        p = Particle(self.pose)
        p.w = self.w
        p.lm = [(mu.copy(), P.copy()) for mu, P in self.lm]
        return p


class OracleFastSlamUnknown(OracleFastSlam):
    """Per-particle loop FastSLAM 1.0 with unknown association and :class:`~faultlab.slam.FastSlamConfig`'s settings.

    The prediction's draws, the weight normalisation and the low-variance resampling are those
    of :class:`tests.slam.oracle.OracleFastSlam`; the particles hold lists of landmarks.
    """

    def __init__(self, new_landmark_sigmas=3.0, **settings):
        super().__init__(**settings)
        self.lp0 = log_p0(self.Q, new_landmark_sigmas)

    def reset(self, pose, *, rng):
        super().reset(pose, rng=rng)
        self.particles = [Particle(pose) for _ in range(self.n)]
        for p in self.particles:
            p.w = 1.0 / self.n
        self.associations: list[list[int]] = []

    def step(self, control, ranges, bearings):
        v, omega = float(control[0]), float(control[1])
        empty = len(ranges) == 0 and v == 0.0 and omega == 0.0
        eps = None if empty else self.control_rng.standard_normal((self.n, 2))
        for i, p in enumerate(self.particles):
            vi, wi = (v, omega) if empty else (v + eps[i, 0] * self.std_v, omega + eps[i, 1] * self.std_omega)
            x, y, th = p.pose
            p.pose = np.array([x + vi * math.cos(th), y + vi * math.sin(th), wrap(th + wi)])
        z = np.column_stack([ranges, bearings]) if len(ranges) else np.empty((0, 2))
        self.associations = []
        for p in self.particles:
            assoc = associate_particle(p.pose, p.lm, z, self.Q, self.lp0) if len(z) else []
            self.associations.append(assoc)
            for m, j in enumerate(assoc):
                r, b = z[m]
                if j < 0:
                    p.lm.append(new_landmark(p.pose, r, b, self.Q))
                    p.w *= math.exp(self.lp0)
                else:
                    mu, P, likelihood = landmark_ekf(p.pose, *p.lm[j], r, b, self.Q)
                    p.w *= likelihood
                    p.lm[j] = (mu, P)
        self.finish_step(empty)
