"""iSAM text files as scenarios without ground truth; every truth-based metric and oracle refuses them by name."""

import math

import numpy as np
import pytest

from faultlab.errors import NoGroundTruthError, ScenarioError
from faultlab.metamorphic import HalvedNoise, IdPermutation, RigidMotion, Verdict, check_relation
from faultlab.metamorphic.relation import map_error, truth_estimate
from faultlab.metrics import map_errors
from faultlab.metrics.trajectory import trajectory_error_mm
from faultlab.scenario.isam import read_isam, victoria_park, victoria_park_file
from faultlab.scenario.model import load_scenario, save_scenario
from faultlab.slam import DeadReckoning, EkfSlam, run_slam
from faultlab.slam.ekf import EkfSlamConfig

SMALL = """\
ODOMETRY 0 1 1.0 0.01 0.5 0.0001 0 0 4e-06 0 4e-06
LANDMARK 1 7 3.0 4.0 0.4 0 0.4
LANDMARK 1 2 1.0 0.0 0.4 0 0.4
ODOMETRY 1 3 2.0 -0.02 0.0 0.0001 0 0 4e-06 0 4e-06
ODOMETRY 3 4 0.5 0.0 -0.25 0.0001 0 0 4e-06 0 4e-06
LANDMARK 4 7 0.0 -2.0 0.4 0 0.4
"""


@pytest.fixture
def small(tmp_path):
    path = tmp_path / "small.txt"
    path.write_text(SMALL)
    return read_isam(path)


def test_records_become_steps_and_observations_by_hand(small):
    assert small.n_steps == 3 and not small.has_truth
    np.testing.assert_array_equal(small.controls, [[1.0, 0.5], [2.0, 0.0], [0.5, -0.25]])
    np.testing.assert_array_equal(small.obs_offsets, [0, 2, 2, 3])
    np.testing.assert_array_equal(small.obs_ids, [2, 7, 7])  # step 0's by id
    np.testing.assert_allclose(small.obs_range, [1.0, 5.0, 2.0])
    np.testing.assert_allclose(small.obs_bearing, [0.0, math.atan2(4, 3), -math.pi / 2])
    np.testing.assert_array_equal(small.landmark_ids, [2, 7])
    assert np.isnan(small.landmarks).all() and np.isnan(small.true_poses[1:]).all()
    np.testing.assert_array_equal(small.start_pose, [0, 0, 0])
    assert small.meta["isam"]["dropped_dy_m"] == pytest.approx(0.03)
    assert small.meta["noise"]["std_v"] == pytest.approx(0.01)
    assert small.meta["noise"]["std_range"] == pytest.approx(math.sqrt(0.4))
    assert small.meta["noise"]["std_bearing_deg"] == pytest.approx(math.degrees(math.sqrt(0.04)))


def test_a_scenario_without_truth_survives_a_save_and_load(small, tmp_path):
    back = load_scenario(save_scenario(small, tmp_path / "vp"))
    assert not back.has_truth and np.array_equal(back.obs_range, small.obs_range)


@pytest.mark.parametrize("text, words", [
    ("ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\nODOMETRY 2 3 1 0 0 1 0 0 1 0 1\n", "not one chain"),
    ("ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\nLANDMARK 5 1 1 1 1 0 1\n", "pose 5"),
    ("ODOMETRY 0 1 1 0 0 1 0 0 1 0 1\nLANDMARK 1 1 1 1 1 0 1\nLANDMARK 1 1 2 1 1 0 1\n", "twice from one pose"),
    ("ODOMETRY 0 1 1 0 0\n", "line 1"),
    ("LANDMARK 1 1 1 1 1 0 1\n", "no ODOMETRY"),
])
def test_damaged_files_are_refused_naming_what_is_wrong(tmp_path, text, words):
    path = tmp_path / "bad.txt"
    path.write_text(text)
    with pytest.raises(ScenarioError, match=words):
        read_isam(path)


def test_truth_based_metrics_and_oracles_say_they_need_the_truth(small):
    est = run_slam(DeadReckoning(), small, rng=np.random.default_rng(0))
    for call in (lambda: map_errors(small, est), lambda: trajectory_error_mm(small, est),
                 lambda: map_error(small, est), lambda: truth_estimate(small)):
        with pytest.raises(NoGroundTruthError, match="needs the ground truth, and small has none"):
            call()
    with pytest.raises(NoGroundTruthError, match="halved_noise"):
        check_relation(DeadReckoning, HalvedNoise(), small, rngs=[np.random.default_rng(i) for i in range(2)])


@pytest.mark.parametrize("relation", [RigidMotion(angle=0.7, translation=(3.0, -2.0)), IdPermutation()])
def test_truth_free_relations_run_on_a_scenario_without_truth(small, relation):
    res = check_relation(lambda: EkfSlam(EkfSlamConfig()), relation, small,
                         rngs=[np.random.default_rng(i) for i in range(2)])
    assert res.verdict == Verdict.HOLDS


def test_victoria_park_comes_from_the_gtsam_wheel():
    pytest.importorskip("gtsam", reason="Victoria Park is read from the gtsam wheel (the [gtsam] extra)")
    lines = victoria_park_file().read_text().splitlines()
    vp = victoria_park()
    assert vp.n_steps == sum(line.startswith("ODOMETRY") for line in lines)
    assert vp.obs_range.size == sum(line.startswith("LANDMARK") for line in lines)
    assert vp.landmark_ids.size == len({line.split()[2] for line in lines if line.startswith("LANDMARK")})
    assert not vp.has_truth
