import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import minimize
from scipy.spatial.transform import Rotation

from faultlab.errors import ScenarioError, SlamOutputError
from faultlab.metrics import kabsch_rms


def rot(theta):
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s], [s, c]])


def brute_force_rms(p, q):
    """Independent reference: minimise the RMS over (theta, tx, ty) numerically, multi-start in theta."""
    def cost(x):
        r = q @ rot(x[0]).T + x[1:] - p
        return np.mean(np.sum(r * r, axis=1))

    best = min((minimize(cost, [t0, 0.0, 0.0], method="BFGS", options={"gtol": 1e-12})
                for t0 in np.linspace(-np.pi, np.pi, 8, endpoint=False)), key=lambda r: r.fun)
    return np.sqrt(best.fun), best.x


def test_matches_numerical_minimiser_on_noisy_map():
    rng = np.random.default_rng(1)
    p = rng.uniform(0, 8, size=(25, 2))
    q = (p + rng.normal(scale=0.3, size=p.shape)) @ rot(2.1).T + [5.0, -3.0]
    err = kabsch_rms(np.arange(25), p, np.arange(25), q)
    ref_rms, ref_x = brute_force_rms(p, q)
    np.testing.assert_allclose(err.rms, ref_rms, rtol=1e-6)
    np.testing.assert_allclose(err.angle, (ref_x[0] + np.pi) % (2 * np.pi) - np.pi, atol=1e-5)
    np.testing.assert_allclose(err.translation, ref_x[1:], atol=1e-5)
    assert err.n_mapped == 25 and err.n_unmapped == 0


def test_rotation_is_proper_and_alignment_recovers_exact_motion():
    rng = np.random.default_rng(2)
    p = rng.normal(size=(10, 2))
    r_true, t_true = rot(-0.4), np.array([1.0, 2.0])
    q = (p - t_true) @ r_true  # p = R q + t
    err = kabsch_rms(np.arange(10), p, np.arange(10), q)
    np.testing.assert_allclose(err.rotation, r_true, atol=1e-12)
    np.testing.assert_allclose(err.translation, t_true, atol=1e-12)
    np.testing.assert_allclose(err.apply(q), p, atol=1e-12)
    np.testing.assert_allclose(np.linalg.det(err.rotation), 1.0)
    np.testing.assert_allclose(err.rms, 0.0, atol=1e-12)


@settings(max_examples=40, deadline=None)
@given(theta=st.floats(-np.pi, np.pi), tx=st.floats(-1e3, 1e3), ty=st.floats(-1e3, 1e3),
       seed=st.integers(0, 2**32 - 1))
def test_invariant_under_rigid_motion_of_estimate(theta, tx, ty, seed):
    rng = np.random.default_rng(seed)
    n = int(rng.integers(2, 30))
    p = rng.uniform(-10, 10, size=(n, 2))
    q = p + rng.normal(scale=0.5, size=p.shape)
    ids = rng.permutation(n) + 100
    base = kabsch_rms(ids, p, ids, q)
    moved = kabsch_rms(ids, p, ids, q @ rot(theta).T + [tx, ty])
    np.testing.assert_allclose(moved.rms, base.rms, rtol=1e-7, atol=1e-9)


def test_reflected_set_cannot_be_fitted_by_a_proper_rotation():
    rng = np.random.default_rng(3)
    p = rng.uniform(0, 5, size=(12, 2))
    q = p * [-1.0, 1.0]  # a mirror image: only a reflection would fit it
    err = kabsch_rms(np.arange(12), p, np.arange(12), q)
    ref_rms, _ = brute_force_rms(p, q)
    assert err.rms > 0.1
    np.testing.assert_allclose(err.rms, ref_rms, rtol=1e-6)
    np.testing.assert_allclose(np.linalg.det(err.rotation), 1.0)
    # Why Rotation.align_vectors is not used: in 3-D the mirror is a half turn and fits exactly.
    r3, _ = Rotation.align_vectors(np.c_[p - p.mean(0), np.zeros(12)], np.c_[q - q.mean(0), np.zeros(12)])
    fitted = r3.apply(np.c_[q - q.mean(0), np.zeros(12)])[:, :2] + p.mean(0)
    np.testing.assert_allclose(fitted, p, atol=1e-9)


def test_matching_is_by_id_not_by_order_and_unmapped_are_excluded():
    rng = np.random.default_rng(4)
    truth_ids = np.array([10, 11, 12, 13, 14, 15])
    p = rng.normal(size=(6, 2))
    sub = np.array([4, 0, 2, 5])
    q = p[sub] + rng.normal(scale=0.2, size=(4, 2))
    err = kabsch_rms(truth_ids, p, truth_ids[sub], q)
    ref_rms, _ = brute_force_rms(p[sub], q)
    np.testing.assert_allclose(err.rms, ref_rms, rtol=1e-6)
    assert (err.n_mapped, err.n_unmapped) == (4, 2)


def test_two_points_hand_computed():
    # Distances 2 and 3: the best fit leaves each endpoint 0.5 off along the line.
    err = kabsch_rms([1, 2], [[0, 0], [2, 0]], [1, 2], [[5, 5], [5, 8]])
    np.testing.assert_allclose(err.rms, 0.5)


def test_zero_and_one_mapped():
    p = np.array([[0.0, 0.0], [1.0, 2.0], [3.0, 1.0]])
    none = kabsch_rms([1, 2, 3], p, np.empty(0, dtype=int), np.empty((0, 2)))
    assert np.isnan(none.rms) and (none.n_mapped, none.n_unmapped) == (0, 3)
    one = kabsch_rms([1, 2, 3], p, [2], [[40.0, -7.0]])
    assert one.rms == 0.0 and (one.n_mapped, one.n_unmapped) == (1, 2)
    np.testing.assert_allclose(one.apply([[40.0, -7.0]]), [[1.0, 2.0]])


def test_errors_name_the_problem():
    p = np.zeros((3, 2)) + np.arange(3)[:, None]
    with pytest.raises(SlamOutputError, match="landmark id 99"):
        kabsch_rms([1, 2, 3], p, [1, 99], [[0, 0], [1, 1]])
    with pytest.raises(SlamOutputError, match="id 2 appears more than once"):
        kabsch_rms([1, 2, 3], p, [2, 2], [[0, 0], [1, 1]])
    with pytest.raises(SlamOutputError, match="landmark 3 has a non-finite"):
        kabsch_rms([1, 2, 3], p, [1, 3], [[0, 0], [np.nan, 1]])
    with pytest.raises(SlamOutputError, match="shape"):
        kabsch_rms([1, 2, 3], p, [1, 2], [[0, 0, 0], [1, 1, 1]])
    with pytest.raises(ScenarioError, match="ground-truth landmark id 1 appears"):
        kabsch_rms([1, 1, 3], p, [1], [[0, 0]])
    with pytest.raises(ScenarioError, match="integers"):
        kabsch_rms([1.5, 2, 3], p, [2], [[0, 0]])
