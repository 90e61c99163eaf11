"""The reference units of FastSLAM 1.0 against independent computations (faultlab.slam.units)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import multivariate_normal

from faultlab.slam import FastSlamConfig
from faultlab.slam import particles
from faultlab.slam import units as U

Q = FastSlamConfig().Q


def _random_case(seed, n=5, k=4):
    rng = np.random.default_rng(seed)
    poses = np.column_stack([rng.uniform(-3, 3, n), rng.uniform(-3, 3, n), rng.uniform(-math.pi, math.pi, n)])
    mu = poses[:, None, :2] + rng.uniform(0.3, 2.0, (n, k, 1)) * np.stack(
        [np.cos(a := rng.uniform(-math.pi, math.pi, (n, k))), np.sin(a)], axis=-1)
    A = rng.normal(size=(n, k, 2, 2))
    P = A @ np.swapaxes(A, -1, -2) * 0.05 + 0.01 * np.eye(2)
    return rng, poses, mu, P


@given(st.floats(-1e4, 1e4, allow_nan=False))
def test_wraps_land_in_half_open_interval_and_differ_by_full_turns(a):
    for wrap in (U.wrap_heading, U.wrap_bearing):
        w = float(wrap(np.float64(a)))
        assert -math.pi <= w < math.pi + 1e-12
        turns = (a - w) / (2 * math.pi)
        assert abs(turns - round(turns)) < 1e-9


def test_predict_measurement_against_finite_differences():
    _, poses, mu, _ = _random_case(0)
    zhat, H = U.predict_measurement(poses, mu)
    d = mu - poses[:, None, :2]
    np.testing.assert_allclose(zhat[..., 0], np.hypot(d[..., 0], d[..., 1]))
    np.testing.assert_allclose(np.cos(zhat[..., 1]), np.cos(np.arctan2(d[..., 1], d[..., 0]) - poses[:, None, 2]))
    eps = 1e-6
    for j in range(2):
        step = np.zeros(2)
        step[j] = eps
        zp, _ = U.predict_measurement(poses, mu + step)
        zm, _ = U.predict_measurement(poses, mu - step)
        np.testing.assert_allclose((zp - zm) / (2 * eps), H[..., :, j], atol=1e-6)


def test_init_landmarks_inverts_the_measurement_model():
    _, poses, mu, _ = _random_case(1)
    zhat, H = U.predict_measurement(poses, mu)
    z = zhat[0]  # the observations of particle 0 ...
    z[:, 1] += 2 * math.pi  # ... with bearings one turn off
    mu0, P0 = U.init_landmarks(poses[:1], z, Q, wrap=U.wrap_bearing)
    np.testing.assert_allclose(mu0[0], mu[0], atol=1e-12)
    Hi = np.linalg.inv(H[0])
    np.testing.assert_allclose(P0[0], Hi @ Q @ np.swapaxes(Hi, -1, -2), rtol=1e-10, atol=1e-15)
    mu_all, P_all = U.init_landmarks(poses, z, Q, wrap=U.wrap_bearing)
    assert mu_all.shape == (5, 4, 2) and P_all.shape == (5, 4, 2, 2)


def test_innovation_wraps_only_the_bearing():
    zhat = np.array([[[1.0, 3.0], [2.0, -3.0]]])
    z = np.array([[1.5, -3.0], [1.0, 3.0]])
    nu = U.innovation(z, zhat, wrap=U.wrap_bearing)
    np.testing.assert_allclose(nu, [[[0.5, 2 * math.pi - 6.0], [-1.0, 6.0 - 2 * math.pi]]])


def test_innovation_covariance_likelihood_and_ekf_against_linalg():
    rng, poses, mu, P = _random_case(2)
    zhat, H = U.predict_measurement(poses, mu)
    S = U.innovation_covariance(H, P, Q)
    np.testing.assert_allclose(S, H @ P @ np.swapaxes(H, -1, -2) + Q, rtol=1e-12)
    nu = rng.normal(scale=0.3, size=mu.shape)
    ll = U.log_likelihood(nu, S)
    ref = np.array([[multivariate_normal(mean=np.zeros(2), cov=S[i, j]).logpdf(nu[i, j])
                     for j in range(S.shape[1])] for i in range(S.shape[0])])
    np.testing.assert_allclose(ll, ref, rtol=1e-10)
    mu1, P1 = U.ekf_update(mu, P, H, S, nu)
    K = P @ np.swapaxes(H, -1, -2) @ np.linalg.inv(S)
    np.testing.assert_allclose(mu1, mu + (K @ nu[..., None])[..., 0], rtol=1e-10)
    np.testing.assert_allclose(P1, (np.eye(2) - K @ H) @ P, rtol=1e-9, atol=1e-14)
    assert np.all(P1[..., 0, 1] == P1[..., 1, 0])
    assert not np.shares_memory(P1, P) and not np.shares_memory(mu1, mu)


def test_combine_weights_multiplies_likelihoods_of_known_landmarks_only():
    logw = np.log([0.5, 0.25, 0.25])
    ll = np.array([[-1.0, -2.0], [-0.5, -4.0], [0.0, 3.0]])
    known = np.array([[True, True], [True, False], [False, False]])
    np.testing.assert_allclose(U.combine_weights(logw, ll, known), logw + [-3.0, -0.5, 0.0])


def test_effective_sample_size():
    assert U.effective_sample_size(np.full(8, 1 / 8)) == pytest.approx(8.0)
    assert U.effective_sample_size(np.array([1.0, 0, 0, 0])) == pytest.approx(1.0)
    assert U.effective_sample_size(np.array([0.5, 0.5, 0, 0])) == pytest.approx(2.0)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=40).filter(lambda w: sum(w) > 1e-3),
       st.integers(0, 2**32 - 1))
def test_low_variance_sampler_copies_each_particle_floor_or_ceil_of_n_w_times(w, seed):
    w = np.array(w) / np.sum(w)
    n = w.size
    idx = U.low_variance_indices(w, np.random.default_rng(seed))
    assert idx.shape == (n,) and np.all(np.diff(idx) >= 0)
    counts = np.bincount(idx, minlength=n)
    assert np.all(counts >= np.floor(n * w - 1e-9)) and np.all(counts <= np.ceil(n * w + 1e-9))
    assert np.all(counts[w == 0] == 0)


def test_resample_only_below_threshold_and_never_for_empty_updates():
    cfg = FastSlamConfig(particles=4)
    rng = np.random.default_rng(0)
    uniform = np.full(4, 0.25)
    peaked = np.array([0.85, 0.05, 0.05, 0.05])
    n_eff = U.effective_sample_size(peaked)
    assert n_eff < 4 / 1.5
    assert U.resample(uniform, 4.0, False, rng, cfg) is None
    assert U.resample(peaked, n_eff, True, rng, cfg) is None
    state = rng.bit_generator.state
    idx = U.resample(peaked, n_eff, False, rng, cfg)
    assert idx.shape == (4,) and np.sum(idx == 0) >= 3
    assert rng.bit_generator.state != state


def test_sample_controls_statistics():
    cfg = FastSlamConfig()
    u = U.sample_controls(np.array([0.8, 0.1]), 20000, np.random.default_rng(3), cfg)
    assert u.shape == (20000, 2)
    np.testing.assert_allclose(u.mean(axis=0), [0.8, 0.1], atol=0.01)
    np.testing.assert_allclose(u.std(axis=0), [cfg.std_v, cfg.std_omega], rtol=0.03)


def test_apply_resample_and_extract_map_follow_the_lineage():
    state = particles.ParticleState.initial(np.zeros(3), 3, capacity=2)
    state.mu[:, 0] = [[1.0, 1.0], [2.0, 2.0], [3.0, 3.0]]
    state = state.replace(ids=np.array([7]), logw=np.log([0.2, 0.7, 0.1]))
    ids, xy = U.extract_map(state)
    np.testing.assert_array_equal(ids, [7])
    np.testing.assert_array_equal(xy, [[2.0, 2.0]])
    res = U.apply_resample(state, np.array([2, 2, 0]))
    np.testing.assert_allclose(np.exp(res.logw), np.full(3, 1 / 3))
    rows = particles.landmark_rows(res, np.array([0]))
    np.testing.assert_array_equal(res.mu[rows[:, 0], 0], [[3.0, 3.0], [3.0, 3.0], [1.0, 1.0]])
    np.testing.assert_array_equal(U.extract_map(res)[1], [[3.0, 3.0]])  # tie -> lowest index
    assert res.mu is state.mu  # no copy of the landmark storage
