"""``python -m faultlab faults`` lists every fault; ``--check`` exits non-zero on equivalent mutants."""

import subprocess
import sys

from faultlab.cli import main
from faultlab.faults import all_faults


def test_faults_lists_every_fault_with_step_origin_and_description(capsys):
    assert main(["faults"]) == 0
    out = capsys.readouterr().out
    faults = all_faults()
    assert len(faults) >= 12
    lines = out.splitlines()
    for f in faults:
        row = next((line for line in lines if line.split()[:1] == [f.name]), None)
        assert row is not None, f"{f.name} not listed"
        assert f.step in row and f.description in row
        assert f"origin: {f.origin}" in out
    assert "example/double_range_offset" in out  # the installed example plugin
    assert f"{len(faults)} faults" in out


def test_faults_verbose_shows_rationales(capsys):
    assert main(["faults", "-v", "--no-plugins"]) == 0
    out = capsys.readouterr().out
    for f in all_faults(plugins=False):
        assert f.rationale in out
    assert "example/" not in out


def test_faults_check_exit_status(capsys):
    ok = main(["faults", "--check", "--steps", "30", "--particles", "20", "--repetitions", "1",
               "motion_sign_error", "missing_angle_wrap"])
    out = capsys.readouterr().out
    assert ok == 0 and "all 2 faults change the output" in out
    bad = main(["faults", "--check", "--steps", "30", "--particles", "20", "--repetitions", "1",
                "motion_sign_error", "tests.faults.test_check:IDENTITY"])
    out = capsys.readouterr().out
    assert bad == 1
    assert "EQUIVALENT" in out and "test/identity" in out


def test_unknown_fault_is_a_clear_error(capsys):
    assert main(["faults", "--check", "motion_sign_eror"]) == 2  # a usage error
    err = capsys.readouterr().err
    assert "unknown fault 'motion_sign_eror'" in err and "did you mean 'motion_sign_error'" in err
    assert err.count("\n") == 1 and err.startswith("faultlab: error: ")


def test_module_entry_point_runs():
    proc = subprocess.run([sys.executable, "-m", "faultlab", "faults", "--no-plugins"], capture_output=True,
                          text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert "naive_resampling" in proc.stdout and "motion_sign_error" in proc.stdout


def test_faults_lists_only_the_selected_faults(capsys):
    assert main(["faults", "missing_angle_wrap", "tests.faults.test_check:IDENTITY", "-v"]) == 0
    out = capsys.readouterr().out
    assert "missing_angle_wrap  (step: wrap_bearing; built-in)" in out
    assert "test/identity  (step: resample; import path)" in out
    assert "naive_resampling" not in out and "2 faults" in out


def test_faults_slam_lists_only_the_applicable_faults_and_says_why_others_are_left_out(capsys):
    assert main(["faults", "--no-plugins", "--slam", "ekf"]) == 0
    out = capsys.readouterr().out
    listed = {line.split()[0] for line in out.splitlines() if line and not line.startswith(" ")}
    for f in all_faults(plugins=False):
        applies = f.step in {"motion_model", "wrap_heading", "wrap_bearing", "init_landmarks",
                             "predict_measurement", "innovation", "motion_jacobians", "predict_covariance",
                             "pose_jacobian", "cross_covariance", "joint_innovation_covariance",
                             "kalman_update", "augment_state"}  # EKF-SLAM's units, written out
        assert (f.name in listed) == applies, f.name
    n_out = sum(1 for f in all_faults(plugins=False) if f.name not in listed)
    assert f"{n_out} of {len(all_faults(plugins=False))} faults do not apply to 'ekf'" in out
    assert "resample (naive_resampling, inverted_resampling_threshold)" in out
    assert main(["faults", "--no-plugins", "--slam", "fastslam"]) == 0
    assert f"all {len(all_faults(plugins=False))} faults apply to 'fastslam'" in capsys.readouterr().out
    assert main(["faults", "--no-plugins", "--slam", "dead_reckoning"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("0 faults") and "do not apply to 'dead_reckoning': it has no replaceable units" in out
    assert main(["faults", "--slam", "nope"]) == 2
    assert "slam: unknown SLAM 'nope'. Known SLAMs: fastslam, " in capsys.readouterr().err


def test_faults_lists_the_sensor_faults_in_their_own_section(capsys):
    from faultlab.faults import all_sensor_faults

    assert main(["faults", "--no-plugins"]) == 0
    out = capsys.readouterr().out
    head, _, section = out.partition("Sensor and hardware faults")
    sensor = all_sensor_faults(plugins=False)
    for f in sensor:
        assert f.description in section and f.description not in head
        assert f.parameter_text() in section
    assert f"{len(sensor)} sensor and hardware faults" in section


def test_faults_for_a_slam_drops_a_hardware_limit_it_has_no_option_for(capsys):
    assert main(["faults", "--no-plugins", "--slam", "ekf"]) == 0
    section = capsys.readouterr().out.partition("Sensor and hardware faults")[2]
    assert "obs_dropout" in section and "particle_budget" not in section
    assert main(["faults", "--no-plugins", "--slam", "fastslam"]) == 0
    assert "particle_budget" in capsys.readouterr().out


def test_faults_check_runs_sensor_faults_on_their_stream_and_option(capsys):
    code = main(["faults", "--check", "--steps", "30", "--particles", "20", "--repetitions", "1",
                 "obs_dropout", "particle_budget"])
    out = capsys.readouterr().out
    rows = {line.split()[0]: line for line in out.splitlines() if line.split()}
    assert code == 0 and "all 2 faults change the output" in out
    assert "sensor stream" in rows["obs_dropout"] and "differs" in rows["obs_dropout"]
    assert "slam option particles" in rows["particle_budget"] and "differs" in rows["particle_budget"]
