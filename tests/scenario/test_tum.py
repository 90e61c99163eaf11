"""TUM trajectory files: read back by evo's own reader to the same numbers; odometry integration."""

import numpy as np
import pytest

from faultlab.errors import ScenarioError
from faultlab.scenario.tum import odometry_poses, read_tum, step_times, write_tum

file_interface = pytest.importorskip("evo.tools.file_interface")


def _angle_diff(a, b):
    return (np.asarray(a) - np.asarray(b) + np.pi) % (2 * np.pi) - np.pi


def test_evo_reads_a_written_trajectory_to_the_same_numbers(tmp_path):
    rng = np.random.default_rng(1)
    poses = np.column_stack([rng.normal(0, 10, 50), rng.normal(0, 10, 50), rng.uniform(-20, 20, 50)])
    times = step_times(49)
    path = write_tum(tmp_path / "t.tum", times, poses)
    traj = file_interface.read_tum_trajectory_file(str(path))
    np.testing.assert_array_equal(traj.timestamps, times)
    np.testing.assert_array_equal(traj.positions_xyz[:, :2], poses[:, :2])
    assert np.all(traj.positions_xyz[:, 2] == 0)
    yaw = np.array([np.arctan2(R[1, 0], R[0, 0]) for R in traj.poses_se3])
    assert np.abs(_angle_diff(yaw, poses[:, 2])).max() < 1e-12
    t, back = read_tum(path)
    np.testing.assert_array_equal(t, times)
    np.testing.assert_array_equal(back[:, :2], poses[:, :2])
    assert np.abs(_angle_diff(back[:, 2], poses[:, 2])).max() < 1e-12


def test_odometry_of_noise_free_controls_is_the_true_path():
    rng = np.random.default_rng(2)
    start = np.array([1.0, -2.0, 0.4])
    u = np.column_stack([rng.uniform(0, 0.3, 40), rng.uniform(-0.5, 0.5, 40)])
    # a slow textbook transcription of the motion model: drive along the heading, then turn
    path = [start]
    for v, w in u:
        x, y, th = path[-1]
        path.append(np.array([x + v * np.cos(th), y + v * np.sin(th), th + w]))
    np.testing.assert_allclose(odometry_poses(start, u), np.array(path), rtol=0, atol=1e-12)


def test_a_malformed_file_is_refused(tmp_path):
    (tmp_path / "bad.tum").write_text("0 1 2 3\n")
    with pytest.raises(ScenarioError, match="expected 8 columns"):
        read_tum(tmp_path / "bad.tum")
    with pytest.raises(ScenarioError, match=r"shape \(N, 3\)"):
        write_tum(tmp_path / "x.tum", [0.0], np.zeros((1, 2)))
