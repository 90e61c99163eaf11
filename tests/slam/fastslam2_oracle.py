"""A deliberately simple per-particle FastSLAM 2.0: the test oracle for faultlab.slam.FastSlam2.

Written from *Probabilistic Robotics* (Table 13.2) and Montemerlo et al. (2003) with one Python
object per particle, a dict of per-landmark EKFs and explicit loops over particles and
observations.  It shares no algorithm code with faultlab.slam: all matrices are dense and built
per particle, inverses and determinants come from ``np.linalg``, and the proposal is the textbook
*Kalman form* over the stacked observations instead of the information form of the vectorised
units:

* prediction: ``x_hat = g(x, u)``, pose noise ``R = V M V^T`` with ``V = dg/du``;
* stacked measurement of the known landmarks: ``Hx`` (2m, 3) at ``x_hat``,
  ``Z = diag(Hm_j P_j Hm_j^T + Q)``, ``L = Hx R Hx^T + Z`` (2m, 2m);
* proposal over the control noise ``du`` (the pose is ``x_hat + V du``; ``Hu = Hx V``):
  ``mean = M Hu^T L^-1 nu``, ``cov = M - M Hu^T L^-1 Hu M``, one draw
  ``du = mean + chol(cov) eps``, new pose ``g(x, u + du)``;
* weight: multiplied by the proposal's normaliser ``N(nu; 0, L)`` (log weights, normalised
  every step); new landmarks contribute a factor 1;
* landmarks: FastSLAM 1.0's per-landmark EKF from the sampled pose (``(I - K H) P``), new ones
  by the inverse measurement model with covariance ``H^-1 Q H^-T``.

To be comparable draw for draw it uses the same random streams as the vectorised filter
(:func:`faultlab.slam.streams.unit_streams` with the unit names ``sample_proposal`` and
``resample``): in a non-empty update one ``standard_normal((N, 2))`` (row ``i`` for particle
``i``), and one ``uniform(0, 1/N)`` when it resamples (low-variance sampler, Table 4.4).
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
        self.logw = 0.0
        self.lm: dict[int, tuple[np.ndarray, np.ndarray]] = {}

    def copy(self) -> "Particle":
        p = Particle(self.pose)
        p.logw = self.logw
        p.lm = {i: (mu.copy(), P.copy()) for i, (mu, P) in self.lm.items()}
        return p


def measurement(pose, mu):
    """Predicted (range, bearing), Jacobian w.r.t. the pose (2, 3) and w.r.t. the landmark (2, 2)."""
    dx, dy = mu[0] - pose[0], mu[1] - pose[1]
    q = dx * dx + dy * dy
    d = math.sqrt(q)
    zhat = np.array([d, math.atan2(dy, dx) - pose[2]])
    Hx = np.array([[-dx / d, -dy / d, 0.0], [dy / q, -dx / q, -1.0]])
    Hm = np.array([[dx / d, dy / d], [-dy / q, dx / q]])
    return zhat, Hx, Hm


def move(pose, v, omega):
    x, y, th = pose
    return np.array([x + v * math.cos(th), y + v * math.sin(th), wrap(th + omega)])


class OracleFastSlam2:
    """Per-particle loop FastSLAM 2.0 with the settings of :class:`faultlab.slam.FastSlamConfig`."""

    def __init__(self, particles=200, std_v=0.1, std_omega=math.radians(20.0), std_range=0.3,
                 std_bearing=math.radians(10.0), resample_ratio=1.5):
        self.n = particles
        self.M = np.diag([std_v ** 2, std_omega ** 2])
        self.Q = np.diag([std_range ** 2, std_bearing ** 2])
        self.ratio = resample_ratio

    def reset(self, pose, *, rng):
        streams = unit_streams(rng, ["sample_proposal", "resample"])
        self.rng_proposal, self.rng_resample = streams["sample_proposal"], streams["resample"]
        self.particles = [Particle(pose) for _ in range(self.n)]
        for p in self.particles:
            p.pose[2] = wrap(p.pose[2])
            p.logw = -math.log(self.n)
        self.n_resamples = 0

    def step(self, control, ranges, bearings, ids):
        v, omega = float(control[0]), float(control[1])
        empty = len(ids) == 0 and v == 0.0 and omega == 0.0
        if empty:
            for p in self.particles:
                p.pose = move(p.pose, v, omega)
            return
        eps = self.rng_proposal.standard_normal((self.n, 2))
        obs = [(float(r), float(b), int(i)) for r, b, i in zip(ranges, bearings, ids)]
        for i, p in enumerate(self.particles):
            self._particle_step(p, v, omega, obs, eps[i])
        if obs:
            top = max(p.logw for p in self.particles)
            log_total = top + math.log(sum(math.exp(p.logw - top) for p in self.particles))
            for p in self.particles:
                p.logw -= log_total
        w = self.weights()
        if 1.0 / np.sum(w ** 2) < self.n / self.ratio:
            self.resample(w)

    def _particle_step(self, p, v, omega, obs, eps):
        th = p.pose[2]
        x_hat = move(p.pose, v, omega)
        V = np.array([[math.cos(th), 0.0], [math.sin(th), 0.0], [0.0, 1.0]])
        known = [(r, b, i) for r, b, i in obs if i in p.lm]
        m = len(known)
        if m:
            Hx = np.zeros((2 * m, 3))
            Z = np.zeros((2 * m, 2 * m))
            nu = np.zeros(2 * m)
            for row, (r, b, lm_id) in enumerate(known):
                mu, P = p.lm[lm_id]
                zhat, Hx_j, Hm_j = measurement(x_hat, mu)
                Hx[2 * row:2 * row + 2] = Hx_j
                Z[2 * row:2 * row + 2, 2 * row:2 * row + 2] = Hm_j @ P @ Hm_j.T + self.Q
                nu[2 * row] = r - zhat[0]
                nu[2 * row + 1] = wrap(b - zhat[1])
            Hu = Hx @ V
            L = Hu @ self.M @ Hu.T + Z  # = Hx R Hx^T + Z with R = V M V^T
            Li = np.linalg.inv(L)
            mean = self.M @ Hu.T @ Li @ nu
            cov = self.M - self.M @ Hu.T @ Li @ Hu @ self.M
            _, logdet = np.linalg.slogdet(2.0 * math.pi * L)
            p.logw += -0.5 * nu @ Li @ nu - 0.5 * logdet
        else:
            mean, cov = np.zeros(2), self.M
        du = mean + np.linalg.cholesky(0.5 * (cov + cov.T)) @ eps
        p.pose = move(p.pose, v + du[0], omega + du[1])
        for r, b, lm_id in obs:
            if lm_id not in p.lm:
                a = p.pose[2] + b
                mu = np.array([p.pose[0] + r * math.cos(a), p.pose[1] + r * math.sin(a)])
                _, _, Hm = measurement(p.pose, mu)
                Hi = np.linalg.inv(Hm)
                p.lm[lm_id] = (mu, Hi @ self.Q @ Hi.T)
            else:
                mu, P = p.lm[lm_id]
                zhat, _, Hm = measurement(p.pose, mu)
                S = Hm @ P @ Hm.T + self.Q
                K = P @ Hm.T @ np.linalg.inv(S)
                nu_j = np.array([r - zhat[0], wrap(b - zhat[1])])
                p.lm[lm_id] = (mu + K @ nu_j, (np.eye(2) - K @ Hm) @ P)

    def resample(self, w):
        """Low-variance sampler, Table 4.4."""
        M = self.n
        r = self.rng_resample.uniform(0.0, 1.0 / M)
        c = w[0]
        i = 0
        chosen = []
        for m in range(M):
            U = r + m / M
            while U > c and i < M - 1:
                i += 1
                c += w[i]
            chosen.append(self.particles[i].copy())
        for p in chosen:
            p.logw = -math.log(M)
        self.particles = chosen
        self.n_resamples += 1

    # -- views for comparison ------------------------------------------------------------------

    def poses(self) -> np.ndarray:
        return np.array([p.pose for p in self.particles])

    def weights(self) -> np.ndarray:
        return np.exp([p.logw for p in self.particles])

    def landmarks(self, ids) -> tuple[np.ndarray, np.ndarray]:
        """Means (N, C, 2) and covariances (N, C, 2, 2) of landmarks ``ids``, in that order."""
        mu = np.array([[p.lm[int(i)][0] for i in ids] for p in self.particles])
        P = np.array([[p.lm[int(i)][1] for i in ids] for p in self.particles])
        return mu.reshape(self.n, len(ids), 2), P.reshape(self.n, len(ids), 2, 2)

    def known_ids(self) -> set[int]:
        return set(self.particles[0].lm)


def run_oracle(oracle: OracleFastSlam2, scenario, *, rng, n_steps=None, callback=None) -> OracleFastSlam2:
    """Drive ``oracle`` through the first ``n_steps`` steps of ``scenario``; ``callback(t)`` after each."""
    oracle.reset(scenario.start_pose, rng=rng)
    T = scenario.n_steps if n_steps is None else min(n_steps, scenario.n_steps)
    for t in range(T):
        r, b, ids = scenario.observations(t)
        oracle.step(scenario.controls[t], r, b, ids)
        if callback is not None:
            callback(t)
    return oracle
