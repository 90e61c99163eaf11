"""MRPT's range-bearing EKF-SLAM behind the process protocol (examples/mrpt-kfslam): exact on noise-free data,
its map frame mapped back onto faultlab's, and close to faultlab's own EKF-SLAM where the two filters agree."""

import dataclasses

import numpy as np
import pytest

from faultlab.scenario import generate_scenario
from faultlab.slam import DeadReckoning, run_slam
from faultlab.slam.process import ProcessSlam, ProcessSlamConfig
from faultlab.space import FIXED_VALUES, CaseSpec
from tests.mrptslam import mrpt_kfslam  # noqa: F401  (fixture)


def _case(seed, n_steps=40):
    values = {**FIXED_VALUES, "map_size": 10.0, "landmark_density": 2.0}
    return generate_scenario(CaseSpec(values), rng=np.random.default_rng(seed), n_steps=n_steps)


def _run(program, case):
    slam = ProcessSlam(ProcessSlamConfig.from_options({"command": [str(program)]}))
    try:
        return run_slam(slam, case, rng=np.random.default_rng(0))
    finally:
        slam.close()


def _exact(case):
    """The case with exact controls and observations (from its true poses and landmarks)."""
    poses = case.true_poses
    step = np.repeat(np.arange(case.n_steps), np.diff(case.obs_offsets))
    order = np.argsort(case.landmark_ids)
    d = case.landmarks[order][np.searchsorted(case.landmark_ids[order], case.obs_ids)] - poses[step + 1, :2]
    return dataclasses.replace(case, controls=np.column_stack([np.hypot(*np.diff(poses[:, :2], axis=0).T),
                                                               np.diff(poses[:, 2])]),
                               obs_range=np.hypot(d[:, 0], d[:, 1]),
                               obs_bearing=np.arctan2(d[:, 1], d[:, 0]) - poses[step + 1, 2])


def test_noise_free_data_gives_the_truth_to_float_precision(mrpt_kfslam):
    case = _exact(_case(1))
    est = _run(mrpt_kfslam, case)
    order = np.argsort(case.landmark_ids)
    truth = case.landmarks[order][np.searchsorted(case.landmark_ids[order], est.landmark_ids)]
    assert est.landmark_ids.size == np.unique(case.obs_ids).size
    np.testing.assert_allclose(est.landmarks, truth, atol=1e-4)  # MRPT stores ranges and bearings as float
    np.testing.assert_allclose(est.trajectory[:, :2], case.true_poses[1:, :2], atol=1e-4)


def test_the_motion_before_the_first_sighting_is_kept(mrpt_kfslam):
    # MRPT skips predictions while its map is empty; the front end composes them into its frame's origin
    case = _case(2)
    blind = 7
    cut = case.obs_offsets[blind]
    shifted = dataclasses.replace(case, obs_offsets=np.maximum(case.obs_offsets - cut, 0),
                                  obs_range=case.obs_range[cut:], obs_bearing=case.obs_bearing[cut:],
                                  obs_ids=case.obs_ids[cut:])
    est = _run(mrpt_kfslam, shifted)
    dead = run_slam(DeadReckoning(), dataclasses.replace(shifted, controls=shifted.controls[:blind],
                                                         obs_offsets=shifted.obs_offsets[:blind + 1]),
                    rng=np.random.default_rng(0))
    np.testing.assert_allclose(est.trajectory[blind - 1], dead.pose, atol=1e-9)
    assert est.trajectory.shape == (case.n_steps, 3)


def test_the_front_end_is_deterministic(mrpt_kfslam):
    case = _case(3)
    a, b = _run(mrpt_kfslam, case), _run(mrpt_kfslam, case)
    assert np.array_equal(a.landmarks, b.landmarks) and np.array_equal(a.pose, b.pose)
