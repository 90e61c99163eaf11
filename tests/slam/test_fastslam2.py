"""Tests of FastSLAM 2.0 (faultlab.slam.fastslam2)."""

import copy
import dataclasses
import functools
import math

import numpy as np
import pytest

from faultlab.errors import ConfigError, SlamInputError, SlamOutputError
from faultlab.faults import get_fault
from faultlab.metrics import map_errors
from faultlab.scenario import generate_scenario
from faultlab.slam import (
    FASTSLAM2_REFERENCE_STEPS,
    DeadReckoning,
    FastSlam,
    FastSlam2,
    FastSlam2Steps,
    FastSlamConfig,
    Observations,
    run_slam,
)
from faultlab.slam import particles
from faultlab.slam import units as U
from faultlab.slam.fastslam2 import RANDOM_UNITS
from faultlab.space import FIXED_VALUES, CaseSpec

from tests.slam.fastslam2_oracle import OracleFastSlam2, run_oracle

TWO_PI = 2.0 * math.pi
REF = FASTSLAM2_REFERENCE_STEPS


def scenario(seed, *, n_steps=200, **values):
    return generate_scenario(CaseSpec(dict(FIXED_VALUES, **values)), rng=np.random.default_rng(seed),
                             n_steps=n_steps)


def fixed_case(seed, n_steps):
    case_seed, slam_seed = np.random.SeedSequence(seed).spawn(2)
    sc = generate_scenario(CaseSpec(FIXED_VALUES), rng=np.random.default_rng(case_seed), n_steps=n_steps)
    return sc, slam_seed


def rms_mm(sc, est):
    return map_errors(sc, est, metrics=("rms",)).rms_mm


def angle_diff(a, b):
    return (np.asarray(a) - np.asarray(b) + math.pi) % TWO_PI - math.pi


def small(n=30):
    return FastSlamConfig(particles=n)


# -- units ----------------------------------------------------------------------------------------


def test_steps_reuse_fastslam1_units_and_name_the_new_ones():
    from faultlab.slam import REFERENCE_STEPS as FS1

    names = FastSlam2Steps.unit_names()
    shared = set(names) & set(type(FS1).unit_names())
    assert shared == set(type(FS1).unit_names()) - {"sample_controls"}  # 2.0 samples its proposal instead
    for name in shared:  # the very same functions: a fault on one of them applies to both SLAMs
        assert getattr(REF, name) is getattr(FS1, name)
    assert {"motion_jacobians", "pose_jacobian", "proposal_information", "proposal", "sample_proposal",
            "proposal_correction"} <= set(names)
    assert set(RANDOM_UNITS) == {"sample_proposal", "resample"} <= set(names)
    assert REF.replaced() == ()
    with pytest.raises(ConfigError, match="proposal"):
        dataclasses.replace(REF, proposal="not a function")
    with pytest.raises(ConfigError, match="FastSlam2Steps"):
        FastSlam2(steps=FS1)


# -- equivalence with the per-particle oracle ----------------------------------------------------


def _compare_with_oracle(sc, *, particles, seed):
    slam = FastSlam2(small(particles))
    slam.reset(sc.start_pose, rng=np.random.default_rng(seed))
    oracle = OracleFastSlam2(particles=particles)
    worst = {"pose": 0.0, "weight": 0.0, "mean": 0.0, "cov": 0.0}

    def check(t):
        slam.step(sc.controls[t], Observations(*sc.observations(t)))
        p = slam.particles()
        op = oracle.poses()
        worst["pose"] = max(worst["pose"], np.abs(p.poses[:, :2] - op[:, :2]).max(),
                            np.abs(angle_diff(p.poses[:, 2], op[:, 2])).max())
        worst["weight"] = max(worst["weight"], np.abs(p.weights - oracle.weights()).max())
        assert set(p.landmark_ids.tolist()) == oracle.known_ids()
        if p.landmark_ids.size:
            mu, P = oracle.landmarks(p.landmark_ids)
            worst["mean"] = max(worst["mean"], np.abs(p.means - mu).max())
            worst["cov"] = max(worst["cov"], np.abs(p.covariances - P).max())

    run_oracle(oracle, sc, rng=np.random.default_rng(seed), callback=check)
    for what, err in worst.items():
        assert err < 1e-9, f"{what} differs from the oracle by {err}"
    assert slam.n_resamples == oracle.n_resamples
    return slam


