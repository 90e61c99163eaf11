"""A deliberately simple per-particle FastSLAM 1.0: the test oracle for the vectorised filter.

Written straight from *Probabilistic Robotics* (Table 13.1, known
correspondences; low-variance sampler of Table 4.4) with one Python object
per particle, a dict of per-landmark EKFs, and explicit loops over particles
and observations.  It shares no code with :mod:`faultlab.slam`: 2 x 2 algebra
uses ``np.linalg.inv`` / ``@``, angles are wrapped with scalar ``math``, the
measurement Jacobian is inverted numerically, the covariance update is the
textbook ``(I - K H) P``, and the weights are linear (normalised every step).

To be comparable draw for draw it follows the unit contract on randomness: the
control noise and the resampling draw from two separate streams derived from
the seed by unit name (:func:`faultlab.slam.streams.unit_streams`, the only
faultlab code used here), and it consumes them in the same order as the
vectorised filter: in a non-empty update one ``standard_normal(2)`` per
particle (particle order) from the ``sample_controls`` stream, and one
``uniform(0, 1/N)`` from the ``resample`` stream when it resamples.
"""

from __future__ import annotations

import math

import numpy as np

from faultlab.slam.streams import unit_streams


def wrap(a: float) -> float:
    """Wrap an angle to [-pi, pi)."""
    return (a + math.pi) % (2.0 * math.pi) - math.pi


class Particle:
    def __init__(self, pose):
        self.pose = np.array(pose, dtype=float)
        self.w = 1.0
        self.lm: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def copy(self) -> "Particle":
        p = Particle(self.pose)
        p.w = self.w
        p.lm = {i: (mu.copy(), P.copy()) for i, (mu, P) in self.lm.items()}
        return p


def measurement(pose, mu):
    """Predicted (range, bearing) and Jacobian w.r.t. the landmark."""
    dx, dy = mu[0] - pose[0], mu[1] - pose[1]
    q = dx * dx + dy * dy
    d = math.sqrt(q)
    zhat = np.array([d, math.atan2(dy, dx) - pose[2]])
    H = np.array([[dx / d, dy / d], [-dy / q, dx / q]])
    return zhat, H


def new_landmark(pose, r, b, Q):
    """Mean and covariance of a landmark first seen at range ``r``, bearing ``b`` (Table 13.1, lines 9-11)."""
    a = pose[2] + b
    mu = np.array([pose[0] + r * math.cos(a), pose[1] + r * math.sin(a)])
    _, H = measurement(pose, mu)
    Hi = np.linalg.inv(H)
    return mu, Hi @ Q @ Hi.T


def landmark_ekf(pose, mu, P, r, b, Q):
    """The landmark's EKF update with observation (r, b) and the observation's likelihood (lines 13-19)."""
    zhat, H = measurement(pose, mu)
    S = H @ P @ H.T + Q
    Si = np.linalg.inv(S)
    K = P @ H.T @ Si
    nu = np.array([r - zhat[0], wrap(b - zhat[1])])
    likelihood = math.exp(-0.5 * nu @ Si @ nu) / math.sqrt(np.linalg.det(2.0 * math.pi * S))
    return mu + K @ nu, (np.eye(2) - K @ H) @ P, likelihood


class OracleFastSlam:
    """Per-particle loop FastSLAM 1.0 with the same settings as :class:`faultlab.slam.FastSlamConfig`."""

    def __init__(self, particles=200, std_v=0.1, std_omega=math.radians(20.0), std_range=0.3,
                 std_bearing=math.radians(10.0), resample_ratio=1.5):
        self.n = particles
        self.std_v, self.std_omega = std_v, std_omega
        self.Q = np.array([[std_range ** 2, 0.0], [0.0, std_bearing ** 2]])
        self.ratio = resample_ratio

    def reset(self, pose, *, rng):
        streams = unit_streams(rng, ["sample_controls", "resample"])
        self.control_rng, self.resample_rng = streams["sample_controls"], streams["resample"]
        self.particles = [Particle(pose) for _ in range(self.n)]
        for p in self.particles:
            p.w = 1.0 / self.n
        self.n_resamples = 0

    def step(self, control, ranges, bearings, ids):
        v, omega = float(control[0]), float(control[1])
        empty = len(ids) == 0 and v == 0.0 and omega == 0.0
        # prediction: sample the motion model
        for p in self.particles:
            if empty:
                vi, wi = v, omega
            else:
                e = self.control_rng.standard_normal(2)
                vi, wi = v + e[0] * self.std_v, omega + e[1] * self.std_omega
            x, y, th = p.pose
            p.pose = np.array([x + vi * math.cos(th), y + vi * math.sin(th), wrap(th + wi)])
        # correction, one landmark EKF per particle and observation
        for p in self.particles:
            for r, b, lm_id in zip(ranges, bearings, ids):
                lm_id = int(lm_id)
                if lm_id not in p.lm:
                    p.lm[lm_id] = new_landmark(p.pose, r, b, self.Q)
                else:
                    mu, P, likelihood = landmark_ekf(p.pose, *p.lm[lm_id], r, b, self.Q)
                    p.w *= likelihood
                    p.lm[lm_id] = (mu, P)
        self.finish_step(empty)

    def finish_step(self, empty: bool) -> None:
        """Normalise the weights, then resample when the effective sample size is low (never for an empty update)."""
        total = sum(p.w for p in self.particles)
        for p in self.particles:
            p.w /= total
        n_eff = 1.0 / sum(p.w ** 2 for p in self.particles)
        if not empty and n_eff < self.n / self.ratio:
            self.resample()

    def resample(self):
        """Low-variance sampler, Table 4.4."""
        M = self.n
        r = self.resample_rng.uniform(0.0, 1.0 / M)
        c = self.particles[0].w
        i = 0
        chosen = []
        for m in range(M):
            U = r + m / M
            while U > c and i < M - 1:
                i += 1
                c += self.particles[i].w
            chosen.append(self.particles[i].copy())
        for p in chosen:
            p.w = 1.0 / M
        self.particles = chosen
        self.n_resamples += 1

    # -- views for comparison ------------------------------------------------------------------

    def poses(self) -> np.ndarray:
        return np.array([p.pose for p in self.particles])

    def weights(self) -> np.ndarray:
        return np.array([p.w for p in self.particles])

    def landmarks(self, ids) -> tuple[np.ndarray, np.ndarray]:
        """Means (N, C, 2) and covariances (N, C, 2, 2) of landmarks ``ids``, in that order."""
        mu = np.array([[p.lm[int(i)][0] for i in ids] for p in self.particles])
        P = np.array([[p.lm[int(i)][1] for i in ids] for p in self.particles])
        return mu.reshape(self.n, len(ids), 2), P.reshape(self.n, len(ids), 2, 2)

    def known_ids(self) -> set[int]:
        return set(self.particles[0].lm)


def run_oracle(oracle: OracleFastSlam, scenario, *, rng, n_steps=None, callback=None) -> OracleFastSlam:
    """Drive ``oracle`` through the first ``n_steps`` steps of ``scenario``; ``callback(t)`` after each."""
    oracle.reset(scenario.start_pose, rng=rng)
    T = scenario.n_steps if n_steps is None else min(n_steps, scenario.n_steps)
    for t in range(T):
        r, b, ids = scenario.observations(t)
        oracle.step(scenario.controls[t], r, b, ids)
        if callback is not None:
            callback(t)
    return oracle
