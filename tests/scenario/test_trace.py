import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.errors import ScenarioError
from faultlab.scenario import drive, generate_scenario, measure_observations, wrap_angle
from faultlab.space import FIXED_VALUES, CaseSpec

NO_NOISE = dict(variance_distance=0.0, variance_angle=0.0, bias_distance=0.0, bias_angle=0.0,
                outlier_probability=0.0, rotation_error=0.0)


def _case(**over):
    return CaseSpec(dict(FIXED_VALUES, **over))


def _brute_force_visible(landmarks, ids, pose, sensor_range, fov):
    """Per-landmark check with math: (visible ids, range, bearing, ids near a boundary)."""
    x, y, th = pose
    vis, near = [], set()
    for (lx, ly), i in zip(landmarks, ids):
        r = math.hypot(lx - x, ly - y)
        b = math.atan2(ly - y, lx - x) - th
        b = (b + math.pi) % (2 * math.pi) - math.pi
        if abs(r - sensor_range) < 1e-9 or abs(abs(b) - fov / 2) < 1e-9:
            near.add(int(i))
        if r <= sensor_range and abs(b) <= fov / 2:
            vis.append((int(i), r, b))
    return vis, near


@settings(max_examples=15, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), fov=st.floats(math.pi / 2, 2 * math.pi),
       size=st.floats(4, 40), density=st.floats(1, 6), step=st.floats(25, 200),
       directionality=st.sampled_from(["random", "loop"]))
def test_noise_free_observations_equal_the_true_geometry(seed, fov, size, density, step, directionality):
    case = _case(field_of_view=fov, map_size=size, landmark_density=density, step_size=step,
                 directionality=directionality, **NO_NOISE)
    sc = generate_scenario(case, rng=np.random.default_rng(seed), n_steps=40)
    for t in range(sc.n_steps):
        r, b, ids = sc.observations(t)
        vis, near = _brute_force_visible(sc.landmarks, sc.landmark_ids, sc.true_poses[t + 1], 2.0, fov)
        got = {int(i) for i in ids} - near
        assert got == {v[0] for v in vis} - near  # every landmark in range and FoV, none outside
        assert list(ids) == sorted(ids)
        if vis:
            exp = {v[0]: v[1:] for v in vis}
            np.testing.assert_allclose(r, [exp[int(i)][0] for i in ids], rtol=0, atol=1e-12)
            np.testing.assert_allclose(b, [exp[int(i)][1] for i in ids], rtol=0, atol=1e-12)


def _integrate(controls, start):
    """Apply the motion model (drive v along the heading, then turn omega) to a control sequence."""
    poses = [np.asarray(start, float)]
    x, y, th = start
    for v, w in controls:
        x += v * math.cos(th)
        y += v * math.sin(th)
        th += w
        poses.append(np.array([x, y, th]))
    return np.array(poses)


def test_noise_free_controls_reproduce_the_true_path():
    sc = generate_scenario(_case(inactivity=30, **NO_NOISE), rng=np.random.default_rng(4), n_steps=80)
    p = _integrate(sc.controls, sc.start_pose)
    np.testing.assert_allclose(p[:, :2], sc.true_poses[:, :2], atol=1e-9)
    np.testing.assert_allclose(wrap_angle(p[:, 2] - sc.true_poses[:, 2]), 0.0, atol=1e-9)
    np.testing.assert_array_equal(sc.true_poses[0], [0.0, 0.0, 0.0])
    np.testing.assert_allclose(sc.controls[sc.controls[:, 0] != 0, 0], 0.8)  # step size 80 cm


@settings(max_examples=20, deadline=None)
@given(n_steps=st.integers(2, 120), idle=st.integers(1, 150), seed=st.integers(0, 2**32 - 1))
def test_inactivity_steps_sit_in_the_middle(n_steps, idle, seed):
    sc = generate_scenario(_case(inactivity=idle), rng=np.random.default_rng(seed), n_steps=n_steps)
    mid = n_steps // 2
    assert sc.n_steps == n_steps + idle
    zero = np.all(sc.controls == 0.0, axis=1)
    np.testing.assert_array_equal(np.flatnonzero(zero), np.arange(mid, mid + idle))
    n_obs = np.diff(sc.obs_offsets)
    assert np.all(n_obs[mid:mid + idle] == 0)
    np.testing.assert_array_equal(sc.true_poses[mid:mid + idle + 1], np.repeat(sc.true_poses[mid:mid + 1], idle + 1, 0))
    assert sc.meta["inactivity_start"] == mid


def _circle_map(n=8, radius=5.0, offset_deg=10.0, seed=0):
    angles = np.deg2rad(offset_deg + 360.0 * np.arange(n) / n)
    lm = radius * np.c_[np.cos(angles), np.sin(angles)]
    order = np.random.default_rng(seed).permutation(n)  # rows in shuffled order
    return lm[order], order


