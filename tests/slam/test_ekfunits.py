"""The EKF-SLAM and FastSLAM 2.0 units against independent computations (faultlab.slam.ekfunits)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import multivariate_normal

from faultlab.slam import FastSlamConfig
from faultlab.slam import units as U
from faultlab.slam import ekfunits as U2

Q = FastSlamConfig().Q
M = np.diag([0.1 ** 2, math.radians(20) ** 2])


def _poses(rng, n):
    return np.column_stack([rng.uniform(-3, 3, n), rng.uniform(-3, 3, n), rng.uniform(-math.pi, math.pi, n)])


def _landmarks(rng, poses, k):
    a = rng.uniform(-math.pi, math.pi, (poses.shape[0], k))
    return poses[:, None, :2] + rng.uniform(0.3, 2.0, a.shape + (1,)) * np.stack([np.cos(a), np.sin(a)], -1)


def _spd(rng, shape, d, scale=0.05):
    A = rng.normal(size=shape + (d, d))
    return A @ np.swapaxes(A, -1, -2) * scale + 0.01 * np.eye(d)


def _numeric_jacobian(f, x, eps=1e-6):
    """Central differences of f: (..., d) -> (..., m) w.r.t. the last axis of x: (..., m, d)."""
    cols = []
    for j in range(x.shape[-1]):
        step = np.zeros(x.shape[-1])
        step[j] = eps
        cols.append((f(x + step) - f(x - step)) / (2 * eps))
    return np.stack(cols, axis=-1)


# -- shared Jacobians ----------------------------------------------------------------------------


def test_motion_jacobians_against_finite_differences_of_the_motion_model():
    rng = np.random.default_rng(0)
    poses, u = _poses(rng, 6), np.column_stack([rng.uniform(-1, 1, 6), rng.uniform(-0.5, 0.5, 6)])
    G, V = U2.motion_jacobians(poses, u)
    no_wrap = lambda a: a  # noqa: E731  (differentiate away from the wrap's jump)
    G_num = _numeric_jacobian(lambda p: U.motion_model(p, u, wrap=no_wrap), poses)
    V_num = _numeric_jacobian(lambda c: U.motion_model(poses, c, wrap=no_wrap), u)
    np.testing.assert_allclose(G, G_num, atol=1e-8)
    np.testing.assert_allclose(V, V_num, atol=1e-8)
    # the motion is linear in the control: g(x, u + du) = g(x, u) + V du exactly (up to rounding)
    du = rng.normal(size=u.shape)
    np.testing.assert_allclose(U.motion_model(poses, u + du, wrap=no_wrap),
                               U.motion_model(poses, u, wrap=no_wrap) + (V @ du[..., None])[..., 0], atol=1e-12)


def test_pose_jacobian_against_finite_differences_of_the_measurement():
    rng = np.random.default_rng(1)
    poses = _poses(rng, 4)
    mu = _landmarks(rng, poses, 3)
    _, H = U.predict_measurement(poses, mu)
    Hx = U2.pose_jacobian(H)
    assert Hx.shape == (4, 3, 2, 3)
    num = np.zeros_like(Hx)
    for i in range(4):
        for j in range(3):
            def z(pose):
                return U.predict_measurement(pose[None], mu[i:i + 1, j:j + 1])[0][0, 0]
            for c, e in enumerate(np.eye(3) * 1e-6):
                num[i, j, :, c] = (z(poses[i] + e) - z(poses[i] - e)) / 2e-6
    np.testing.assert_allclose(Hx, num, atol=1e-7)


# -- EKF-SLAM -----------------------------------------------------------------------------------


def _ekf_case(seed, n_lm=5, k=3):
    rng = np.random.default_rng(seed)
    D = 3 + 2 * n_lm
    Sigma = _spd(rng, (), D, scale=0.1)
    mu = np.concatenate([_poses(rng, 1)[0], rng.uniform(-3, 3, 2 * n_lm)])
    cols = rng.choice(n_lm, size=k, replace=False)
    return rng, mu, Sigma, 3 + 2 * cols


def _dense_H(D, idx, Hx, Hm):
    H = np.zeros((2 * len(idx), D))
    for i, j in enumerate(idx):
        H[2 * i:2 * i + 2, :3] = Hx[i]
        H[2 * i:2 * i + 2, j:j + 2] = Hm[i]
    return H


def test_predict_covariance_is_the_dense_prediction():
    rng, mu, Sigma, _ = _ekf_case(2)
    D = Sigma.shape[0]
    u = np.array([[0.7, 0.2]])
    G, V = U2.motion_jacobians(mu[None, :3], u)
    Sxx, Sxm = U2.predict_covariance(Sigma[:3, :3], Sigma[:3, 3:], G[0], V[0], M)
    Gfull = np.eye(D)
    Gfull[:3, :3] = G[0]
    F = np.zeros((3, D))
    F[:, :3] = np.eye(3)
    ref = Gfull @ Sigma @ Gfull.T + F.T @ V[0] @ M @ V[0].T @ F
    np.testing.assert_allclose(Sxx, ref[:3, :3], rtol=1e-12)
    np.testing.assert_allclose(Sxm, ref[:3, 3:], rtol=1e-12)
    np.testing.assert_allclose(ref[3:, 3:], Sigma[3:, 3:], rtol=0)  # the map block does not change
    assert np.array_equal(Sxx, Sxx.T)
    # an empty update (v = omega = 0, no noise) changes nothing, bit for bit
    G0, V0 = U2.motion_jacobians(mu[None, :3], np.zeros((1, 2)))
    Sxx0, Sxm0 = U2.predict_covariance(Sigma[:3, :3], Sigma[:3, 3:], G0[0], V0[0], np.zeros((2, 2)))
    assert np.array_equal(Sxx0, Sigma[:3, :3]) and np.array_equal(Sxm0, Sigma[:3, 3:])


def test_sparse_gain_terms_equal_the_dense_textbook_update():
    rng, mu, Sigma, idx = _ekf_case(3)
    D = Sigma.shape[0]
    lm = mu[idx[:, None] + np.arange(2)]
    zhat, Hm = U.predict_measurement(mu[None, :3], lm[None])
    Hx = U2.pose_jacobian(Hm)[0]
    Hm = Hm[0]
    H = _dense_H(D, idx, Hx, Hm)
    PHt = U2.cross_covariance(Sigma, idx, Hx, Hm)
    np.testing.assert_allclose(PHt, Sigma @ H.T, rtol=1e-12, atol=1e-14)
    S = U2.joint_innovation_covariance(PHt, idx, Hx, Hm, Q)
    np.testing.assert_allclose(S, H @ Sigma @ H.T + np.kron(np.eye(len(idx)), Q), rtol=1e-12, atol=1e-14)
    assert np.array_equal(S, S.T)
    nu = rng.normal(scale=0.2, size=2 * len(idx))
    mu1, Sigma1 = U2.kalman_update(mu, Sigma, PHt, S, nu)
    K = Sigma @ H.T @ np.linalg.inv(S)
    np.testing.assert_allclose(mu1, mu + K @ nu, rtol=1e-11, atol=1e-13)
    np.testing.assert_allclose(Sigma1, (np.eye(D) - K @ H) @ Sigma, rtol=1e-9, atol=1e-13)
    assert np.array_equal(Sigma1, Sigma1.T)
    assert np.all(np.linalg.eigvalsh(Sigma1) > 0)
    assert not np.shares_memory(Sigma1, Sigma) and not np.shares_memory(mu1, mu)


def test_augment_state_is_the_linearised_inverse_measurement_model():
    rng, mu, Sigma, _ = _ekf_case(4, n_lm=2, k=1)
    D = Sigma.shape[0]
    z = np.column_stack([rng.uniform(0.3, 2, 3), rng.uniform(-3, 3, 3)])
    lm, P = U.init_landmarks(mu[None, :3], z, Q, wrap=U.wrap_bearing)
    mu2, Sigma2 = U2.augment_state(mu, Sigma, lm[0], P[0])
    np.testing.assert_array_equal(mu2[:D], mu)
    np.testing.assert_allclose(mu2[D:], lm[0].ravel())

    # dense reference: Jacobians of m(pose, z) by finite differences, Sigma' = T Sigma T^T + J Q J^T
    def inverse_model(pose, zz):
        return U.init_landmarks(pose[None], zz, Q, wrap=U.wrap_bearing)[0][0].ravel()

    eps = 1e-6
    Jx = np.column_stack([(inverse_model(mu[:3] + e, z) - inverse_model(mu[:3] - e, z)) / (2 * eps)
                          for e in np.eye(3) * eps])
    Jz = np.zeros((6, 6))
    for j in range(6):
        dz = np.zeros(6)
        dz[j] = eps
        dz = dz.reshape(3, 2)
        Jz[:, j] = (inverse_model(mu[:3], z + dz) - inverse_model(mu[:3], z - dz)) / (2 * eps)
    T = np.zeros((D + 6, D))
    T[:D] = np.eye(D)
    T[D:, :3] = Jx
    ref = T @ Sigma @ T.T
    ref[D:, D:] += Jz @ np.kron(np.eye(3), Q) @ Jz.T
    np.testing.assert_allclose(Sigma2, ref, rtol=1e-6, atol=1e-9)
    assert np.array_equal(Sigma2, Sigma2.T)


# -- FastSLAM 2.0 proposal ----------------------------------------------------------------------


def _proposal_case(seed, n=4, k=3):
    rng = np.random.default_rng(seed)
    poses = _poses(rng, n)
    mu = _landmarks(rng, poses, k)
    P = _spd(rng, (n, k), 2)
    _, H = U.predict_measurement(poses, mu)
    Z = U.innovation_covariance(H, P, Q)
    nu = rng.normal(scale=0.2, size=(n, k, 2))
    known = rng.random((n, k)) < 0.7
    _, V = U2.motion_jacobians(poses, np.zeros((n, 2)))
    return rng, U2.pose_jacobian(H), V, Z, nu, known


def test_proposal_information_sums_over_the_known_pairs():
    _, Hx, V, Z, nu, known = _proposal_case(5)
    lam, eta = U2.proposal_information(Hx, V, Z, nu, known)
    for i in range(Hx.shape[0]):
        ref_lam, ref_eta = np.zeros((2, 2)), np.zeros(2)
        for j in range(Hx.shape[1]):
            if known[i, j]:
                Hu = Hx[i, j] @ V[i]
                Zi = np.linalg.inv(Z[i, j])
                ref_lam += Hu.T @ Zi @ Hu
                ref_eta += Hu.T @ Zi @ nu[i, j]
        np.testing.assert_allclose(lam[i], ref_lam, rtol=1e-10, atol=1e-12)
        np.testing.assert_allclose(eta[i], ref_eta, rtol=1e-10, atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from(["full", "no_v", "no_omega"]))
def test_proposal_is_the_kalman_posterior_of_the_control_noise(seed, noise):
    """cov, mean and the weight correction against the dense Kalman form and scipy's Gaussian."""
    rng, Hx, V, Z, nu, known = _proposal_case(seed, n=3, k=3)
    Mx = {"full": M, "no_v": np.diag([0.0, M[1, 1]]), "no_omega": np.diag([M[0, 0], 0.0])}[noise]
    lam, eta = U2.proposal_information(Hx, V, Z, nu, known)
    mean, cov = U2.proposal(lam, eta, Mx)
    corr = U2.proposal_correction(lam, eta, cov, Mx)
    assert np.array_equal(cov[:, 0, 1], cov[:, 1, 0])
    for i in range(Hx.shape[0]):
        j = np.flatnonzero(known[i])
        if not j.size:
            np.testing.assert_allclose(cov[i], Mx, atol=1e-15)
            assert mean[i].tolist() == [0.0, 0.0] and corr[i] == 0.0
            continue
        Hu = np.concatenate([Hx[i, jj] @ V[i] for jj in j])  # (2m, 2)
        Zb = np.zeros((2 * j.size, 2 * j.size))
        for r, jj in enumerate(j):
            Zb[2 * r:2 * r + 2, 2 * r:2 * r + 2] = Z[i, jj]
        v = nu[i, j].ravel()
        L = Hu @ Mx @ Hu.T + Zb
        Li = np.linalg.inv(L)
        np.testing.assert_allclose(cov[i], Mx - Mx @ Hu.T @ Li @ Hu @ Mx, rtol=1e-8, atol=1e-14)
        np.testing.assert_allclose(mean[i], Mx @ Hu.T @ Li @ v, rtol=1e-8, atol=1e-14)
        joint = multivariate_normal(np.zeros(v.size), L).logpdf(v)
        per_landmark = sum(multivariate_normal(np.zeros(2), Z[i, jj]).logpdf(nu[i, jj]) for jj in j)
        assert corr[i] == pytest.approx(joint - per_landmark, rel=1e-8, abs=1e-10)
        if noise == "full":  # Table 13.2's information form for an invertible noise covariance
            np.testing.assert_allclose(cov[i], np.linalg.inv(np.linalg.inv(Mx) + Hu.T @ np.linalg.inv(Zb) @ Hu),
                                       rtol=1e-8)


