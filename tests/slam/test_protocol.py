import dataclasses
import math
from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from faultlab.errors import SlamInputError, SlamOutputError
from faultlab.slam.protocol import (Estimate, Observations, SlamAdapter, _all_valid, as_control, as_start_pose,
                                    check_generator)
from faultlab.metrics import trajectory_error_mm
from faultlab.scenario import generate_scenario
from faultlab.slam import (DeadReckoning, EkfSlam, EkfSlamConfig, FastSlam, FastSlam2, FastSlamConfig,
                           run_slam)
from faultlab.slam.association import FastSlam2Unknown, FastSlamUnknown
from faultlab.slam.gtsam import GtsamSlam, GtsamSlamConfig, gtsam_available
from faultlab.slam.profiles import get_profile
from faultlab.space.case import FIXED_VALUES, CaseSpec


def test_observations_accept_empty_and_coerce_types():
    obs = Observations([1.0, 2.0], [0.1, -0.2], [3, 4])
    assert obs.ids.dtype == np.int64 and len(obs) == 2
    assert len(Observations.empty()) == 0


@pytest.mark.parametrize(
    "ranges, bearings, ids, message",
    [
        ([1.0, np.nan], [0.0, 0.0], [1, 2], "NaN"),
        ([1.0, -0.5], [0.0, 0.0], [1, 2], "negative range"),
        ([1.0], [0.0, 0.1], [1], "equal length"),
        ([[1.0]], [[0.0]], [[1]], "1-d"),
        ([1.0, 1.0], [0.0, 0.0], [1, 1], "twice"),
        ([1.0], [0.0], [1.5], "integers"),
    ],
)
def test_observations_reject_bad_input(ranges, bearings, ids, message):
    with pytest.raises(SlamInputError, match=message):
        Observations(ranges, bearings, ids)


def test_control_validation():
    np.testing.assert_array_equal(as_control((1, 2)), [1.0, 2.0])
    with pytest.raises(SlamInputError, match="shape"):
        as_control([1.0, 2.0, 3.0])
    with pytest.raises(SlamInputError, match="finite"):
        as_control([np.inf, 0.0])


def test_start_pose_validation_copies_and_names_the_slam():
    given = [1, 2, 3]
    pose = as_start_pose(given, where="mine")
    assert pose.dtype == float and pose.tolist() == [1.0, 2.0, 3.0]
    held = np.zeros(3)
    as_start_pose(held, where="mine")[0] = 5.0
    assert held[0] == 0.0  # a new array: the caller's pose is never changed
    for bad in ([1.0, 2.0], [0.0, np.nan, 0.0], [[0.0, 0.0, 0.0]]):
        with pytest.raises(SlamInputError, match="mine: start pose must be 3 finite numbers"):
            as_start_pose(bad, where="mine")
    check_generator(np.random.default_rng(0), where="mine")
    with pytest.raises(SlamInputError, match="mine: rng must be a numpy.random.Generator, got RandomState"):
        check_generator(np.random.RandomState(0), where="mine")


def test_estimate_validation_names_the_bad_landmark():
    est = Estimate(np.zeros(3), np.array([7, 9]), np.array([[0.0, 1.0], [np.nan, 2.0]]))
    with pytest.raises(SlamOutputError, match="landmark 9"):
        est.validate()
    with pytest.raises(SlamOutputError, match="shape"):
        Estimate(np.zeros(2), np.array([1]), np.zeros((1, 2))).validate()
    ok = Estimate(np.zeros(3), np.array([1]), np.array([[1.0, 2.0]])).validate()
    assert ok.as_dict() == {1: (1.0, 2.0)}


class _Recorder(SlamAdapter):
    def reset(self, pose, *, rng):
        self.calls = []

    def update(self, control, observations):
        self.calls.append((control, observations))

    def estimate(self):
        return Estimate(np.zeros(3), np.empty(0, dtype=np.int64), np.empty((0, 2)))


def test_step_validates_before_update():
    slam = _Recorder()
    slam.reset(np.zeros(3), rng=np.random.default_rng(0))
    slam.step([0.5, 0.1], ([1.0], [0.0], [2]))
    slam.step([0.0, 0.0])
    with pytest.raises(SlamInputError):
        slam.step([0.0, 0.0], ([-1.0], [0.0], [2]))
    assert len(slam.calls) == 2
    assert len(slam.calls[1][1]) == 0


@st.composite
def observation_streams(draw):
    """A scenario's observation arrays (a few steps), sometimes with a planted defect."""
    counts = draw(st.lists(st.integers(0, 4), min_size=1, max_size=5))
    m = sum(counts)
    ranges = draw(hnp.arrays(np.float64, m, elements=st.one_of(
        st.floats(0.0, 100.0), st.sampled_from([-0.0, -1.0, np.nan, np.inf]))))
    bearings = draw(hnp.arrays(np.float64, m, elements=st.one_of(st.floats(-4.0, 4.0), st.just(np.nan))))
    ids = draw(hnp.arrays(np.int64, m, elements=st.integers(0, 5)))
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    return SimpleNamespace(obs_range=ranges, obs_bearing=bearings, obs_ids=ids, obs_offsets=offsets)