def test_loop_visits_a_circle_in_angular_order():
    lm, order = _circle_map()
    d = drive(lm, rng=np.random.default_rng(1), n_steps=300, step=0.5, fov=2 * math.pi, sensor_range=2.0,
              loop=True, path_turn_std=0.0)
    # landmark k of the circle (angle 10 + 45 k degrees) sits in row where order == k
    visited = order[d.targets]
    assert len(visited) > 10
    expected = np.arange(len(visited)) % 8
    np.testing.assert_array_equal(visited, expected)
    assert d.target_rounds.max() >= 1  # went round more than once


def test_random_traversal_is_not_in_angular_order():
    lm, order = _circle_map()
    d = drive(lm, rng=np.random.default_rng(1), n_steps=300, step=0.5, fov=2 * math.pi, sensor_range=2.0,
              loop=False, path_turn_std=0.0)
    first_round = order[d.targets[d.target_rounds == 0]]
    assert len(set(first_round)) == len(first_round) >= 3  # targets of a round are distinct
    assert np.any(np.diff(first_round) < 0)  # but not in angular order


def _ccw_offsets_per_round(lm, d):
    """ccw angle of each target from the round's start angle (previous target's angle, 0 at first)."""
    polar = np.mod(np.arctan2(lm[:, 1], lm[:, 0]), 2 * math.pi)
    out = []
    for r in np.unique(d.target_rounds):
        sel = np.flatnonzero(d.target_rounds == r)
        start = 0.0 if sel[0] == 0 else polar[d.targets[sel[0] - 1]]
        offs = np.mod(polar[d.targets[sel]] - start, 2 * math.pi)
        if sel[0] > 0:  # the previous round's last target is visited last, a full turn on
            offs[d.targets[sel] == d.targets[sel[0] - 1]] = 2 * math.pi
        out.append(offs)
    return out


@settings(max_examples=20, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), side=st.floats(4, 14), n=st.integers(3, 150))
def test_loop_targets_go_round_the_centre_in_angular_order(seed, side, n):
    from faultlab.scenario import generate_landmarks

    rng = np.random.default_rng(seed)
    lm, ids = generate_landmarks(side=side, n_landmarks=n, rng=rng)
    d = drive(lm, ids, rng=rng, n_steps=200, step=0.6, fov=math.pi, sensor_range=2.0, loop=True)
    for offs in _ccw_offsets_per_round(lm, d):
        assert np.all(np.diff(offs) >= 0)


def test_random_order_breaks_the_angular_property():
    rng = np.random.default_rng(0)
    from faultlab.scenario import generate_landmarks

    lm, ids = generate_landmarks(side=12.0, n_landmarks=60, rng=rng)
    d = drive(lm, ids, rng=rng, n_steps=200, step=0.6, fov=math.pi, sensor_range=1.0, loop=False)
    assert any(np.any(np.diff(o) < 0) for o in _ccw_offsets_per_round(lm, d))


@pytest.mark.parametrize("loop", [False, True])
def test_each_target_is_seen_before_the_next_is_chosen(loop):
    from faultlab.scenario import generate_landmarks

    rng = np.random.default_rng(5)
    lm, ids = generate_landmarks(side=10.0, n_landmarks=120, rng=rng)
    d = drive(lm, ids, rng=rng, n_steps=300, step=0.7, fov=math.pi / 2, sensor_range=2.0, loop=loop)
    for k in range(len(d.targets) - 1):
        t = d.target_steps[k + 1] - 1  # the step after which target k had been seen
        seen = d.vis_index[d.vis_offsets[t]:d.vis_offsets[t + 1]]
        assert d.targets[k] in seen
    # a round ends only when every landmark has been seen
    for r in np.unique(d.target_rounds)[1:]:
        first = d.target_steps[np.flatnonzero(d.target_rounds == r)[0]]
        prev = d.target_steps[np.flatnonzero(d.target_rounds == r - 1)[0]]
        assert set(d.vis_index[d.vis_offsets[prev]:d.vis_offsets[first]]) == set(range(120))


