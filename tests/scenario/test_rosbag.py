"""A case written as a ROS 2 bag reads back with rosbags to the same numbers, on the documented topics."""

import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from faultlab.errors import ScenarioError
from faultlab.scenario import write_suite
from faultlab.scenario.rosbag import TOPICS, read_bag, write_bag
from faultlab.scenario.tum import odometry_poses

rosbags = pytest.importorskip("rosbags")


@pytest.fixture(scope="module")
def scenario(tmp_path_factory):
    return write_suite("random", seed=11, out=tmp_path_factory.mktemp("suite"), n_steps=60, n_cases=1).scenarios[0]


def _angle_diff(a, b):
    return (np.asarray(a) - np.asarray(b) + np.pi) % (2 * np.pi) - np.pi


def test_a_bag_reads_back_to_the_same_numbers(scenario, tmp_path):
    write_bag(scenario, tmp_path / "bag")
    back = read_bag(tmp_path / "bag")
    for name in ("controls", "obs_offsets", "obs_range", "obs_bearing", "obs_ids", "landmark_ids", "landmarks"):
        np.testing.assert_array_equal(getattr(back, name), getattr(scenario, name), err_msg=name)
    np.testing.assert_array_equal(back.true_poses[:, :2], scenario.true_poses[:, :2])
    assert np.abs(_angle_diff(back.true_poses[:, 2], scenario.true_poses[:, 2])).max() < 1e-12
    odo = odometry_poses(scenario.start_pose, scenario.controls)[1:]
    np.testing.assert_array_equal(back.odometry[:, :2], odo[:, :2])
    assert np.abs(_angle_diff(back.odometry[:, 2], odo[:, 2])).max() < 1e-12
    T = scenario.n_steps
    assert back.stamps["/odom"].tolist() == [(t + 1) * 10 ** 9 for t in range(T)]
    assert back.stamps["/ground_truth/pose"].tolist() == [t * 10 ** 9 for t in range(T + 1)]


def test_the_bag_has_the_documented_topics_and_types_readable_without_registering_them(scenario, tmp_path):
    from rosbags.highlevel import AnyReader

    write_bag(scenario, tmp_path / "bag")
    with AnyReader([tmp_path / "bag"]) as reader:  # the custom types come from the bag itself
        assert {c.topic: c.msgtype for c in reader.connections} == TOPICS
        counts = {c.topic: c.msgcount for c in reader.connections}
        obs = next(c for c in reader.connections if c.topic == "/observations")
        first = reader.deserialize(next(reader.messages(connections=[obs]))[2], obs.msgtype)
    assert counts == {"/odom": scenario.n_steps, "/observations": scenario.n_steps,
                      "/ground_truth/pose": scenario.n_steps + 1, "/ground_truth/landmarks": 1}
    a, b = scenario.obs_offsets[:2]
    np.testing.assert_array_equal(first.ranges, scenario.obs_range[a:b])


def test_an_existing_directory_is_never_overwritten(scenario, tmp_path):
    (tmp_path / "bag").mkdir()
    with pytest.raises(ScenarioError, match="already exists"):
        write_bag(scenario, tmp_path / "bag")
    assert list((tmp_path / "bag").iterdir()) == []


@settings(max_examples=8, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_any_case_round_trips_including_empty_steps_and_no_steps(tmp_path, data):
    from faultlab.scenario.model import Scenario
    from faultlab.space import FIXED_VALUES, CaseSpec

    T = data.draw(st.integers(0, 6))
    counts = data.draw(st.lists(st.integers(0, 4), min_size=T, max_size=T))
    M = sum(counts)
    floats = st.floats(-1e3, 1e3, allow_nan=False)
    arr = lambda n, elements=floats: np.array(data.draw(st.lists(elements, min_size=n, max_size=n)), dtype=float)
    L = data.draw(st.integers(0, 5))
    sc = Scenario(case=CaseSpec(FIXED_VALUES), seed=None,
                  landmarks=arr(2 * L).reshape(L, 2),
                  landmark_ids=np.array(data.draw(st.lists(st.integers(-2 ** 62, 2 ** 62), min_size=L, max_size=L,
                                                           unique=True)), dtype=np.int64),
                  true_poses=arr(3 * (T + 1)).reshape(T + 1, 3), controls=arr(2 * T).reshape(T, 2),
                  obs_offsets=np.concatenate([[0], np.cumsum(counts)]).astype(np.int64),
                  obs_range=arr(M, st.floats(0, 1e3)), obs_bearing=arr(M),
                  obs_ids=np.array(data.draw(st.lists(st.integers(0, 2 ** 62), min_size=M, max_size=M)),
                                   dtype=np.int64))
    path = Path(tempfile.mkdtemp(dir=tmp_path)) / "bag"
    write_bag(sc, path)
    back = read_bag(path)
    for name in ("controls", "obs_offsets", "obs_range", "obs_bearing", "obs_ids", "landmark_ids", "landmarks"):
        np.testing.assert_array_equal(getattr(back, name), getattr(sc, name), err_msg=name)
    np.testing.assert_array_equal(back.true_poses[:, :2], sc.true_poses[:, :2])
    assert np.all(np.abs(_angle_diff(back.true_poses[:, 2], sc.true_poses[:, 2])) < 1e-9)
