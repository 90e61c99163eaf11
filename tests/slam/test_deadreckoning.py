"""Tests of the dead-reckoning baseline (faultlab.slam.deadreckoning)."""

import math

import numpy as np
import pytest

from faultlab.errors import SlamInputError
from faultlab.scenario import generate_scenario
from faultlab.slam import DeadReckoning, Observations, run_slam
from faultlab.space.case import FIXED_VALUES, CaseSpec


def test_noise_free_trace_is_reproduced_exactly():
    zero = dict(FIXED_VALUES, variance_distance=0.0, variance_angle=0.0, outlier_probability=0.0)
    sc = generate_scenario(CaseSpec(zero), rng=np.random.default_rng(0), n_steps=200)
    est = run_slam(DeadReckoning(), sc, rng=np.random.default_rng(0))
    np.testing.assert_allclose(est.pose[:2], sc.true_poses[-1, :2], atol=1e-9)
    assert abs((est.pose[2] - sc.true_poses[-1, 2] + math.pi) % (2 * math.pi) - math.pi) < 1e-9
    truth = dict(zip(sc.landmark_ids.tolist(), sc.landmarks))
    assert set(est.landmark_ids.tolist()) == set(np.unique(sc.obs_ids).tolist())
    np.testing.assert_allclose(est.landmarks, [truth[i] for i in est.landmark_ids], atol=1e-9)


def test_landmark_is_the_mean_of_its_projected_observations():
    dr = DeadReckoning()
    dr.reset([1.0, 0.0, math.pi / 2], rng=np.random.default_rng(0))
    dr.step([0.0, 0.0], Observations([2.0, 1.0], [0.0, -math.pi / 2], [50, -3]))  # from (1, 0), heading up
    dr.step([1.0, -math.pi / 2], Observations([1.0], [2 * math.pi], [50]))  # now at (1, 1), heading 0
    dr.step([0.5, 0.0])
    est = dr.estimate()
    got = est.as_dict()
    assert sorted(got) == [-3, 50]
    np.testing.assert_allclose(got[-3], (2.0, 0.0), atol=1e-12)
    np.testing.assert_allclose(got[50], ((1.0 + 2.0) / 2, (2.0 + 1.0) / 2), atol=1e-12)
    np.testing.assert_allclose(est.pose, [1.5, 1.0, 0.0], atol=1e-12)


def test_rng_is_not_used_and_bad_input_is_rejected():
    sc = generate_scenario(CaseSpec(FIXED_VALUES), rng=np.random.default_rng(1), n_steps=50)
    a = run_slam(DeadReckoning(), sc, rng=np.random.default_rng(1))
    b = run_slam(DeadReckoning(), sc, rng=np.random.default_rng(2))
    np.testing.assert_array_equal(a.landmarks, b.landmarks)
    dr = DeadReckoning()
    with pytest.raises(SlamInputError, match="reset"):
        dr.step([0.0, 0.0])
    dr.reset([0.0, 0.0, 0.0], rng=None)
    with pytest.raises(SlamInputError, match="negative range"):
        dr.step([0.1, 0.0], ([-1.0], [0.0], [4]))
    with pytest.raises(SlamInputError, match="start pose"):
        dr.reset([0.0, 0.0], rng=None)