def test_matches_per_particle_oracle_with_resampling_and_inactivity():
    sc = scenario(3, n_steps=60, landmark_density=1.0, inactivity=15)
    assert np.sum(np.all(sc.controls == 0, axis=1) & (np.diff(sc.obs_offsets) == 0)) == 15  # empty updates
    slam = _compare_with_oracle(sc, particles=12, seed=7)
    assert 5 < slam.n_resamples < sc.n_steps - 15


def test_matches_oracle_on_a_loop_with_full_fov_and_rotation_error():
    sc = scenario(11, n_steps=40, directionality="loop", field_of_view=TWO_PI, rotation_error=-TWO_PI,
                  landmark_density=2.0)
    assert np.min(sc.obs_bearing) < -math.pi  # bearings really are offset
    slam = _compare_with_oracle(sc, particles=6, seed=2)
    assert slam.n_resamples > 0


# -- accuracy ------------------------------------------------------------------------------------


def test_beats_dead_reckoning_on_fixed_suite_cases():
    slam_mm, dr_mm = [], []
    for seed in range(3):
        sc, slam_seed = fixed_case(seed, 150)
        slam_mm.append(rms_mm(sc, run_slam(FastSlam2(small(50)), sc, rng=np.random.default_rng(slam_seed))))
        dr_mm.append(rms_mm(sc, run_slam(DeadReckoning(), sc, rng=np.random.default_rng(slam_seed))))
    assert np.median(slam_mm) < 0.6 * np.median(dr_mm), (slam_mm, dr_mm)


def test_the_improved_proposal_needs_fewer_particles_than_fastslam1():
    """Montemerlo et al. (2003): with the same few particles FastSLAM 2.0 maps better than 1.0."""
    fs2, fs1 = [], []
    for seed in range(5):
        sc, slam_seed = fixed_case(seed, 150)
        fs2.append(rms_mm(sc, run_slam(FastSlam2(small(20)), sc, rng=np.random.default_rng(slam_seed))))
        fs1.append(rms_mm(sc, run_slam(FastSlam(small(20)), sc, rng=np.random.default_rng(slam_seed))))
    assert np.median(fs2) < 0.8 * np.median(fs1), (fs2, fs1)


@pytest.mark.slow
def test_full_fixed_suite_cases_beat_dead_reckoning():
    """1000-step fixed-suite cases with the paper's 200 particles (FastSLAM 1.0: median <= 100 mm)."""
    slam_mm, dr_mm = [], []
    for seed in range(3):
        sc, slam_seed = fixed_case(seed, 1000)
        slam_mm.append(rms_mm(sc, run_slam(FastSlam2(), sc, rng=np.random.default_rng(slam_seed))))
        dr_mm.append(rms_mm(sc, run_slam(DeadReckoning(), sc, rng=np.random.default_rng(slam_seed))))
    assert np.median(slam_mm) <= 100.0 and max(s - d for s, d in zip(slam_mm, dr_mm)) < 0, (slam_mm, dr_mm)


def test_zero_noise_gives_a_nearly_exact_map():
    zero = dict(variance_distance=0.0, variance_angle=0.0, outlier_probability=0.0)
    sc = scenario(0, n_steps=200, **zero)
    cfg = FastSlamConfig(particles=20, std_v=1e-3, std_omega=1e-3, std_range=1e-3, std_bearing=1e-3)
    est = run_slam(FastSlam2(cfg), sc, rng=np.random.default_rng(1))
    assert rms_mm(sc, est) < 2.0
    assert np.abs(est.pose[:2] - sc.true_poses[-1, :2]).max() < 0.02


# -- angles, empty updates, determinism ----------------------------------------------------------


