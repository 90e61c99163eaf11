"""The built-in faults do exactly what their descriptions say (checked against independent code)."""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.faults import all_faults, get_fault
from faultlab.faults.builtin import BUILTIN_FAULTS, PAPER_FAULTS, in_place_ancestors
from faultlab.faults.check import outputs_equal, unit_outputs
from faultlab.slam import REFERENCE_STEPS, FastSlamConfig, FastSlamSteps, ParticleState

CFG = FastSlamConfig()
Q = CFG.Q


def faulty(name):
    f = get_fault(name)
    return getattr(f.patch(REFERENCE_STEPS), f.step)


def wrap(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


def h(pose, m):
    """Range-bearing measurement of landmark m from pose (independent of faultlab)."""
    dx, dy = m[0] - pose[0], m[1] - pose[1]
    return np.array([math.hypot(dx, dy), math.atan2(dy, dx) - pose[2]])


def numeric_jacobian(pose, m, eps=1e-6):
    J = np.empty((2, 2))
    for j in range(2):
        d = np.zeros(2)
        d[j] = eps
        J[:, j] = (h(pose, m + d) - h(pose, m - d)) / (2 * eps)
    return J


# --------------------------------------------------------------------------- generic (cosmic-ray style)

EXAMPLES = [(f.name, i) for f in all_faults() for i in range(len(f.examples))]


@pytest.mark.parametrize("name, i", EXAMPLES)
def test_every_fault_example_kills_the_mutant_at_unit_level(name, i):
    f = get_fault(name)
    original, mutated = unit_outputs(f, f.examples[i])
    assert not outputs_equal(original, mutated), f"{name}: example {f.examples[i].note!r} is not affected"


def test_every_builtin_fault_has_an_example_and_its_own_replacement():
    assert len(BUILTIN_FAULTS) >= 11 and [f.name for f in PAPER_FAULTS] == [
        "naive_resampling", "missing_angle_wrap", "motion_sign_error"]
    for f in BUILTIN_FAULTS:
        assert f.examples, f.name
        patched = f.patch(REFERENCE_STEPS)
        assert patched.replaced() == (f.step,), f.name
    assert REFERENCE_STEPS.replaced() == ()  # nothing leaked into the reference table


# --------------------------------------------------------------------------- the paper's three

def test_naive_resampling_is_multinomial_at_every_update_without_neff_test():
    w = np.array([0.1, 0.4, 0.2, 0.3])
    unit = faulty("naive_resampling")
    for empty, n_eff in ((True, 4.0), (False, 4.0), (False, 1.0)):
        idx = unit(w, n_eff, empty, np.random.default_rng(3), CFG)
        # independent multinomial draw with the same uniforms: first i with cumsum(w)[i] > u
        u = np.random.default_rng(3).random(4)
        expected = [next(i for i, c in enumerate(np.cumsum(w)) if c > x) for x in u]
        np.testing.assert_array_equal(idx, expected)
    # frequencies follow the weights (multinomial, not systematic)
    counts = np.bincount(unit(w / w.sum(), 1.0, True, np.random.default_rng(0), CFG), minlength=4)
    assert counts.sum() == 4
    big = np.random.default_rng(1)
    w2 = np.array([0.5, 0.25, 0.25])
    draws = np.concatenate([unit(w2, 3.0, True, big, CFG) for _ in range(2000)])
    np.testing.assert_allclose(np.bincount(draws) / draws.size, w2, atol=0.02)
    assert REFERENCE_STEPS.resample(np.full(4, 0.25), 4.0, True, np.random.default_rng(0), CFG) is None


def test_missing_angle_wrap_is_the_identity_where_the_reference_wraps():
    a = np.array([-7.0, -math.pi - 0.1, 0.3, math.pi + 0.2, 9.0])
    np.testing.assert_array_equal(faulty("missing_angle_wrap")(a), a)
    np.testing.assert_allclose(REFERENCE_STEPS.wrap_bearing(a), wrap(a))


def test_motion_sign_error_subtracts_b_u():
    rng = np.random.default_rng(0)
    poses = rng.uniform(-3, 3, (5, 3))
    u = rng.uniform(-1, 1, (5, 2))
    out = faulty("motion_sign_error")(poses, u, wrap=REFERENCE_STEPS.wrap_heading)
    th = poses[:, 2]
    expected = np.stack([poses[:, 0] - u[:, 0] * np.cos(th), poses[:, 1] - u[:, 0] * np.sin(th),
                         wrap(th - u[:, 1])], axis=1)
    np.testing.assert_allclose(out, expected, atol=1e-12)


# --------------------------------------------------------------------------- resampling faults

def _python_in_place_resampling(indices):
    """PythonRobotics-style loop: tmp = particles[:] (shallow) and in-place attribute copies."""

    class P:
        def __init__(self, origin):
            self.origin = origin

    particles = [P(i) for i in range(len(indices))]
    tmp = particles[:]
    for i, j in enumerate(indices):
        particles[i].origin = tmp[j].origin
    return np.array([p.origin for p in particles])


@settings(max_examples=200, deadline=None)
@given(st.lists(st.integers(0, 11), min_size=12, max_size=12), st.booleans())
def test_in_place_ancestors_match_the_shallow_copy_loop(indices, sort):
    idx = np.array(sorted(indices) if sort else indices)
    np.testing.assert_array_equal(in_place_ancestors(idx), _python_in_place_resampling(idx))


def _state(n=4):
    st0 = ParticleState.initial(np.zeros(3), n)
    return dataclasses.replace(st0, poses=np.arange(3.0 * n).reshape(n, 3),
                               logw=np.log(np.arange(1.0, n + 1) / np.sum(np.arange(1.0, n + 1))))


def test_shallow_copy_resampling_shares_the_ancestor_storage_row():
    st0 = _state()
    idx = np.array([1, 0, 0, 3])
    out = faulty("shallow_copy_resampling")(st0, idx)
    eff = np.array([1, 1, 1, 3])  # slot 0 was overwritten by particle 1 before particles 1, 2 read it
    np.testing.assert_array_equal(out.poses, st0.poses[eff])
    np.testing.assert_array_equal(out.owner, eff)  # duplicates write into one shared row
    np.testing.assert_allclose(np.exp(out.logw), 0.25)
    ref = REFERENCE_STEPS.apply_resample(st0, idx)
    np.testing.assert_array_equal(ref.owner, np.arange(4))
    np.testing.assert_array_equal(ref.poses, st0.poses[idx])


def test_inverted_resampling_threshold_resamples_exactly_when_neff_is_high():
    unit = faulty("inverted_resampling_threshold")
    w = np.full(6, 1 / 6)
    threshold = 6 / CFG.resample_ratio
    for n_eff in (1.0, 2.5, 3.9, 4.1, 5.0, 6.0):
        out = unit(w, n_eff, False, np.random.default_rng(0), CFG)
        assert (out is not None) == (n_eff > threshold), n_eff
        ref = REFERENCE_STEPS.resample(w, n_eff, False, np.random.default_rng(0), CFG)
        assert (ref is not None) == (n_eff < threshold), n_eff
    assert unit(w, 6.0, True, np.random.default_rng(0), CFG) is None  # empty updates still never resample


def test_resample_keeps_weights_keeps_the_ancestor_weights():
    st0 = _state()
    idx = np.array([3, 3, 2, 1])
    out = faulty("resample_keeps_weights")(st0, idx)
    w = np.exp(st0.logw)[idx]
    np.testing.assert_allclose(np.exp(out.logw), w / w.sum(), rtol=1e-12)
    np.testing.assert_array_equal(out.poses, st0.poses[idx])


# --------------------------------------------------------------------------- weights

def test_weight_overwritten_keeps_only_the_last_known_observation():
    rng = np.random.default_rng(2)
    logw = np.log(rng.dirichlet(np.ones(5)))
    loglik = rng.normal(size=(5, 4))
    known = rng.random((5, 4)) < 0.5
    known[0] = False
    out = faulty("weight_overwritten")(logw, loglik, known)
    for i in range(5):  # the per-observation loop with w = p instead of w *= p
        w = logw[i]
        for k in range(4):
            if known[i, k]:
                w = loglik[i, k]
        assert out[i] == w


def test_likelihood_without_normaliser_is_only_the_mahalanobis_term():
    rng = np.random.default_rng(4)
    A = rng.normal(size=(3, 2, 2, 2))
    S = A @ np.swapaxes(A, -1, -2) + 0.1 * np.eye(2)
    nu = rng.normal(size=(3, 2, 2))
    out = faulty("likelihood_without_normaliser")(nu, S)
    expected = -0.5 * np.einsum("...i,...i->...", nu, np.linalg.solve(S, nu[..., None])[..., 0])
    np.testing.assert_allclose(out, expected, rtol=1e-10, atol=1e-12)


# --------------------------------------------------------------------------- landmark EKF

def _ekf_case():
    poses = np.array([[0.0, 0.0, 0.3], [1.0, -1.0, -2.0]])
    mu = np.array([[[1.5, 0.7]], [[0.2, 0.9]]])
    P = np.array([[[[0.05, 0.01], [0.01, 0.08]]], [[[0.2, -0.03], [-0.03, 0.1]]]])
    zhat, H = REFERENCE_STEPS.predict_measurement(poses, mu)
    S = REFERENCE_STEPS.innovation_covariance(H, P, Q)
    nu = np.array([[[0.1, -0.05]], [[-0.2, 0.15]]])
    return poses, mu, P, H, S, nu


def test_gain_from_wrong_covariance_uses_s_plus_hpht():
    poses, mu, P, H, S, nu = _ekf_case()
    mu2, P2 = faulty("gain_from_wrong_covariance")(mu, P, H, S, nu)
    for i in range(2):
        Hi, Pi = H[i, 0], P[i, 0]
        S_wrong = 2 * Hi @ Pi @ Hi.T + Q
        K = Pi @ Hi.T @ np.linalg.inv(S_wrong)
        np.testing.assert_allclose(mu2[i, 0], mu[i, 0] + K @ nu[i, 0], atol=1e-12)
        np.testing.assert_allclose(P2[i, 0], (np.eye(2) - K @ Hi) @ Pi, atol=1e-12)
        assert np.all(np.linalg.eigvalsh((P2[i, 0] + P2[i, 0].T) / 2) > 0)  # stays positive definite


def test_frozen_landmark_covariance_moves_the_mean_but_not_the_covariance():
    poses, mu, P, H, S, nu = _ekf_case()
    mu_ref, P_ref = REFERENCE_STEPS.ekf_update(mu, P, H, S, nu)
    mu2, P2 = faulty("frozen_landmark_covariance")(mu, P, H, S, nu)
    np.testing.assert_array_equal(mu2, mu_ref)
    np.testing.assert_array_equal(P2, P)
    assert not np.allclose(P_ref, P)


def test_jacobian_sign_error_negates_the_bearing_row_only():
    poses, mu, *_ = _ekf_case()
    zhat, H = faulty("jacobian_sign_error")(poses, mu)
    for i in range(2):
        J = numeric_jacobian(poses[i], mu[i, 0])
        np.testing.assert_allclose(H[i, 0, 0], J[0], atol=1e-7)
        np.testing.assert_allclose(H[i, 0, 1], -J[1], atol=1e-7)
    np.testing.assert_array_equal(zhat, REFERENCE_STEPS.predict_measurement(poses, mu)[0])


def test_init_covariance_not_inverted_is_g_q_gt():
    poses = np.array([[0.5, -0.2, 1.0], [-1.0, 2.0, -2.5]])
    z = np.array([[1.7, 0.4], [0.6, -1.2]])
    mu, P = faulty("init_covariance_not_inverted")(poses, z, Q, wrap=REFERENCE_STEPS.wrap_bearing)
    mu_ref, P_ref = REFERENCE_STEPS.init_landmarks(poses, z, Q, wrap=REFERENCE_STEPS.wrap_bearing)
    np.testing.assert_array_equal(mu, mu_ref)
    for i in range(2):
        for k in range(2):
            G = numeric_jacobian(poses[i], mu[i, k])
            np.testing.assert_allclose(P[i, k], G @ Q @ G.T, rtol=1e-6, atol=1e-12)
            Gi = np.linalg.inv(G)
            np.testing.assert_allclose(P_ref[i, k], Gi @ Q @ Gi.T, rtol=1e-6)


def test_bearing_in_degrees_initialises_landmarks_almost_straight_ahead():
    poses = np.array([[0.5, -0.2, 1.0]])
    z = np.array([[2.0, 1.2], [1.0, -0.7]])
    mu, _ = faulty("bearing_in_degrees")(poses, z, Q, wrap=REFERENCE_STEPS.wrap_bearing)
    a = poses[0, 2] + np.deg2rad(z[:, 1])
    expected = poses[0, :2] + z[:, :1] * np.stack([np.cos(a), np.sin(a)], axis=1)
    np.testing.assert_allclose(mu[0], expected, atol=1e-12)


def test_new_landmark_near_zero_uses_the_stored_x_only():
    seen = np.array([True, False, True])
    mu = np.array([[[0.01, 5.0], [0.0, 0.0], [0.0101, 1.0]], [[-0.005, 0.0], [3.0, 3.0], [-2.0, 0.0]]])
    out = faulty("new_landmark_near_zero")(seen, mu)
    np.testing.assert_array_equal(out, [[True, True, False], [True, False, False]])
    np.testing.assert_array_equal(REFERENCE_STEPS.classify_new(seen, mu), [[False, True, False]] * 2)


# --------------------------------------------------------------------------- prediction

def test_shared_control_noise_draws_once_for_all_particles():
    u = np.array([0.08, 0.1])
    out = faulty("shared_control_noise")(u, 6, np.random.default_rng(9), CFG)
    eps = np.random.default_rng(9).standard_normal((1, 2))[0]
    np.testing.assert_allclose(out, np.tile(u + eps * [CFG.std_v, CFG.std_omega], (6, 1)), atol=1e-15)
    ref = REFERENCE_STEPS.sample_controls(u, 6, np.random.default_rng(9), CFG)
    assert np.unique(ref[:, 0]).size == 6


def test_turn_before_drive_moves_along_the_new_heading():
    rng = np.random.default_rng(5)
    poses = rng.uniform(-3, 3, (4, 3))
    u = rng.uniform(-1, 1, (4, 2))
    out = faulty("turn_before_drive")(poses, u, wrap=REFERENCE_STEPS.wrap_heading)
    th = poses[:, 2] + u[:, 1]
    expected = np.stack([poses[:, 0] + u[:, 0] * np.cos(th), poses[:, 1] + u[:, 0] * np.sin(th), wrap(th)],
                        axis=1)
    np.testing.assert_allclose(out, expected, atol=1e-12)


def test_faults_do_not_modify_their_inputs():
    poses, mu, P, H, S, nu = _ekf_case()
    copies = [a.copy() for a in (poses, mu, P, H, S, nu)]
    for name in ("gain_from_wrong_covariance", "frozen_landmark_covariance"):
        faulty(name)(mu, P, H, S, nu)
    faulty("jacobian_sign_error")(poses, mu)
    u = np.array([[0.1, 0.2], [0.3, -0.1]])
    u0 = u.copy()
    faulty("turn_before_drive")(poses, u, wrap=REFERENCE_STEPS.wrap_heading)
    faulty("motion_sign_error")(poses, u, wrap=REFERENCE_STEPS.wrap_heading)
    for a, b in zip((poses, mu, P, H, S, nu), copies):
        np.testing.assert_array_equal(a, b)
    np.testing.assert_array_equal(u, u0)
    assert FastSlamSteps() == REFERENCE_STEPS


# --------------------------------------------------------------------------- the paper's aliasing


def test_paper_aliasing_is_the_paper_profiles_shallow_copy_resampling():
    from faultlab.slam import paperunits

    st0 = _state(6)
    idx = np.array([2, 0, 0, 5, 3, 3])
    out = faulty("paper_aliasing")(st0, idx)
    ref = paperunits.apply_resample_aliased(st0, idx)
    eff = np.array([2, 2, 2, 5, 5, 5])  # slots 0 and 3 were overwritten before 1, 2 and 4, 5 read them
    np.testing.assert_array_equal(in_place_ancestors(idx), eff)
    for a in (out, ref):
        np.testing.assert_array_equal(a.poses, st0.poses[eff])
        np.testing.assert_array_equal(a.owner, eff)
        np.testing.assert_array_equal(a.lineage, eff)
        np.testing.assert_allclose(np.exp(a.logw), 1 / 6)
        assert a.sequential_sharers
    # shallow_copy_resampling shares the same rows but lets the sharers update in parallel
    last_wins = faulty("shallow_copy_resampling")(st0, idx)
    np.testing.assert_array_equal(last_wins.owner, eff)
    assert not last_wins.sequential_sharers