@settings(max_examples=300, deadline=None)
@given(observation_streams())
def test_the_scenario_wide_observation_check_agrees_with_the_per_step_checks(sc):
    """Oracle: building every step's Observations with its own checks."""
    def per_step_ok():
        for t in range(sc.obs_offsets.size - 1):
            a, b = sc.obs_offsets[t], sc.obs_offsets[t + 1]
            try:
                Observations(sc.obs_range[a:b], sc.obs_bearing[a:b], sc.obs_ids[a:b])
            except SlamInputError:
                return False
        return True

    assert _all_valid(sc) == per_step_ok()
    if _all_valid(sc):
        a, b = sc.obs_offsets[-2], sc.obs_offsets[-1]
        fast = Observations._checked(sc.obs_range[a:b], sc.obs_bearing[a:b], sc.obs_ids[a:b])
        slow = Observations(sc.obs_range[a:b], sc.obs_bearing[a:b], sc.obs_ids[a:b])
        for name in ("ranges", "bearings", "ids"):
            got, want = getattr(fast, name), getattr(slow, name)
            assert got.dtype == want.dtype and np.array_equal(got, want, equal_nan=True)
        assert fast.hidden is slow.hidden is False and len(fast) == len(slow)


# --------------------------------------------------------------------------- the trajectory of an estimate

def test_an_estimate_without_a_trajectory_is_valid_and_a_malformed_one_is_not():
    base = dict(pose=np.zeros(3), landmark_ids=np.array([1]), landmarks=np.zeros((1, 2)))
    assert Estimate(**base).validate().trajectory is None
    assert Estimate(**base, trajectory=np.zeros((0, 3))).validate().trajectory.shape == (0, 3)
    # a diverged trajectory keeps the map scorable: its ATE is NaN (faultlab.metrics.trajectory_error_mm)
    Estimate(**base, trajectory=np.full((2, 3), np.nan)).validate()
    for bad in (np.zeros((4, 2)), np.zeros(3), np.zeros((2, 3, 1)), np.array([["a", "b", "c"]])):
        with pytest.raises(SlamOutputError, match="trajectory must be numbers of shape \\(T, 3\\)"):
            Estimate(**base, trajectory=bad).validate()

# Every built-in SLAM reports its trajectory: one pose per step, aligned with ``true_poses[1:]``.
# 
# Checked on two scenes: a noise-free scenario (controls and observations exact; the SLAMs assume
# little noise), where the absolute trajectory error must be small against the truth's own extent;
# and the same scenario with every step followed by an idle step, where the trajectory must repeat
# each pose and, scored against a truth planted at a known distance ``d`` from it in opposite
# directions within each pair, the ATE is exactly ``d`` (the pairs cancel in the alignment's
# cross-covariance, so the optimal rigid motion is the identity: an exact, independent answer).

LOW = dict(std_v=0.01, std_omega=math.radians(0.5), std_range=0.05, std_bearing=math.radians(1.0))


def _paper():
    p = get_profile("paper")
    return FastSlam(dataclasses.replace(p.config, particles=20, **LOW), steps=p.steps)


#: name -> a SLAM that assumes little noise
SLAMS = {
    "fastslam1": lambda: FastSlam(FastSlamConfig(particles=20, **LOW)),
    "fastslam1-paper": _paper,
    "fastslam2": lambda: FastSlam2(FastSlamConfig(particles=20, **LOW)),
    "fastslam1-unknown": lambda: FastSlamUnknown(FastSlamConfig(particles=20, association="unknown", **LOW)),
    "fastslam2-unknown": lambda: FastSlam2Unknown(FastSlamConfig(particles=20, association="unknown", **LOW)),
    "ekf": lambda: EkfSlam(EkfSlamConfig(**LOW)),
    "gtsam": lambda: GtsamSlam(GtsamSlamConfig(**LOW)),
    "dead_reckoning": DeadReckoning,
}


def _make(name):
    if name == "gtsam" and not gtsam_available():
        pytest.skip("gtsam is not installed")
    return SLAMS[name]()


@pytest.fixture(scope="module")
def exact():
    """A noise-free scenario: 30 steps through a 16 m^2 map, no outliers."""
    values = {**FIXED_VALUES, "map_size": 16.0, "variance_distance": 0.0, "variance_angle": 0.0,
              "outlier_probability": 0.0}
    return generate_scenario(CaseSpec(values), rng=np.random.default_rng(4), n_steps=30)


def _with_idle_steps(sc):
    """``sc`` with an idle step (control (0, 0), no observation) after every step: every true pose twice."""
    T = sc.n_steps
    controls = np.zeros((2 * T, 2))
    controls[0::2] = sc.controls
    offsets = np.repeat(sc.obs_offsets[1:], 2)
    poses = np.concatenate([sc.true_poses[:1], np.repeat(sc.true_poses[1:], 2, axis=0)])
    return dataclasses.replace(sc, controls=controls, obs_offsets=np.concatenate([[0], offsets]), true_poses=poses)