def test_offsets_of_2pi_on_bearings_turns_and_start_heading_change_nothing():
    sc = scenario(5, n_steps=200)
    assert np.any(np.abs(np.diff(sc.true_poses[:, 2])) > math.pi)  # the trajectory crosses +-pi
    rng = np.random.default_rng(0)
    moving = np.any(sc.controls != 0, axis=1)
    controls = sc.controls.copy()
    controls[moving, 1] += TWO_PI * rng.choice([-1.0, 1.0], size=int(moving.sum()))
    bearings = sc.obs_bearing + TWO_PI * rng.choice([-1.0, 1.0], size=sc.obs_bearing.size)
    poses = sc.true_poses.copy()
    poses[0, 2] -= TWO_PI
    shifted = dataclasses.replace(sc, controls=controls, obs_bearing=bearings, true_poses=poses)
    a = run_slam(FastSlam2(small(40)), sc, rng=np.random.default_rng(4))
    b = run_slam(FastSlam2(small(40)), shifted, rng=np.random.default_rng(4))
    np.testing.assert_array_equal(a.landmark_ids, b.landmark_ids)
    np.testing.assert_allclose(b.landmarks, a.landmarks, rtol=0, atol=1e-8)
    np.testing.assert_allclose(b.pose[:2], a.pose[:2], rtol=0, atol=1e-8)
    assert abs(angle_diff(b.pose[2], a.pose[2])) < 1e-8 and -math.pi <= b.pose[2] < math.pi
    assert rms_mm(sc, a) < 150.0


def test_empty_updates_draw_nothing_and_change_nothing():
    sc = scenario(4, n_steps=20)
    slam = FastSlam2(small(25))
    slam.reset(sc.start_pose, rng=np.random.default_rng(5))
    for t in range(20):
        slam.step(sc.controls[t], sc.observations(t))
    streams = {name: copy.deepcopy(g.bit_generator.state) for name, g in slam._streams.items()}
    before, n_res = slam.particles(), slam.n_resamples
    for _ in range(40):
        slam.step([0.0, 0.0], Observations.empty())
    after = slam.particles()
    assert {name: g.bit_generator.state for name, g in slam._streams.items()} == streams
    assert slam.n_resamples == n_res
    np.testing.assert_array_equal(after.poses, before.poses)
    np.testing.assert_array_equal(after.weights, before.weights)
    np.testing.assert_array_equal(after.means, before.means)
    np.testing.assert_array_equal(after.covariances, before.covariances)
    slam.step([0.0, 0.0], sc.observations(19))  # zero control but observations: not empty
    assert slam._streams["sample_proposal"].bit_generator.state != streams["sample_proposal"]
    assert np.abs(slam.particles().poses - before.poses).max() > 0


def test_same_seed_same_estimate_different_seed_different_estimate():
    sc = scenario(8, n_steps=100)
    a = run_slam(FastSlam2(small()), sc, rng=np.random.default_rng(42))
    b = run_slam(FastSlam2(small()), sc, rng=np.random.default_rng(42))
    c = run_slam(FastSlam2(small()), sc, rng=np.random.default_rng(43))
    np.testing.assert_array_equal(a.landmark_ids, b.landmark_ids)
    np.testing.assert_array_equal(a.landmarks, b.landmarks)
    np.testing.assert_array_equal(a.pose, b.pose)
    assert np.abs(a.landmarks - c.landmarks).max() > 1e-6


# -- replaceable units and common random numbers -------------------------------------------------


def _pass_through(unit, calls):
    @functools.wraps(unit)
    def wrapper(*args, **kwargs):
        calls.append(unit.__name__)
        return unit(*args, **kwargs)
    return wrapper


