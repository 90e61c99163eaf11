"""``python -m faultlab adapter check``: exit 0 for a conforming program, 1 with the broken rule otherwise."""

import pytest

from faultlab.cli import main
from faultlab.slam.conformance import CHECKS
from tests.processslam import example_slam  # noqa: F401  (fixture)


def test_adapter_check_passes_the_example_and_fails_the_broken_variant(example_slam, capsys):
    assert main(["adapter", "check", str(example_slam)]) == 0
    out = capsys.readouterr().out
    assert out.count("  pass  ") == len(CHECKS) and "FAIL" not in out
    assert main(["adapter", "check", "--env", "EXAMPLE_SLAM_BREAK=estimate", str(example_slam)]) == 1
    out = capsys.readouterr().out
    assert "FAIL  large-map" in out and "rule estimate-landmarks" in out


def test_adapter_check_passes_arguments_through_to_the_program(example_slam, capsys):
    # env runs the program with the variable set: arguments after CMD belong to the program
    assert main(["adapter", "check", "env", "EXAMPLE_SLAM_BREAK=estimate", str(example_slam)]) == 1
    assert "rule estimate-landmarks" in capsys.readouterr().out


def test_adapter_check_of_a_missing_program_is_one_error_line(capsys):
    assert main(["adapter", "check", "/nonexistent/faultlab-slam"]) == 1
    captured = capsys.readouterr()
    assert "FAIL" not in captured.out
    (line,) = captured.err.splitlines()
    assert line.startswith("faultlab: error: ") and "cannot start it" in line and "no check was run" in line


def test_adapter_check_refuses_a_bad_option(capsys):
    with pytest.raises(SystemExit) as info:
        main(["adapter", "check", "--env", "NOVALUE", "prog"])
    assert info.value.code == 2
    assert "expected NAME=VALUE" in capsys.readouterr().err
