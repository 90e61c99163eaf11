"""ATE after rigid alignment without scale, checked against evo's APE (translation part) and a planted motion."""

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from faultlab.errors import SlamOutputError
from faultlab.metrics.trajectory import absolute_trajectory_error, align_rigid, trajectory_error_mm

evo_metrics = pytest.importorskip("evo.core.metrics")
evo_trajectory = pytest.importorskip("evo.core.trajectory")


def _evo_ape_rmse(ref: np.ndarray, est: np.ndarray) -> tuple[float, np.ndarray]:
    """evo: both trajectories as PoseTrajectory3D, est.align(ref) without scale, APE on the translation part."""
    n = ref.shape[0]
    pad = (lambda p: np.column_stack([p, np.zeros(n)])) if ref.shape[1] == 2 else (lambda p: p)
    quat = np.tile([1.0, 0, 0, 0], (n, 1))
    stamps = np.arange(n, dtype=float)
    t_ref = evo_trajectory.PoseTrajectory3D(positions_xyz=pad(ref), orientations_quat_wxyz=quat, timestamps=stamps)
    t_est = evo_trajectory.PoseTrajectory3D(positions_xyz=pad(est), orientations_quat_wxyz=quat.copy(),
                                            timestamps=stamps)
    t_est.align(t_ref, correct_scale=False)
    ape = evo_metrics.APE(evo_metrics.PoseRelation.translation_part)
    ape.process_data((t_ref, t_est))
    return ape.get_statistic(evo_metrics.StatisticsType.rmse), ape.error


def _walk(rng, n: int, d: int) -> np.ndarray:
    return np.cumsum(rng.normal(0, 0.3, (n, d)), axis=0)


@pytest.mark.parametrize("d", [2, 3])
@pytest.mark.parametrize("seed", range(5))
def test_ate_equals_evo_ape_to_1e_9(d, seed):
    rng = np.random.default_rng(seed)
    ref = _walk(rng, 200, d)
    if d == 2:
        a = rng.uniform(-np.pi, np.pi)
        rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    else:
        rot = Rotation.random(random_state=seed).as_matrix()
    est = (ref + rng.normal(0, 0.05, ref.shape)) @ rot.T + rng.normal(0, 5, d)
    ours = absolute_trajectory_error(ref, est)
    rmse, errors = _evo_ape_rmse(ref, est)
    assert abs(ours.rmse - rmse) <= 1e-9
    np.testing.assert_allclose(ours.errors, errors, rtol=0, atol=1e-9)
    assert ours.max == pytest.approx(errors.max(), abs=1e-9)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2 ** 32 - 1), d=st.sampled_from([2, 3]), n=st.integers(3, 50))
def test_a_planted_rigid_motion_is_undone_exactly(seed, d, n):
    rng = np.random.default_rng(seed)
    ref = rng.normal(0, 3, (n, d))
    rot = Rotation.random(random_state=seed).as_matrix()[:d, :d] if d == 3 else None
    if d == 2:
        a = rng.uniform(-np.pi, np.pi)
        rot = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
    shift = rng.normal(0, 10, d)
    est = (ref - shift) @ rot  # ref = est @ rot.T + shift
    r, t = align_rigid(ref, est)
    np.testing.assert_allclose(r, rot, atol=1e-9)
    np.testing.assert_allclose(t, shift, atol=1e-8)
    assert absolute_trajectory_error(ref, est).rmse < 1e-8
    assert np.linalg.det(r) == pytest.approx(1.0)


def test_a_mirrored_trajectory_is_not_fitted_by_a_reflection():
    ref = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 2.0], [0.0, 3.0]])
    mirrored = ref * [1.0, -1.0]
    err = absolute_trajectory_error(ref, mirrored)
    assert np.linalg.det(err.rotation) == pytest.approx(1.0)
    assert err.rmse > 0.5


def test_mismatched_or_non_finite_trajectories_are_refused():
    with pytest.raises(SlamOutputError, match="same shape"):
        absolute_trajectory_error(np.zeros((3, 2)), np.zeros((4, 2)))
    with pytest.raises(SlamOutputError, match="not finite"):
        absolute_trajectory_error(np.zeros((3, 2)), np.full((3, 2), np.nan))
    with pytest.raises(SlamOutputError, match=r"\(N, 2\) or \(N, 3\)"):
        absolute_trajectory_error(np.zeros((3, 4)), np.zeros((3, 4)))


# --------------------------------------------------------------------------- a job's ATE column

def _case(true_poses):
    from types import SimpleNamespace

    return SimpleNamespace(true_poses=np.asarray(true_poses, dtype=float))


def _estimate(trajectory):
    from faultlab.slam import Estimate

    return Estimate(np.zeros(3), np.empty(0, dtype=np.int64), np.empty((0, 2)), trajectory=trajectory)


@settings(max_examples=30, deadline=None)
@given(st.integers(10, 40), st.integers(0, 2 ** 32 - 1))
def test_the_job_ate_is_evos_ape_of_the_trajectory_against_the_poses_after_each_step(n, seed):
    # evo aligns in SE(3): on planar points a half turn about an in-plane axis (a mirror image in the
    # plane) can beat every planar rotation when the points are few and noisy; here it cannot
    rng = np.random.default_rng(seed)
    truth = np.column_stack([np.cumsum(rng.normal(0, 1, (n + 1, 2)), axis=0), rng.uniform(-3, 3, n + 1)])
    traj = truth[1:] + np.column_stack([rng.normal(0, 0.05, (n, 2)), rng.normal(0, 0.1, n)])
    rmse, _ = _evo_ape_rmse(truth[1:, :2], traj[:, :2])
    assert trajectory_error_mm(_case(truth), _estimate(traj)) == pytest.approx(1000 * rmse, rel=1e-9, abs=1e-9)


def test_a_planted_offset_off_a_straight_line_is_the_error():
    # truth at constant speed along a line; the estimate off it by d, signs + - - + repeating: the signs
    # sum to zero and cancel against the positions, so no rigid motion does better than the identity
    n, d = 40, 0.3
    t = np.arange(n + 1, dtype=float)
    heading = 0.7
    truth = np.column_stack([2 + t * np.cos(heading), -1 + t * np.sin(heading), np.full(n + 1, heading)])
    signs = np.tile([1.0, -1.0, -1.0, 1.0], n // 4)
    normal = np.array([-np.sin(heading), np.cos(heading)])
    traj = truth[1:].copy()
    traj[:, :2] += d * signs[:, None] * normal
    assert trajectory_error_mm(_case(truth), _estimate(traj)) == pytest.approx(1000 * d, abs=1e-9)


def test_no_trajectory_or_a_diverged_one_is_nan_and_a_wrong_length_is_refused():
    truth = np.zeros((6, 3))
    truth[:, 0] = np.arange(6)
    assert np.isnan(trajectory_error_mm(_case(truth), _estimate(None)))
    bad = truth[1:].copy()
    bad[2, 1] = np.inf
    assert np.isnan(trajectory_error_mm(_case(truth), _estimate(bad)))
    assert np.isnan(trajectory_error_mm(_case(truth[:1]), _estimate(np.zeros((0, 3)))))
    with pytest.raises(SlamOutputError, match=r"one pose \(x, y, theta\) per step, shape \(5, 3\), got \(6, 3\)"):
        trajectory_error_mm(_case(truth), _estimate(truth))