@pytest.mark.parametrize("name", FastSlam2Steps.unit_names())
def test_a_pass_through_replacement_of_any_unit_is_called_and_changes_nothing(name):
    sc = scenario(2, n_steps=30, inactivity=5)
    ref_slam = FastSlam2(small(15))
    ref = run_slam(ref_slam, sc, rng=np.random.default_rng(0))
    calls = []
    slam = ref_slam.with_steps(dataclasses.replace(REF, **{name: _pass_through(getattr(REF, name), calls)}))
    assert slam.steps.replaced() == (name,) and slam.config is ref_slam.config
    est = run_slam(slam, sc, rng=np.random.default_rng(0))
    assert calls, f"unit {name} was never called"
    np.testing.assert_array_equal(est.landmark_ids, ref.landmark_ids)
    np.testing.assert_array_equal(est.landmarks, ref.landmarks)
    np.testing.assert_array_equal(est.pose, ref.pose)
    assert slam.n_resamples == ref_slam.n_resamples > 0


class _RecordingRng:
    """Wraps a Generator and records every value it hands out."""

    def __init__(self, rng, log):
        self._rng, self._log = rng, log

    def __getattr__(self, name):
        method = getattr(self._rng, name)

        def call(*args, **kwargs):
            out = method(*args, **kwargs)
            self._log.append(np.ravel(out).copy())
            return out
        return call


def _record(unit, log, position):
    """``unit`` with its rng argument (positional index ``position``) wrapped in a recorder."""
    def wrapper(*args):
        args = list(args)
        args[position] = _RecordingRng(args[position], log)
        return unit(*args)
    return wrapper


def _naive_resampling(w, n_eff, empty, rng, config):
    return rng.choice(w.size, size=w.size, p=w)  # draws N numbers at every update


def _double_draw_proposal(mean, cov, rng):
    rng.standard_normal(mean.shape)  # an extra draw, discarded
    return U.sample_controls(np.zeros(2), mean.shape[0], rng, FastSlamConfig()) * 0.5 + mean


def _draws(steps, sc):
    slam = FastSlam2(small(20), steps=steps)
    run_slam(slam, sc, rng=np.random.default_rng(9))
    return slam


@pytest.mark.parametrize("unit, position, other, replacement", [
    ("sample_proposal", 2, "resample", _naive_resampling),
    ("sample_proposal", 2, "proposal", lambda lam, eta, M: (np.zeros_like(eta), lam * 0 + 2 * M)),
    ("resample", 3, "sample_proposal", _double_draw_proposal),
    ("resample", 3, "ekf_update", lambda mu, P, H, S, nu: (mu, P)),
])
def test_a_units_random_draws_do_not_depend_on_other_units(unit, position, other, replacement):
    """Common random numbers by unit: replacing another unit leaves this unit's draws bit-identical."""
    sc = scenario(12, n_steps=80, inactivity=10)
    ref_log, log = [], []
    _draws(dataclasses.replace(REF, **{unit: _record(getattr(REF, unit), ref_log, position)}), sc)
    _draws(dataclasses.replace(REF, **{unit: _record(getattr(REF, unit), log, position),
                                       other: replacement}), sc)
    ref_vals, vals = np.concatenate(ref_log), np.concatenate(log)
    m = min(ref_vals.size, vals.size)
    assert m >= 5
    np.testing.assert_array_equal(vals[:m], ref_vals[:m])
    if other == "resample":  # the replaced unit really drew more from its own stream
        assert vals.size == ref_vals.size


def test_the_papers_faults_apply_and_are_visible():
    sc = scenario(6, n_steps=150, rotation_error=TWO_PI, inactivity=100)
    ref = rms_mm(sc, run_slam(FastSlam2(small(50)), sc, rng=np.random.default_rng(0)))
    for name in ("missing_angle_wrap", "motion_sign_error"):
        faulty = get_fault(name).apply(FastSlam2(small(50)))
        assert isinstance(faulty, FastSlam2) and faulty.steps.replaced() == (get_fault(name).step,)
        try:
            err = rms_mm(sc, run_slam(faulty, sc, rng=np.random.default_rng(0)))
        except SlamOutputError:
            err = math.inf  # a crash is a detection too
        assert err > ref + 250.0, (name, ref, err)
    naive = get_fault("naive_resampling").apply(FastSlam2(small(50)))
    run_slam(naive, sc, rng=np.random.default_rng(0))
    assert naive.n_resamples == sc.n_steps


# -- storage and protocol behaviour --------------------------------------------------------------


