"""Tests of EKF-SLAM (faultlab.slam.ekf)."""

import dataclasses
import functools
import math

import numpy as np
import pytest
from threadpoolctl import threadpool_limits

from faultlab.errors import ConfigError, FaultError, SlamInputError, SlamOutputError
from faultlab.faults import get_fault
from faultlab.metrics import map_errors
from faultlab.scenario import generate_scenario
from faultlab.slam import (
    EKF_REFERENCE_STEPS,
    DeadReckoning,
    EkfSlam,
    EkfSlamConfig,
    EkfSlamSteps,
    FastSlamConfig,
    Observations,
    run_slam,
)
from faultlab.space import FIXED_VALUES, CaseSpec

from tests.slam.ekf_oracle import OracleEkfSlam, run_oracle

TWO_PI = 2.0 * math.pi


def scenario(seed, *, n_steps=200, **values):
    return generate_scenario(CaseSpec(dict(FIXED_VALUES, **values)), rng=np.random.default_rng(seed),
                             n_steps=n_steps)


def rms_mm(sc, est):
    return map_errors(sc, est, metrics=("rms",)).rms_mm


def angle_diff(a, b):
    return (np.asarray(a) - np.asarray(b) + math.pi) % TWO_PI - math.pi


# -- configuration and units -------------------------------------------------------------------


def test_config_defaults_are_fastslams_noise_settings():
    cfg, fs = EkfSlamConfig(), FastSlamConfig()
    assert (cfg.std_v, cfg.std_omega, cfg.std_range, cfg.std_bearing) == (fs.std_v, fs.std_omega, fs.std_range,
                                                                          fs.std_bearing)
    np.testing.assert_array_equal(cfg.Q, fs.Q)
    np.testing.assert_allclose(cfg.M, np.diag([0.01, math.radians(20) ** 2]))


@pytest.mark.parametrize("kwargs, message", [
    (dict(std_v=-0.1), "std_v must be >= 0"),
    (dict(std_omega=float("nan")), "std_omega must be finite"),
    (dict(std_range=0.0), "std_range must be > 0"),
    (dict(std_bearing="x"), "std_bearing must be a number"),
    (dict(std_v=True), "std_v must be a number"),
])
def test_config_rejects_bad_values(kwargs, message):
    with pytest.raises(ConfigError, match=message):
        EkfSlamConfig(**kwargs)


def test_steps_reuse_fastslam1_units_and_name_the_new_ones():
    from faultlab.slam import REFERENCE_STEPS as FS1

    names = EkfSlamSteps.unit_names()
    shared = {"motion_model", "wrap_heading", "wrap_bearing", "predict_measurement", "innovation", "init_landmarks"}
    assert shared <= set(names)
    for name in shared:  # the very same functions: a fault on one of them applies to both SLAMs
        assert getattr(EKF_REFERENCE_STEPS, name) is getattr(FS1, name)
    assert {"motion_jacobians", "predict_covariance", "pose_jacobian", "cross_covariance",
            "joint_innovation_covariance", "kalman_update", "augment_state"} <= set(names)
    assert EKF_REFERENCE_STEPS.replaced() == ()
    with pytest.raises(ConfigError, match="kalman_update"):
        dataclasses.replace(EKF_REFERENCE_STEPS, kalman_update=None)
    with pytest.raises(ConfigError, match="EkfSlamSteps"):
        EkfSlam(steps=FS1)
    with pytest.raises(ConfigError, match="EkfSlamConfig"):
        EkfSlam(FastSlamConfig())


# -- equivalence with the dense-matrix oracle ---------------------------------------------------


def _compare_with_oracle(sc, cfg=EkfSlamConfig()):
    slam = EkfSlam(cfg)
    slam.reset(sc.start_pose, rng=np.random.default_rng(0))
    oracle = OracleEkfSlam(cfg.std_v, cfg.std_omega, cfg.std_range, cfg.std_bearing)
    worst = {"pose": 0.0, "map": 0.0, "cov": 0.0}

    def check(t):
        slam.step(sc.controls[t], Observations(*sc.observations(t)))
        assert slam.landmark_ids.tolist() == oracle.landmark_ids()
        mu, om = slam.mean, oracle.mu
        worst["pose"] = max(worst["pose"], np.abs(mu[:2] - om[:2]).max(), abs(angle_diff(mu[2], om[2])))
        worst["map"] = max(worst["map"], np.abs(mu[3:] - om[3:]).max(initial=0.0))
        worst["cov"] = max(worst["cov"], np.abs(slam.covariance - oracle.Sigma).max())

    with threadpool_limits(limits=1, user_api="blas"):  # the oracle's dense algebra, on a shared machine
        run_oracle(oracle, sc, callback=check)
    for what, err in worst.items():
        assert err < 1e-9, f"{what} differs from the oracle by {err}"
    return slam


def test_matches_dense_oracle_with_inactivity():
    sc = scenario(3, n_steps=60, landmark_density=1.0, inactivity=15)
    slam = _compare_with_oracle(sc)
    assert slam.landmark_ids.size > 20  # landmarks were added along the way