def test_sample_proposal_uses_one_standard_normal_draw_and_the_cholesky_factor():
    rng, Hx, V, Z, nu, known = _proposal_case(6, n=5)
    mean, cov = U2.proposal(*U2.proposal_information(Hx, V, Z, nu, known), M)
    g = np.random.default_rng(11)
    du = U2.sample_proposal(mean, cov, g)
    ref = np.random.default_rng(11)
    eps = ref.standard_normal((5, 2))
    assert g.bit_generator.state == ref.bit_generator.state
    expected = mean + np.einsum("nij,nj->ni", np.linalg.cholesky(cov), eps)
    np.testing.assert_allclose(du, expected, rtol=1e-12, atol=1e-15)
    # singular covariance (no turn noise): the turn is the mean, the zero pivot gives no NaN
    cov0 = cov.copy()
    cov0[:, 1, :] = cov0[:, :, 1] = 0.0
    du0 = U2.sample_proposal(mean, cov0, np.random.default_rng(11))
    np.testing.assert_array_equal(du0[:, 1], mean[:, 1])


def test_without_known_landmarks_the_proposal_is_fastslam1s_motion_noise():
    n = 50
    lam, eta = np.zeros((n, 2, 2)), np.zeros((n, 2))
    mean, cov = U2.proposal(lam, eta, M)
    np.testing.assert_array_equal(cov, np.broadcast_to(M, (n, 2, 2)))
    assert not mean.any() and not U2.proposal_correction(lam, eta, cov, M).any()
    u = np.array([0.8, -0.1])
    du = U2.sample_proposal(mean, cov, np.random.default_rng(4))
    ref = U.sample_controls(u, n, np.random.default_rng(4), FastSlamConfig())
    np.testing.assert_allclose(u + du, ref, rtol=1e-15, atol=1e-15)


def test_proposal_correction_vanishes_for_a_deterministic_motion():
    """With M = 0 the pose is known and the weight is FastSLAM 1.0's product of likelihoods."""
    _, Hx, V, Z, nu, known = _proposal_case(7)
    lam, eta = U2.proposal_information(Hx, V, Z, nu, known)
    mean, cov = U2.proposal(lam, eta, np.zeros((2, 2)))
    assert not cov.any() and not mean.any()
    np.testing.assert_array_equal(U2.proposal_correction(lam, eta, cov, np.zeros((2, 2))), 0.0)
