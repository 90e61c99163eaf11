"""Particles that share landmark arrays update them one after another (faultlab.slam.sharing).

The oracle is a slow, per-particle transcription of the paper's filter (PythonRobotics' FastSLAM 1.0
as modified in the replication package, ``slam/slam_correct.py``), written from its semantics with one
Python object per particle, landmark arrays that resampling shares by reference, and the package's own
length unit (0.1 m): it shares no code with faultlab.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from faultlab.faults import get_fault
from faultlab.scenario import generate_scenario
from faultlab.slam import REFERENCE_STEPS, FastSlam, run_slam
from faultlab.slam.profiles import PAPER_CONFIG, PAPER_LENGTH_UNIT, PAPER_NO_ALIASING_STEPS, PAPER_STEPS
from faultlab.slam.sharing import correct_in_sharer_order, sharer_ranks
from faultlab.space import FIXED_VALUES, CaseSpec

N = 6
#: Resampling indices applied after the given steps (chains, duplicates, repeated sharing).
SCRIPT = {2: [1, 0, 0, 3, 3, 5], 4: [2, 2, 0, 1, 5, 4], 7: [5, 5, 5, 0, 1, 2], 9: [0, 0, 4, 4, 3, 3],
          11: [1, 1, 2, 2, 3, 3]}


def _pi_2_pi(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


class _Particle:
    def __init__(self, n_landmarks: int):
        self.w = 1.0 / N
        self.x = self.y = self.yaw = 0.0
        self.lm = np.zeros((n_landmarks, 2))
        self.lmP = np.zeros((2 * n_landmarks, 2))


def _paper_filter(scenario, eps, Q, tolerance=0.01):
    """The paper's FastSLAM 1.0 with given control noise and resampling indices, in 0.1 m units."""
    L = PAPER_LENGTH_UNIT
    n_lm = int(scenario.landmark_ids.max()) + 1
    parts = [_Particle(n_lm) for _ in range(N)]
    for t in range(scenario.n_steps):
        v, omega = scenario.controls[t]
        for i, p in enumerate(parts):  # prediction; every step of the scenario moves
            vd, od = v / L + eps[t][i, 0] / L, omega + eps[t][i, 1]
            p.x, p.y = p.x + vd * math.cos(p.yaw), p.y + vd * math.sin(p.yaw)
            p.yaw = _pi_2_pi(p.yaw + od)
        ranges, bearings, ids = scenario.observations(t)
        for r, b, j in zip(ranges / L, bearings, ids):  # observations outer, particles inner
            z = np.array([r, b])
            for p in parts:
                P = p.lmP[2 * j:2 * j + 2]
                if abs(p.lm[j, 0]) <= tolerance:  # new landmark, written into the (shared) arrays
                    a = _pi_2_pi(p.yaw + b)
                    c, s = math.cos(a), math.sin(a)
                    p.lm[j] = (p.x + r * c, p.y + r * s)
                    G = np.array([[c, s], [-s / r, c / r]])
                    p.lmP[2 * j:2 * j + 2] = np.linalg.inv(G) @ Q @ np.linalg.inv(G.T)
                    continue
                dx, dy = p.lm[j, 0] - p.x, p.lm[j, 1] - p.y
                d2 = dx * dx + dy * dy
                d = math.sqrt(d2)
                zp = np.array([d, _pi_2_pi(math.atan2(dy, dx) - p.yaw)])
                H = np.array([[dx / d, dy / d], [-dy / d2, dx / d2]])
                S = H @ P @ H.T + Q
                dz = z - zp
                dz[1] = _pi_2_pi(dz[1])
                p.w *= math.exp(-0.5 * dz @ np.linalg.inv(S) @ dz) / (2 * math.pi * math.sqrt(np.linalg.det(S)))
                PHt = P @ H.T
                K = PHt @ np.linalg.inv(S)
                p.lm[j] = p.lm[j] + K @ dz
                p.lmP[2 * j:2 * j + 2] = P - K @ PHt.T
        total = sum(p.w for p in parts)  # normalize_weight
        for p in parts:
            p.w = p.w / total if total != 0.0 else 1.0 / N
        if t in SCRIPT:  # resampling(): a shallow list copy, views of the landmark arrays
            tmp = parts[:]
            for i, k in enumerate(SCRIPT[t]):
                parts[i].x, parts[i].y, parts[i].yaw = tmp[k].x, tmp[k].y, tmp[k].yaw
                parts[i].lm = tmp[k].lm[:, :]
                parts[i].lmP = tmp[k].lmP[:, :]
                parts[i].w = 1.0 / N
    return parts