def test_noise_bias_and_rotation_error_statistics():
    case = _case(map_size=200.0, landmark_density=8.0, field_of_view=2 * math.pi, variance_distance=50.0,
                 variance_angle=0.1, bias_distance=-20.0, bias_angle=0.03, outlier_probability=0.0,
                 rotation_error=2 * math.pi, step_size=50.0)
    sc = generate_scenario(case, rng=np.random.default_rng(8), n_steps=600, path_turn_std=0.0)
    # independent true geometry from the true poses
    step_of = np.repeat(np.arange(sc.n_steps), np.diff(sc.obs_offsets))
    pose = sc.true_poses[step_of + 1]
    lm = sc.landmarks[np.searchsorted(sc.landmark_ids, sc.obs_ids)]
    dx, dy = lm[:, 0] - pose[:, 0], lm[:, 1] - pose[:, 1]
    r_true = np.hypot(dx, dy)
    b_true = np.arctan2(dy, dx) - pose[:, 2]
    b_true = (b_true + math.pi) % (2 * math.pi) - math.pi
    ok = r_true > 0.2  # away from the clip at 0
    er = sc.obs_range[ok] - r_true[ok]
    eb = sc.obs_bearing - b_true
    assert len(er) > 10000
    assert abs(er.mean() - (-0.020)) < 0.002 and abs(er.std() - 0.050) < 0.002
    assert abs(eb.mean() - (0.03 + 2 * math.pi)) < 0.004 and abs(eb.std() - 0.1) < 0.004
    assert np.all(sc.obs_range >= 0)
    # controls: true turn is the bearing of the target (no path noise here); measured = true + noise
    dv = sc.controls[:, 0] - 0.5
    assert abs(dv.mean() + 0.020) < 0.008 and abs(dv.std() - 0.05) < 0.008
    true_turn = wrap_angle(np.diff(sc.true_poses[:, 2]))
    dw = sc.controls[:, 1] - true_turn
    dw = dw - 2 * math.pi * np.round((dw - 2 * math.pi) / (2 * math.pi))  # true turns may wrap by 2 pi
    assert abs(dw.mean() - (2 * math.pi + 0.03)) < 0.02 and abs(dw.std() - 0.1) < 0.01


def test_rotation_error_adds_exactly_two_pi_without_other_noise():
    base = _case(**NO_NOISE)
    neg = _case(**dict(NO_NOISE, rotation_error=-2 * math.pi))
    a = generate_scenario(base, rng=np.random.default_rng(3), n_steps=60)
    b = generate_scenario(neg, rng=np.random.default_rng(3), n_steps=60)
    np.testing.assert_array_equal(a.true_poses, b.true_poses)
    np.testing.assert_allclose(b.obs_bearing - a.obs_bearing, -2 * math.pi, atol=1e-12)
    np.testing.assert_allclose(b.controls[:, 1] - a.controls[:, 1], -2 * math.pi, atol=1e-12)
    np.testing.assert_array_equal(b.obs_range, a.obs_range)


def test_outliers():
    case = _case(map_size=100.0, landmark_density=6.0, outlier_probability=30.0, field_of_view=2 * math.pi,
                 variance_distance=0.0, variance_angle=0.0, bias_distance=0.0, bias_angle=0.0)
    rng = np.random.default_rng(2)
    sc = generate_scenario(case, rng=rng, n_steps=300)
    d = drive(sc.landmarks, sc.landmark_ids, rng=rng, n_steps=300, step=0.8, fov=math.pi * 2,
              sensor_range=2.0, loop=False)
    m = measure_observations(sc.landmarks, sc.landmark_ids, d, rng=rng, std_distance=0.0, std_angle=0.0,
                             bias_distance=0.0, bias_angle=0.0, outlier_probability=0.3, rotation_error=0.0,
                             sensor_range=2.0)
    n = m.outlier.size
    assert abs(m.outlier.mean() - 0.3) < 0.02
    np.testing.assert_array_equal(m.range[~m.outlier], m.true_range[~m.outlier])
    maxr = m.outlier & (m.range == 2.0) & (m.true_range < 2.0)
    assert abs(maxr.sum() / m.outlier.sum() - 0.5) < 0.03
    short = m.outlier & ~(m.range == 2.0)
    assert np.all(m.range[short] <= m.true_range[short]) and np.all(m.range[short] >= 0)
    # uniform in [0, true range]: the ratio is uniform on [0, 1]
    ratio = m.range[short] / m.true_range[short]
    assert abs(ratio.mean() - 0.5) < 0.03 and n > 1000
    np.testing.assert_array_equal(m.bearing, m.true_bearing)  # bearings are untouched by outliers
    # in the scenario too: ~30 % of observations deviate from the truth
    assert 0.25 < sc.meta["n_outliers"] / sc.meta["n_observations"] < 0.35


def test_empty_map_is_an_error():
    with pytest.raises(ScenarioError, match="no landmarks"):
        drive(np.empty((0, 2)), rng=np.random.default_rng(0), n_steps=5, step=1, fov=1, sensor_range=2,
              loop=False)


# --------------------------------------------------------------------------- the package's field-of-view defect


def _package_fov_test(angle, half_opening):
    """The replication package's test (simulator.py), angle wrapped to [-pi, pi) first."""
    angle = (angle + math.pi) % (2 * math.pi) - math.pi
    return min(angle, 2 * math.pi - angle) < half_opening