@pytest.mark.parametrize("name", list(SLAMS))
def test_the_trajectory_has_one_pose_per_step_and_a_small_error_on_an_exact_scenario(exact, name):
    est = run_slam(_make(name), exact, rng=np.random.default_rng(1))
    assert est.trajectory.shape == (exact.n_steps, 3) and np.isfinite(est.trajectory).all()
    truth = exact.true_poses[1:, :2]
    spread_mm = 1000 * math.sqrt(np.mean(np.sum((truth - truth.mean(axis=0)) ** 2, axis=1)))
    ate = trajectory_error_mm(exact, est)
    # the ATE of a trajectory that never moved is the spread; a SLAM on exact data is far below it
    assert ate < 0.1 * spread_mm, (ate, spread_mm)
    if name in ("ekf", "dead_reckoning", "gtsam"):  # exact input: these reproduce the truth
        assert ate < 1e-3
        np.testing.assert_allclose(est.trajectory[-1], est.pose, rtol=0, atol=1e-9)


@pytest.mark.parametrize("name", list(SLAMS))
def test_against_a_planted_offset_the_error_is_the_offset(exact, name):
    sc = _with_idle_steps(exact)
    est = run_slam(_make(name), sc, rng=np.random.default_rng(2))
    q = est.trajectory
    assert q.shape == (sc.n_steps, 3)
    np.testing.assert_array_equal(q[0::2], q[1::2])  # an idle step moves nothing
    d = 0.25
    angle = np.random.default_rng(3).uniform(-np.pi, np.pi, exact.n_steps)
    v = d * np.stack([np.cos(angle), np.sin(angle)], axis=1)
    planted = np.empty((sc.n_steps, 2))
    planted[0::2], planted[1::2] = q[0::2, :2] + v, q[1::2, :2] - v
    truth = sc.true_poses.copy()
    truth[1:, :2] = planted
    assert trajectory_error_mm(dataclasses.replace(sc, true_poses=truth), est) == pytest.approx(1000 * d, abs=1e-6)


def _best_particle_oracle(poses, logw):
    """The highest-weight particle's pose the slow way (ties: the lowest index)."""
    return poses[max(range(len(logw)), key=lambda j: (logw[j], -j))].copy()


@pytest.mark.parametrize("name", ["fastslam1", "fastslam1-paper", "fastslam2", "fastslam1-unknown"])
def test_a_particle_filters_trajectory_is_its_best_particles_pose_after_each_step(exact, name):
    slam = _make(name)
    slam.reset(exact.start_pose, rng=np.random.default_rng(5))
    expected = []
    for t in range(exact.n_steps):
        r, b, ids = exact.observations(t)
        slam.step(exact.controls[t], Observations.without_ids(r, b) if name.endswith("unknown")
                  else Observations(r, b, ids))
        st = slam.state
        expected.append(_best_particle_oracle(np.asarray(st.poses), np.asarray(st.logw)))
    est = slam.estimate()
    np.testing.assert_array_equal(est.trajectory, np.array(expected))
    np.testing.assert_array_equal(est.trajectory[-1], est.pose)


def test_a_batch_reports_each_repetitions_own_trajectory(exact):
    seeds = (7, 8, 9)
    batch = FastSlam(FastSlamConfig(particles=20, **LOW))
    batch.reset_batch(exact.start_pose, rngs=[np.random.default_rng(s) for s in seeds])
    for t in range(exact.n_steps):
        batch.step(exact.controls[t], exact.observations(t))
    for s, est in zip(seeds, batch.estimates()):
        alone = run_slam(FastSlam(FastSlamConfig(particles=20, **LOW)), exact, rng=np.random.default_rng(s))
        np.testing.assert_array_equal(est.trajectory, alone.trajectory)


def test_a_covariance_is_validated_with_the_estimate():
    ids, lm = np.array([3, 9]), np.zeros((2, 2))
    ok = np.eye(7) * 0.01
    Estimate(np.zeros(3), ids, lm, covariance=ok).validate()
    rounding = ok.copy()
    rounding[0, 1] = 1e-14  # far below the rounding tolerance
    Estimate(np.zeros(3), ids, lm, covariance=rounding).validate()
    broken = ok.copy()
    broken[4, 6] = 0.005  # one triangle only
    nan = ok.copy()
    nan[2, 2] = np.nan
    for cov, match in [(broken, "not symmetric"), (nan, "not finite"), (np.eye(5), r"shape \(7, 7\)"),
                       (-ok, "not positive semi-definite")]:
        with pytest.raises(SlamOutputError, match=match):
            Estimate(np.zeros(3), ids, lm, covariance=cov).validate()


def test_ekf_slam_reports_its_state_covariance(exact):
    slam = EkfSlam()
    est = run_slam(slam, exact, rng=np.random.default_rng(0))
    assert est.covariance.shape == (3 + 2 * est.landmark_ids.size,) * 2
    np.testing.assert_array_equal(est.covariance, slam.covariance)
    assert np.min(np.linalg.eigvalsh(est.covariance)) > -1e-12