def test_storage_in_another_layout_or_owned_by_a_permutation_is_equivalent():
    """The element-wise gather/write path gives the reference result (the fast path is the reference's)."""
    sc = scenario(9, n_steps=60, inactivity=10)
    ref_slam = FastSlam2(small(25))
    ref = run_slam(ref_slam, sc, rng=np.random.default_rng(3))
    perm = np.random.default_rng(0).permutation(25)

    def permuted_owner(state, idx):
        return U.apply_resample(state, idx).replace(owner=perm.copy())

    def plain_arrays(state, idx):
        rows = particles.landmark_rows(state, np.arange(state.mu.shape[1]))[idx]
        cols = np.arange(state.mu.shape[1])[None, :]
        n = state.n_particles
        return state.replace(poses=state.poses[idx], logw=np.full(n, -math.log(n)),
                             mu=np.ascontiguousarray(state.mu[rows, cols]),
                             P=np.ascontiguousarray(state.P[rows, cols]),
                             anc=np.tile(np.arange(n, dtype=np.int64)[:, None], (1, state.mu.shape[1])),
                             lineage=np.arange(n), owner=np.arange(n))

    for fn in (permuted_owner, plain_arrays):
        slam = FastSlam2(small(25), steps=dataclasses.replace(REF, apply_resample=fn))
        est = run_slam(slam, sc, rng=np.random.default_rng(3))
        assert slam.n_resamples == ref_slam.n_resamples > 0
        np.testing.assert_allclose(est.landmarks, ref.landmarks, rtol=0, atol=1e-12)
        np.testing.assert_allclose(slam.particles().covariances, ref_slam.particles().covariances,
                                   rtol=0, atol=1e-12)


def test_shallow_copy_resampling_is_expressible_and_shares_storage():
    def shallow(state, idx):
        return U.apply_resample(state, idx).replace(owner=state.owner[idx])

    sc = scenario(9, n_steps=60)
    slam = FastSlam2(small(25), steps=dataclasses.replace(REF, apply_resample=shallow))
    est = run_slam(slam, sc, rng=np.random.default_rng(3))
    owner = slam.state.owner
    assert np.unique(owner).size < owner.size
    dup = np.flatnonzero(owner == owner[np.argmax(np.bincount(owner))])
    p = slam.particles()
    np.testing.assert_array_equal(p.means[dup[0]], p.means[dup[1]])
    assert np.isfinite(est.landmarks).all()


def test_bad_input_and_non_finite_weights_raise_clear_errors():
    with pytest.raises(SlamInputError, match="reset"):
        FastSlam2().step([0.0, 0.0])
    with pytest.raises(SlamInputError, match="start pose"):
        FastSlam2().reset([0.0, np.inf, 0.0], rng=np.random.default_rng(0))
    with pytest.raises(SlamInputError, match="Generator"):
        FastSlam2().reset([0.0, 0.0, 0.0], rng=1)
    with pytest.raises(ConfigError, match="FastSlamConfig"):
        FastSlam2(config={"particles": 3})
    bad = dataclasses.replace(REF, proposal_correction=lambda lam, eta, cov, M: np.full(eta.shape[0], np.nan))
    with pytest.raises(SlamOutputError, match="weights are not finite"):
        run_slam(FastSlam2(small(10), steps=bad), scenario(1, n_steps=30), rng=np.random.default_rng(0))


def test_estimate_is_the_highest_weight_particle():
    sc = scenario(6, n_steps=40)
    never = dataclasses.replace(REF, resample=lambda w, n_eff, empty, rng, config: None)
    slam = FastSlam2(small(30), steps=never)
    est = run_slam(slam, sc, rng=np.random.default_rng(1))
    p = slam.particles()
    best = int(np.argmax(p.weights))
    assert p.weights[best] > 2 * np.median(p.weights)
    np.testing.assert_array_equal(est.landmark_ids, p.landmark_ids)
    np.testing.assert_array_equal(est.landmarks, p.means[best])
    np.testing.assert_array_equal(est.pose, p.poses[best])
