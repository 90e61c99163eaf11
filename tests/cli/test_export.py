"""``python -m faultlab export``: a ROS 2 bag, TUM files and a protocol transcript of saved cases; refusals
write nothing."""

import subprocess

import numpy as np
import pytest

from faultlab.cli import main
from faultlab.scenario import write_suite
from faultlab.scenario.rosbag import read_bag
from faultlab.scenario.tum import odometry_poses, read_tum
from faultlab.slam import run_slam
from faultlab.slam.process import ProcessSlam, ProcessSlamConfig, draw_seed, estimate_from_reply
from tests.processslam import example_slam  # noqa: F401  (fixture)


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    return write_suite("random", seed=5, out=tmp_path_factory.mktemp("suite"), n_steps=40, n_cases=2)


def test_export_rosbag2_reads_back_to_the_cases_numbers(suite, tmp_path, capsys):
    assert main(["export", *map(str, suite.paths), "--format", "rosbag2", "--out", str(tmp_path)]) == 0
    assert capsys.readouterr().out.split() == [str(tmp_path / "case1"), str(tmp_path / "case2")]
    for i, scenario in enumerate(suite.scenarios, start=1):
        back = read_bag(tmp_path / f"case{i}")
        for name in ("controls", "obs_offsets", "obs_range", "obs_bearing", "obs_ids", "landmarks"):
            np.testing.assert_array_equal(getattr(back, name), getattr(scenario, name))


def test_export_tum_writes_the_true_and_the_odometry_trajectory(suite, tmp_path):
    assert main(["export", str(suite.paths[0].with_suffix("")), "--format", "tum", "--out", str(tmp_path)]) == 0
    sc = suite.scenarios[0]
    t, truth = read_tum(tmp_path / "case1.groundtruth.tum")
    np.testing.assert_array_equal(t, np.arange(sc.n_steps + 1))
    np.testing.assert_array_equal(truth[:, :2], sc.true_poses[:, :2])
    _, odo = read_tum(tmp_path / "case1.odometry.tum")
    np.testing.assert_array_equal(odo[:, :2], odometry_poses(sc.start_pose, sc.controls)[:, :2])


def test_export_jsonl_run_standalone_gives_the_adapters_estimate(suite, tmp_path, example_slam):
    rng_seed = 9
    seed = draw_seed(np.random.default_rng(rng_seed))
    assert main(["export", str(suite.paths[1]), "--format", "jsonl", "--out", str(tmp_path),
                 "--seed", str(seed)]) == 0
    with open(tmp_path / "case2.jsonl") as fh:
        done = subprocess.run([str(example_slam)], stdin=fh, capture_output=True, text=True, check=True)
    alone = estimate_from_reply(done.stdout.splitlines()[-1])
    slam = ProcessSlam(ProcessSlamConfig(command=(str(example_slam),)))
    est = run_slam(slam, suite.scenarios[1], rng=np.random.default_rng(rng_seed))
    np.testing.assert_array_equal(est.pose, alone.pose)
    np.testing.assert_array_equal(est.landmark_ids, alone.landmark_ids)
    np.testing.assert_array_equal(est.landmarks, alone.landmarks)


def test_export_refuses_before_writing_anything(suite, tmp_path, capsys):
    (tmp_path / "case2.jsonl").write_text("mine\n")
    assert main(["export", *map(str, suite.paths), "--format", "jsonl", "--out", str(tmp_path)]) == 1
    assert "case2.jsonl already exists" in capsys.readouterr().err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["case2.jsonl"]
    assert (tmp_path / "case2.jsonl").read_text() == "mine\n"
    assert main(["export", str(suite.paths[0]), "--format", "tum", "--seed", "3", "--out", str(tmp_path)]) == 1
    assert "--seed applies to --format jsonl only" in capsys.readouterr().err
    assert main(["export", str(tmp_path / "nothing"), "--format", "tum", "--out", str(tmp_path / "o")]) == 1
    assert "missing file" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_the_ate_of_exported_odometry_equals_evo_ape_on_the_same_files(suite, tmp_path):
    evo_metrics = pytest.importorskip("evo.core.metrics")
    file_interface = pytest.importorskip("evo.tools.file_interface")
    from faultlab.metrics.trajectory import absolute_trajectory_error

    assert main(["export", str(suite.paths[0]), "--format", "tum", "--out", str(tmp_path)]) == 0
    ref = file_interface.read_tum_trajectory_file(str(tmp_path / "case1.groundtruth.tum"))
    est = file_interface.read_tum_trajectory_file(str(tmp_path / "case1.odometry.tum"))
    est.align(ref, correct_scale=False)
    ape = evo_metrics.APE(evo_metrics.PoseRelation.translation_part)
    ape.process_data((ref, est))
    _, truth = read_tum(tmp_path / "case1.groundtruth.tum")
    _, odo = read_tum(tmp_path / "case1.odometry.tum")
    ours = absolute_trajectory_error(truth[:, :2], odo[:, :2])
    assert ours.rmse > 0  # the case's odometry has noise: something to measure
    assert abs(ours.rmse - ape.get_statistic(evo_metrics.StatisticsType.rmse)) <= 1e-9
