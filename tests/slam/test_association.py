"""FastSLAM 1.0 and 2.0 with unknown data association (faultlab.slam.association)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.errors import ConfigError, SlamInputError
from faultlab.faults import applicable_faults, get_fault
from faultlab.metrics import map_errors
from faultlab.scenario import generate_scenario
from faultlab.slam import Observations, run_slam
from faultlab.slam.association import (FastSlam2Unknown, FastSlam2UnknownSteps, FastSlamUnknown,
                                       FastSlamUnknownSteps)
from faultlab.slam.associationunits import NEW_LANDMARK
from faultlab.slam.fastslam import FastSlam, FastSlamConfig
from faultlab.slam.protocol import HIDDEN_ID
from faultlab.slam.registry import build_slam
from faultlab.space import FIXED_VALUES, CaseSpec
from tests.slam.association_oracle import OracleFastSlamUnknown, associate_particle

UNKNOWN = FastSlamConfig(association="unknown")


def _scenario(seed=1, n_steps=40, **values):
    return generate_scenario(CaseSpec({**FIXED_VALUES, **values}), rng=np.random.default_rng(seed), n_steps=n_steps)


def _filter(n=1, **kw):
    cfg = FastSlamConfig(association="unknown", particles=n, std_v=0.0, std_omega=0.0, std_range=0.05,
                         std_bearing=math.radians(2.0), **kw)
    slam = FastSlamUnknown(cfg)
    slam.reset(np.zeros(3), rng=np.random.default_rng(0))
    return slam


def _sight(points, pose=(0.0, 0.0, 0.0)):
    """Exact (range, bearing) observations of ``points`` from ``pose``, ids hidden."""
    d = np.asarray(points, dtype=float) - np.asarray(pose[:2])
    return Observations.without_ids(np.hypot(d[:, 0], d[:, 1]), np.arctan2(d[:, 1], d[:, 0]) - pose[2])


def test_landmarks_are_created_once_and_then_reobserved():
    slam = _filter()
    slam.step((0.0, 0.0), _sight([[1.0, 0.0], [0.0, 1.0]]))
    assert slam.state.size.tolist() == [2]
    slam.step((0.0, 0.0), _sight([[0.0, 1.0], [1.0, 0.0]]))  # same landmarks, other order
    assert slam.state.size.tolist() == [2]
    slam.step((0.0, 0.0), _sight([[1.0, 0.0], [-1.5, 0.2]]))  # one known, one far from every landmark
    assert slam.state.size.tolist() == [3]
    est = slam.estimate()
    np.testing.assert_allclose(est.landmarks, [[1.0, 0.0], [0.0, 1.0], [-1.5, 0.2]], atol=1e-9)
    assert est.landmark_ids.tolist() == [0, 1, 2]


def test_a_lower_threshold_merges_what_a_higher_one_separates():
    near = [[1.0, 0.0], [1.0, 0.12]]  # 6.8 deg apart: 3.4 bearing sigmas
    loose, strict = _filter(new_landmark_sigmas=8.0), _filter(new_landmark_sigmas=2.0)
    for slam in (loose, strict):
        slam.step((0.0, 0.0), _sight(near[:1]))
        slam.step((0.0, 0.0), _sight(near[1:]))
    assert loose.state.size.tolist() == [1] and strict.state.size.tolist() == [2]


# -- equivalence with the per-particle oracle --------------------------------------------------------


@pytest.mark.parametrize("seed", [3, 4])
def test_fastslam_unknown_matches_the_per_particle_oracle(seed):
    sc = _scenario(seed=seed, n_steps=25, map_size=9.0, landmark_density=1.5, outlier_probability=5.0)
    n = 6
    slam = FastSlamUnknown(FastSlamConfig(association="unknown", particles=n))
    oracle = OracleFastSlamUnknown(particles=n)
    slam.reset(sc.start_pose, rng=np.random.default_rng(seed))
    oracle.reset(sc.start_pose, rng=np.random.default_rng(seed))
    sizes = []
    for t in range(sc.n_steps):
        r, b, _ = sc.observations(t)
        slam.step(sc.controls[t], Observations.without_ids(r, b))
        oracle.step(sc.controls[t], r, b)
        s = slam.state
        np.testing.assert_allclose(s.poses, [p.pose for p in oracle.particles], atol=1e-9)
        np.testing.assert_allclose(np.exp(s.logw), [p.w for p in oracle.particles], rtol=1e-7, atol=1e-12)
        assert s.size.tolist() == [len(p.lm) for p in oracle.particles]
        for i, p in enumerate(oracle.particles):
            if p.lm:
                np.testing.assert_allclose(s.mu[i, :len(p.lm)], [mu for mu, _ in p.lm], atol=1e-8)
                np.testing.assert_allclose(s.P[i, :len(p.lm)], [P for _, P in p.lm], atol=1e-8)
        sizes.append(int(s.size.max()))
    assert sizes[-1] > 5  # the run did create and re-associate landmarks


def test_fastslam2_unknown_associates_like_the_oracle():
    """At every step, FastSLAM 2.0's association (at the noise-free prediction) is the oracle's on its own maps."""
    sc = _scenario(seed=5, n_steps=25, map_size=9.0, landmark_density=1.5)
    slam = FastSlam2Unknown(FastSlamConfig(association="unknown", particles=8))
    slam.reset(sc.start_pose, rng=np.random.default_rng(5))
    Q, lp0 = slam.config.Q, slam.config.log_p0
    checked = 0
    for t in range(sc.n_steps):
        r, b, _ = sc.observations(t)
        st = slam.state
        if len(r) and st.size.max():
            x_hat = np.asarray(slam.steps.motion_model(st.poses, np.broadcast_to(sc.controls[t], (8, 2)),
                                                       wrap=slam.steps.wrap_heading))
            got = slam._associate(x_hat, np.column_stack([r, b])).assoc
            for i in range(8):
                lms = [(st.mu[i, j], st.P[i, j]) for j in range(st.size[i])]
                assert got[i].tolist() == associate_particle(x_hat[i], lms, np.column_stack([r, b]), Q, lp0)
            checked += 1
        slam.step(sc.controls[t], Observations.without_ids(r, b))
    assert checked > 10 and slam.state.size.max() > 5


# -- properties --------------------------------------------------------------------------------------


@settings(max_examples=30, deadline=None)
@given(st.lists(st.integers(0, 15), min_size=2, max_size=8, unique=True), st.randoms(use_true_random=False),
       st.integers(0, 3))
def test_permuting_observations_permutes_the_association(cells, rnd, n_new):
    """Well-separated landmarks (a 1.5 m grid): the association follows the observations, whatever their order."""
    grid = np.array([[1.5 * (c % 4) - 2.25, 1.5 * (c // 4) - 2.25] for c in range(16)])
    slam = _filter(n=3)
    slam.step((0.0, 0.0), _sight(grid[cells]))
    seen = grid[cells]
    extra = np.array([[3.5, 3.4], [-3.4, 3.6], [3.6, -3.5]])[:n_new]  # far from every mapped landmark
    z_points = np.concatenate([seen, extra])
    perm = list(range(len(z_points)))
    rnd.shuffle(perm)
    obs = _sight(z_points)
    z = np.column_stack([obs.ranges, obs.bearings])
    poses = slam.state.poses
    a = slam._associate(poses, z).assoc
    b = slam._associate(poses, z[perm]).assoc
    np.testing.assert_array_equal(a[:, perm], b)
    assert (a[:, :len(seen)] == np.arange(len(seen))).all() and (a[:, len(seen):] == NEW_LANDMARK).all()


# -- the adapter protocol, the registry, faults, scoring ---------------------------------------------


def test_the_driver_hides_the_ids_and_a_known_association_slam_refuses_hidden_ones():
    sc = _scenario(n_steps=15)
    seen = []

    class Spy(FastSlamUnknown):
        def update(self, control, observations):
            seen.append(observations.ids.copy())
            super().update(control, observations)

    run_slam(Spy(FastSlamConfig(association="unknown", particles=5)), sc, rng=np.random.default_rng(0))
    assert sum(len(s) for s in seen) > 0 and all((s == HIDDEN_ID).all() for s in seen)
    slam = FastSlam(FastSlamConfig(particles=5))
    slam.reset(sc.start_pose, rng=np.random.default_rng(0))
    with pytest.raises(SlamInputError, match="hide"):
        slam.step((0.1, 0.0), Observations.without_ids([1.0], [0.0]))
    with pytest.raises(SlamInputError, match="hidden ids"):
        Observations([1.0], [0.0], [3], hidden=True)


def test_the_registry_builds_the_unknown_association_filters_by_option():
    assert type(build_slam("fastslam", {"association": "unknown"})) is FastSlamUnknown
    assert type(build_slam("fastslam2", {"association": "unknown", "particles": 7})) is FastSlam2Unknown
    with pytest.raises(ConfigError, match="association"):
        build_slam("fastslam", {"association": "maybe"})
    with pytest.raises(ConfigError, match="known"):
        FastSlam(UNKNOWN)
    from faultlab.slam.registry import BUILTIN_SLAMS
    with pytest.raises(ConfigError, match="profile"):
        BUILTIN_SLAMS["fastslam"].options({"association": "unknown", "profile": "paper"}, where="x: slam")
    assert "association" not in FastSlamConfig().to_options()  # the default leaves existing hashes alone


def test_faults_apply_to_the_units_the_mode_has():
    names = {f.name for f in applicable_faults(FastSlamUnknown()).applicable}
    assert {"naive_resampling", "missing_angle_wrap", "motion_sign_error"} <= names
    assert "shallow_copy_resampling" not in names  # apply_resample: the id-aligned storage only
    assert set(FastSlamUnknownSteps.unit_names()) >= {"associate", "resample_maps", "extract_unlabelled_map"}
    assert "classify_new" not in FastSlam2UnknownSteps.unit_names()
    sc = _scenario(n_steps=30)
    ref = run_slam(FastSlamUnknown(FastSlamConfig(association="unknown", particles=10)), sc,
                   rng=np.random.default_rng(1))
    faulty = get_fault("motion_sign_error").apply(FastSlamUnknown(FastSlamConfig(association="unknown",
                                                                                 particles=10)))
    bad = run_slam(faulty, sc, rng=np.random.default_rng(1))
    assert map_errors(sc, bad, association="unknown").emd_mm > map_errors(sc, ref, association="unknown").emd_mm


@pytest.mark.parametrize("cls", [FastSlamUnknown, FastSlam2Unknown])
def test_same_seed_same_map_and_the_map_is_scored_by_emd(cls):
    sc = _scenario(n_steps=40)
    cfg = FastSlamConfig(association="unknown", particles=10, std_range=0.05, std_bearing=math.radians(3.0))
    a = run_slam(cls(cfg), sc, rng=np.random.default_rng(2))
    b = run_slam(cls(cfg), sc, rng=np.random.default_rng(2))
    np.testing.assert_array_equal(a.landmarks, b.landmarks)
    err = map_errors(sc, a, association="unknown")
    assert math.isnan(err.rms_mm) and err.n_mapped == len(a.landmarks)
    from faultlab.metrics import earth_movers_distance
    assert err.emd_mm == pytest.approx(1000 * earth_movers_distance(sc.landmarks, a.landmarks))
    assert cls.supports_batch is False and cls.association == "unknown"
