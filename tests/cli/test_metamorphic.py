"""``python -m faultlab metamorphic`` prints the relation x fault matrix."""

import pytest

from faultlab.cli import main


def test_metamorphic_matrix_for_two_faults(capsys):
    code = main(["metamorphic", "--steps", "40", "--repetitions", "2", "--particles", "20", "--no-plugins",
                 "--faults", "missing_angle_wrap", "naive_resampling", "--relations", "bearing_turn", "id_permutation"])
    out = capsys.readouterr().out
    assert code == 0  # the unmodified FastSLAM keeps every relation
    assert "SLAM 'fastslam' (20 particles)" in out and "40 steps, seed 0); 2 repetitions" in out
    rows = {line.split()[0]: line.split()[1:] for line in out.splitlines() if line.split()}
    assert rows["baseline"][0::2] == ["holds", "holds"]
    assert rows["missing_angle_wrap"][0] == "VIOLATED"  # bearing_turn
    assert rows["naive_resampling"][0::2] == ["holds", "holds"]
    assert "bearing_turn (exact): violated by missing_angle_wrap" in out
    assert "id_permutation (exact): violated by no fault" in out


def test_metamorphic_says_which_faults_do_not_apply(capsys):
    code = main(["metamorphic", "--slam", "dead_reckoning", "--steps", "20", "--repetitions", "2", "--no-plugins",
                 "--relations", "rigid_motion"])
    out = capsys.readouterr().out
    assert code == 0
    assert "faults do not apply to 'dead_reckoning': it has no replaceable units" in out
    assert [line.split()[0] for line in out.splitlines()].count("baseline") == 1


@pytest.mark.parametrize("option", ["--repetitions", "--reps"])  # the former spelling still parses
def test_metamorphic_refuses_a_single_repetition(capsys, option):
    assert main(["metamorphic", option, "1"]) == 1
    assert "--repetitions must be >= 2" in capsys.readouterr().err


def test_metamorphic_runs_a_stream_fault_and_refuses_a_hardware_limit(capsys):
    code = main(["metamorphic", "--steps", "20", "--repetitions", "2", "--particles", "20", "--no-plugins",
                 "--faults", "obs_dropout", "--relations", "rigid_motion"])
    out = capsys.readouterr().out
    assert code == 0 and [line.split()[0] for line in out.splitlines()].count("obs_dropout") == 1
    assert main(["metamorphic", "--steps", "20", "--repetitions", "2", "--no-plugins",
                 "--faults", "particle_budget", "--relations", "rigid_motion"]) == 1
    captured = capsys.readouterr()
    assert captured.out == "" and "'particle_budget' is a hardware limit" in captured.err
    assert "Traceback" not in captured.err