def _scripted(steps, eps):
    """The steps with the control noise and the resampling decisions taken from the script."""
    controls = iter(eps)
    resamples = iter(range(10 ** 6))

    def sample_controls(u, n, rng, config):
        return u[None, :] + next(controls)

    def resample(w, n_eff, empty, rng, config):
        t = next(resamples)
        return np.array(SCRIPT[t]) if t in SCRIPT else None

    return dataclasses.replace(steps, sample_controls=sample_controls, resample=resample)


@pytest.fixture(scope="module")
def tiny_case():
    values = dict(FIXED_VALUES, map_size=4.0, landmark_density=2.0, step_size=40.0, field_of_view=2 * math.pi)
    scenario = generate_scenario(CaseSpec(values), rng=np.random.default_rng(11), n_steps=14)
    rng = np.random.default_rng(5)
    eps = [rng.normal(size=(N, 2)) * [PAPER_CONFIG.std_v, PAPER_CONFIG.std_omega]
           for _ in range(scenario.n_steps)]
    return scenario, eps


def _run(steps, scenario, eps):
    cfg = dataclasses.replace(PAPER_CONFIG, particles=N)
    slam = FastSlam(cfg, steps=_scripted(steps, eps))
    run_slam(slam, scenario, rng=np.random.default_rng(0))
    return slam


def test_paper_profile_equals_the_per_particle_transcription_with_shared_arrays(tiny_case):
    scenario, eps = tiny_case
    L = PAPER_LENGTH_UNIT
    Q = np.diag([(PAPER_CONFIG.std_range / L) ** 2, PAPER_CONFIG.std_bearing ** 2])
    parts = _paper_filter(scenario, eps, Q)
    slam = _run(PAPER_STEPS, scenario, eps)
    got = slam.particles()
    ids = got.landmark_ids
    assert ids.size == np.unique(scenario.obs_ids).size
    np.testing.assert_allclose(got.poses[:, :2], [[p.x * L, p.y * L] for p in parts], rtol=1e-10, atol=1e-12)
    np.testing.assert_allclose(got.weights, [p.w for p in parts], rtol=1e-8)
    np.testing.assert_allclose(got.means, [p.lm[ids] * L for p in parts], rtol=1e-8, atol=1e-12)
    cov = [[p.lmP[2 * j:2 * j + 2] * L * L for j in ids] for p in parts]
    np.testing.assert_allclose(got.covariances, cov, rtol=1e-7, atol=1e-15)
    # the sharing structure is the transcription's: equal storage rows <=> the same landmark arrays
    owner = np.asarray(slam.state.owner)
    same_array = np.array([[np.shares_memory(a.lm, b.lm) for b in parts] for a in parts])
    np.testing.assert_array_equal(owner[:, None] == owner[None, :], same_array)
    assert np.unique(owner).size <= 3  # the script leaves few distinct maps: sharing was exercised


def test_paper_aliasing_fault_is_the_paper_profiles_resampling(tiny_case):
    scenario, eps = tiny_case
    fault = get_fault("paper_aliasing")
    with_fault = _run(fault.patch(PAPER_NO_ALIASING_STEPS), scenario, eps)
    paper = _run(PAPER_STEPS, scenario, eps)
    a, b = with_fault.particles(), paper.particles()
    np.testing.assert_array_equal(a.means, b.means)
    np.testing.assert_array_equal(a.covariances, b.covariances)
    np.testing.assert_array_equal(a.weights, b.weights)
    # without aliasing, and with the parallel last-writer-wins shallow copy, the result differs
    deep = _run(PAPER_NO_ALIASING_STEPS, scenario, eps).particles()
    shallow = get_fault("shallow_copy_resampling").patch(PAPER_NO_ALIASING_STEPS)
    last_wins = _run(shallow, scenario, eps).particles()
    assert not np.allclose(deep.means, b.means, atol=1e-6)
    assert not np.allclose(last_wins.means, b.means, atol=1e-6)