def test_in_field_of_view_with_the_bug_is_the_packages_expression():
    from faultlab.scenario.trace import in_field_of_view

    angles = np.linspace(-math.pi, math.pi, 721, endpoint=False) + 1e-7  # off the grid of boundaries
    for fov in (math.pi / 2, math.pi, 1.5 * math.pi, 2 * math.pi):
        bug = in_field_of_view(angles, fov, fov_bug=True)
        expected = [_package_fov_test(a, fov / 2) for a in angles]  # sensor_fov is the half opening
        np.testing.assert_array_equal(bug, expected)
        assert np.all(bug[angles < 0])  # every right-side bearing passes, whatever the opening
        np.testing.assert_array_equal(in_field_of_view(angles, fov), np.abs(angles) <= fov / 2)


def _brute_force_visible_with_bug(landmarks, ids, pose, sensor_range, fov):
    """Per landmark, the package's visibility: (visible ids, ids near a boundary)."""
    x, y, th = pose
    vis, near = set(), set()
    for (lx, ly), i in zip(landmarks, ids):
        r = math.hypot(lx - x, ly - y)
        b = math.atan2(ly - y, lx - x) - th
        if abs(r - sensor_range) < 1e-9 or abs(((b + math.pi) % (2 * math.pi) - math.pi) - fov / 2) < 1e-9:
            near.add(int(i))
        if r <= sensor_range and _package_fov_test(b, fov / 2):
            vis.add(int(i))
    return vis, near


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), fov=st.floats(math.pi / 2, 1.5 * math.pi))
def test_fov_bug_observes_every_right_side_landmark_in_range(seed, fov):
    case = _case(field_of_view=fov, map_size=36.0, **NO_NOISE)
    bug = generate_scenario(case, rng=np.random.default_rng(seed), n_steps=40, fov_bug=True)
    n_right_outside = n_expected = 0
    for t in range(bug.n_steps):
        r, b, ids = bug.observations(t)
        vis, near = _brute_force_visible_with_bug(bug.landmarks, bug.landmark_ids, bug.true_poses[t + 1], 2.0, fov)
        assert {int(i) for i in ids} - near == vis - near
        n_right_outside += int(np.sum(b < -fov / 2))  # observed although outside the opening
        pose = bug.true_poses[t + 1]
        for (lx, ly), i in zip(bug.landmarks, bug.landmark_ids):  # brute force: right side, outside, in range
            bb = (math.atan2(ly - pose[1], lx - pose[0]) - pose[2] + math.pi) % (2 * math.pi) - math.pi
            if math.hypot(lx - pose[0], ly - pose[1]) <= 2.0 and bb < -fov / 2 and int(i) not in near:
                n_expected += 1
    assert n_right_outside == n_expected and n_expected > 0
    assert bug.fov_bug and bug.meta["config"]["fov_bug"] is True


def test_fov_bug_is_off_by_default_and_the_default_is_unchanged():
    case = _case(**NO_NOISE)
    default = generate_scenario(case, rng=np.random.default_rng(4), n_steps=60)
    explicit = generate_scenario(case, rng=np.random.default_rng(4), n_steps=60, fov_bug=False)
    bug = generate_scenario(case, rng=np.random.default_rng(4), n_steps=60, fov_bug=True)
    assert not default.fov_bug and default.meta["config"]["fov_bug"] is False
    for name in ("landmarks", "true_poses", "controls", "obs_offsets", "obs_range", "obs_bearing", "obs_ids"):
        np.testing.assert_array_equal(getattr(default, name), getattr(explicit, name))
    fov = FIXED_VALUES["field_of_view"]
    assert np.all(np.abs(default.obs_bearing) <= fov / 2 + 1e-12)  # nothing outside the opening by default
    assert np.sum(bug.obs_bearing < -fov / 2) > 0  # the defect sees behind on the right
    assert bug.obs_range.size > default.obs_range.size
    with pytest.raises(ScenarioError, match="fov_bug"):
        generate_scenario(case, rng=np.random.default_rng(4), n_steps=5, fov_bug="yes")


def test_fov_bug_is_recorded_in_the_saved_scenario_and_loaded_back(tmp_path):
    from faultlab.scenario import load_scenario, save_scenario

    for flag in (True, False):
        sc = generate_scenario(_case(), rng=np.random.default_rng(2), n_steps=20, fov_bug=flag)
        loaded = load_scenario(save_scenario(sc, tmp_path / f"case_{flag}"))
        assert loaded.fov_bug is flag and loaded.meta["config"]["fov_bug"] is flag
        np.testing.assert_array_equal(loaded.obs_bearing, sc.obs_bearing)