def test_matches_dense_oracle_on_a_loop_with_full_fov_and_rotation_error():
    sc = scenario(11, n_steps=40, directionality="loop", field_of_view=TWO_PI, rotation_error=TWO_PI,
                  landmark_density=2.0)
    assert np.max(sc.obs_bearing) > math.pi  # bearings really are offset
    _compare_with_oracle(sc, EkfSlamConfig(std_v=0.05, std_omega=0.1))


# -- accuracy ------------------------------------------------------------------------------------


def test_beats_dead_reckoning_on_fixed_suite_cases():
    ekf_mm, dr_mm = [], []
    for seed in range(3):
        case_seed, slam_seed = np.random.SeedSequence(seed).spawn(2)
        sc = generate_scenario(CaseSpec(FIXED_VALUES), rng=np.random.default_rng(case_seed), n_steps=100)
        ekf_mm.append(rms_mm(sc, run_slam(EkfSlam(), sc, rng=np.random.default_rng(slam_seed))))
        dr_mm.append(rms_mm(sc, run_slam(DeadReckoning(), sc, rng=np.random.default_rng(slam_seed))))
    assert np.median(ekf_mm) < 0.6 * np.median(dr_mm), (ekf_mm, dr_mm)


@pytest.mark.slow
def test_full_fixed_suite_cases_beat_dead_reckoning():
    """1000-step fixed-suite cases: EKF-SLAM's map error is a fraction of dead reckoning's."""
    for seed in range(3):
        case_seed, slam_seed = np.random.SeedSequence(seed).spawn(2)
        sc = generate_scenario(CaseSpec(FIXED_VALUES), rng=np.random.default_rng(case_seed))
        assert sc.n_steps == 1000
        ekf = rms_mm(sc, run_slam(EkfSlam(), sc, rng=np.random.default_rng(slam_seed)))
        dr = rms_mm(sc, run_slam(DeadReckoning(), sc, rng=np.random.default_rng(slam_seed)))
        assert ekf < 0.5 * dr and ekf < 50.0, (seed, ekf, dr)


def test_zero_noise_gives_a_nearly_exact_map():
    zero = dict(variance_distance=0.0, variance_angle=0.0, outlier_probability=0.0)
    sc = scenario(0, n_steps=120, map_size=16.0, **zero)
    cfg = EkfSlamConfig(std_v=1e-3, std_omega=1e-3, std_range=1e-3, std_bearing=1e-3)
    est = run_slam(EkfSlam(cfg), sc, rng=np.random.default_rng(1))
    assert est.landmark_ids.size == sc.landmark_ids.size
    assert rms_mm(sc, est) < 2.0
    assert np.abs(est.pose[:2] - sc.true_poses[-1, :2]).max() < 0.01


# -- angles, empty updates, determinism --------------------------------------------------------


def test_offsets_of_2pi_on_bearings_turns_and_start_heading_change_nothing():
    sc = scenario(5, n_steps=150, map_size=16.0)
    assert np.any(np.abs(np.diff(sc.true_poses[:, 2])) > math.pi)  # the trajectory crosses +-pi
    rng = np.random.default_rng(0)
    moving = np.any(sc.controls != 0, axis=1)
    controls = sc.controls.copy()
    controls[moving, 1] += TWO_PI * rng.choice([-1.0, 1.0], size=int(moving.sum()))
    bearings = sc.obs_bearing + TWO_PI * rng.choice([-1.0, 1.0], size=sc.obs_bearing.size)
    poses = sc.true_poses.copy()
    poses[0, 2] -= TWO_PI
    shifted = dataclasses.replace(sc, controls=controls, obs_bearing=bearings, true_poses=poses)
    a = run_slam(EkfSlam(), sc, rng=np.random.default_rng(4))
    b = run_slam(EkfSlam(), shifted, rng=np.random.default_rng(4))
    np.testing.assert_array_equal(a.landmark_ids, b.landmark_ids)
    np.testing.assert_allclose(b.landmarks, a.landmarks, rtol=0, atol=1e-8)
    np.testing.assert_allclose(b.pose[:2], a.pose[:2], rtol=0, atol=1e-8)
    assert abs(angle_diff(b.pose[2], a.pose[2])) < 1e-8 and -math.pi <= b.pose[2] < math.pi
    assert rms_mm(sc, a) < 50.0


def test_empty_updates_change_nothing_and_zero_control_with_observations_does():
    sc = scenario(4, n_steps=20)
    slam = EkfSlam()
    slam.reset(sc.start_pose, rng=np.random.default_rng(5))
    for t in range(20):
        slam.step(sc.controls[t], sc.observations(t))
    mean, cov = slam.mean, slam.covariance
    for _ in range(30):
        slam.step([0.0, 0.0], Observations.empty())
    np.testing.assert_array_equal(slam.mean, mean)
    np.testing.assert_array_equal(slam.covariance, cov)
    slam.step([0.0, 0.0], sc.observations(19))  # not empty: the control noise is added
    assert slam.covariance[2, 2] != cov[2, 2]