def test_sharer_ranks_against_brute_force():
    owner = np.array([4, 1, 4, 4, 0, 1, 7])
    group, rank, order = sharer_ranks(owner)
    for i in range(owner.size):
        assert rank[i] == sum(1 for j in range(i) if owner[j] == owner[i])
        for j in range(owner.size):
            assert (group[i] == group[j]) == (owner[i] == owner[j])
    assert list(order) == sorted(range(owner.size), key=lambda i: (owner[i], i))


def test_without_sharing_the_sequential_correction_is_the_parallel_one():
    rng = np.random.default_rng(3)
    n, k = 5, 4
    poses = np.column_stack([rng.uniform(-1, 1, n), rng.uniform(-1, 1, n), rng.uniform(-3, 3, n)])
    mu = rng.uniform(-2, 2, (n, k, 2))
    A = rng.normal(size=(n, k, 2, 2))
    P = A @ np.swapaxes(A, -1, -2) * 0.01 + 0.01 * np.eye(2)
    z = np.column_stack([rng.uniform(0.5, 2, k), rng.uniform(-3, 3, k)])
    seen = np.array([True, True, False, True])
    mu[:, 2] = 0.0
    P[:, 2] = 0.0
    logw = np.log(rng.dirichlet(np.ones(n)))
    Q = PAPER_CONFIG.Q
    s = REFERENCE_STEPS
    got_w, got_mu, got_P = correct_in_sharer_order(s, logw, np.arange(n), poses, z, seen, mu, P, Q)
    # the reference pipeline, all particles at once
    new = s.classify_new(seen, mu)
    mu0, P0 = s.init_landmarks(poses, z, Q, wrap=s.wrap_bearing)
    m = np.where(new[..., None], mu0, mu)
    Pm = np.where(new[..., None, None], P0, P)
    zhat, H = s.predict_measurement(poses, m)
    nu = s.innovation(z, zhat, wrap=s.wrap_bearing)
    S = s.innovation_covariance(H, Pm, Q)
    w = s.combine_weights(logw, s.log_likelihood(nu, S), ~new)
    m2, P2 = s.ekf_update(m, Pm, H, S, nu)
    np.testing.assert_allclose(got_w, w, rtol=1e-13)
    np.testing.assert_allclose(got_mu, np.where(new[..., None], m, m2), rtol=1e-13)
    np.testing.assert_allclose(got_P, np.where(new[..., None, None], Pm, P2), rtol=1e-13)


def test_a_shared_landmark_is_updated_once_per_sharer_in_particle_order():
    """Three particles share one row: the second and third start from the previous sharer's result."""
    s = REFERENCE_STEPS
    Q = PAPER_CONFIG.Q
    poses = np.array([[0.0, 0.0, 0.0], [0.1, 0.0, 0.05], [0.0, -0.1, -0.05]])
    mu = np.tile([[[1.0, 0.5]]], (3, 1, 1))
    P = np.tile([[[[0.02, 0.0], [0.0, 0.02]]]], (3, 1, 1, 1))
    z = np.array([[1.2, 0.4]])
    logw = np.log(np.full(3, 1 / 3))
    got_w, got_mu, got_P = correct_in_sharer_order(s, logw, np.array([2, 2, 2]), poses, z, np.array([True]),
                                                   mu, P, Q)
    m, Pm, lls = mu[:1], P[:1], []
    for i in range(3):  # one particle at a time, each from the previous result
        zhat, H = s.predict_measurement(poses[i:i + 1], m)
        nu = s.innovation(z, zhat, wrap=s.wrap_bearing)
        S = s.innovation_covariance(H, Pm, Q)
        lls.append(s.log_likelihood(nu, S)[0, 0])
        m, Pm = s.ekf_update(m, Pm, H, S, nu)
    np.testing.assert_allclose(got_mu, np.repeat(m, 3, axis=0), rtol=1e-13)
    np.testing.assert_allclose(got_P, np.repeat(Pm, 3, axis=0), rtol=1e-13)
    np.testing.assert_allclose(got_w, logw + np.array(lls), rtol=1e-13)
    assert np.linalg.det(got_P[0, 0]) < np.linalg.det(P[0, 0]) / 2  # shrunk once per sharer