def test_deterministic_and_draws_nothing():
    sc = scenario(8, n_steps=80)
    rng = np.random.default_rng(42)
    state = rng.bit_generator.state
    a = run_slam(EkfSlam(), sc, rng=rng)
    assert rng.bit_generator.state == state
    b = run_slam(EkfSlam(), sc, rng=np.random.default_rng(43))
    np.testing.assert_array_equal(a.landmarks, b.landmarks)
    np.testing.assert_array_equal(a.pose, b.pose)


# -- replaceable units ---------------------------------------------------------------------------


def _pass_through(unit, calls):
    @functools.wraps(unit)
    def wrapper(*args, **kwargs):
        calls[unit.__name__] = calls.get(unit.__name__, 0) + 1
        return unit(*args, **kwargs)
    return wrapper


@pytest.mark.parametrize("name", EkfSlamSteps.unit_names())
def test_a_pass_through_replacement_of_any_unit_is_called_and_changes_nothing(name):
    sc = scenario(2, n_steps=40, inactivity=5)
    ref = run_slam(EkfSlam(), sc, rng=np.random.default_rng(0))
    calls = {}
    steps = dataclasses.replace(EKF_REFERENCE_STEPS, **{name: _pass_through(getattr(EKF_REFERENCE_STEPS, name),
                                                                             calls)})
    slam = EkfSlam().with_steps(steps)
    assert slam.steps.replaced() == (name,) and "replaced=['" + name in repr(slam)
    est = run_slam(slam, sc, rng=np.random.default_rng(0))
    assert calls.get(getattr(EKF_REFERENCE_STEPS, name).__name__, 0) > 0
    np.testing.assert_array_equal(est.landmark_ids, ref.landmark_ids)
    np.testing.assert_array_equal(est.landmarks, ref.landmarks)
    np.testing.assert_array_equal(est.pose, ref.pose)


def test_the_papers_faults_apply_and_are_visible():
    sc = scenario(6, n_steps=150, map_size=16.0, rotation_error=TWO_PI)
    ref = rms_mm(sc, run_slam(EkfSlam(), sc, rng=np.random.default_rng(0)))
    for name in ("missing_angle_wrap", "motion_sign_error"):
        faulty = get_fault(name).apply(EkfSlam())
        assert faulty.steps.replaced() == (get_fault(name).step,)
        try:
            err = rms_mm(sc, run_slam(faulty, sc, rng=np.random.default_rng(0)))
        except (np.linalg.LinAlgError, SlamOutputError):
            err = math.inf  # a crash is a detection too
        assert err > ref + 250.0, (name, ref, err)
    with pytest.raises(FaultError, match="resample"):  # EKF-SLAM has no resampling unit
        get_fault("naive_resampling").apply(EkfSlam())


# -- protocol behaviour --------------------------------------------------------------------------


def test_bad_input_raises_clear_errors():
    with pytest.raises(SlamInputError, match="reset"):
        EkfSlam().step([0.0, 0.0])
    with pytest.raises(SlamInputError, match="reset"):
        EkfSlam().estimate()
    with pytest.raises(SlamInputError, match="start pose"):
        EkfSlam().reset([0.0, np.nan, 0.0], rng=np.random.default_rng(0))
    with pytest.raises(SlamInputError, match="Generator"):
        EkfSlam().reset([0.0, 0.0, 0.0], rng=0)
    slam = EkfSlam()
    slam.reset([0.0, 0.0, 0.0], rng=np.random.default_rng(0))
    slam.step([0.5, 0.1], ([1.0], [0.2], [7]))
    mean = slam.mean
    with pytest.raises(SlamInputError, match="NaN"):
        slam.step([0.8, 0.1], ([1.0, np.nan], [0.0, 0.2], [1, 2]))
    np.testing.assert_array_equal(slam.mean, mean)


def test_arbitrary_ids_in_order_of_first_observation():
    rng = np.random.default_rng(0)
    ids = rng.choice(np.arange(-10**12, 10**12, 10**9), 30, replace=False)
    truth = {int(i): rng.uniform(-2, 2, 2) for i in ids}
    slam = EkfSlam(EkfSlamConfig(std_range=1e-2, std_bearing=1e-2))
    slam.reset([0.0, 0.0, 0.0], rng=np.random.default_rng(1))
    order = []
    for t in range(6):
        seen = [int(i) for i in ids[: 5 * (t + 1)]][::-1]
        order += [i for i in seen if i not in order]
        xy = np.array([truth[i] for i in seen])
        slam.step([0.0, 0.0], (np.hypot(xy[:, 0], xy[:, 1]), np.arctan2(xy[:, 1], xy[:, 0]), seen))
    est = slam.estimate()
    assert est.landmark_ids.tolist() == order
    err = max(np.hypot(*(np.array(est.as_dict()[i]) - truth[i])) for i in truth)
    assert err < 0.02
