"""faultlab compare: exit status 0/1/2/3 on planted changes, the reports, a reused baseline record."""

import json
import os
import subprocess
import sys
from pathlib import Path

from junitparser import Failure, JUnitXml

from faultlab.cli import main

TESTS = Path(__file__).resolve().parents[1]
SPACE = TESTS / "oracles" / "small_space.toml"
SUITE = ["--space", str(SPACE), "--suite", "random", "--cases", "4", "--steps", "30", "-K", "2",
         "--path", str(TESTS / "campaigns")]


def _compare(tmp_path, *args):
    return main(["compare", *SUITE, "--out", str(tmp_path / "out"), *args])


def _report(tmp_path):
    return json.loads((tmp_path / "out" / "report" / "compare.json").read_text())


def test_the_same_deterministic_slam_is_identical_and_equivalent(tmp_path):
    assert _compare(tmp_path, "compare_slams:odometry", "compare_slams:odometry", "--require-equivalence") == 0
    rep = _report(tmp_path)
    assert rep["pooled"]["verdict"] == "identical" and rep["equivalent"] and rep["exit_status"] == 0
    assert all(c["verdict"] == "identical" for c in rep["cases"])


def test_a_candidate_that_crashes_where_the_baseline_ran_is_a_regression(tmp_path):
    assert _compare(tmp_path, "compare_slams:odometry", "compare_slams:odometry_crashing") == 1
    rep = _report(tmp_path)
    assert rep["regression"] and any(c["crash_regression"] for c in rep["cases"])
    xml = JUnitXml.fromfile(str(tmp_path / "out" / "report" / "compare-junit.xml"))
    failed = [case.name for suite in xml for case in suite if any(isinstance(r, Failure) for r in case.result)]
    assert failed and all(name.startswith("random-1-") for name in failed)


def test_worse_maps_are_a_regression_better_ones_not_equivalent(tmp_path):
    # EKF-SLAM maps better than dead reckoning on these cases (both deterministic: exact per case)
    assert _compare(tmp_path / "a", "ekf", "dead_reckoning", "--cases", "10") == 1
    assert _report(tmp_path / "a")["pooled"]["verdict"] == "regression"
    assert _compare(tmp_path / "b", "dead_reckoning", "ekf", "--cases", "10") == 0
    # resumed from the records: the same verdict, now gated on equivalence
    assert _compare(tmp_path / "b", "dead_reckoning", "ekf", "--cases", "10", "--require-equivalence",
                    "--html") == 3
    html = (tmp_path / "b" / "out" / "report" / "html" / "index.html").read_text()
    assert 'id="table-cases"' in html and "improvement" in html
    assert _report(tmp_path / "b")["pooled"]["verdict"] == "improvement"
    md = (tmp_path / "b" / "out" / "report" / "compare.md").read_text()
    assert "improvement" in md and "δ = ±10 %" in md and "alpha = 0.05" in md


def test_usage_errors_exit_2_and_write_nothing(tmp_path, capsys):
    assert _compare(tmp_path, "dead_reckoning", "ekf", "--delta", "1.5") == 2
    assert _compare(tmp_path, "dead_reckoning", "no_such_slam") == 2
    assert _compare(tmp_path, "dead_reckoning") == 2  # no candidate
    assert not (tmp_path / "out").exists()
    assert "faultlab compare: error:" in capsys.readouterr().err


def test_a_recorded_baseline_is_reused_from_another_directory(tmp_path):
    store = tmp_path / "baseline"
    assert main(["compare", "ekf", "--record-only", "--baseline-store", str(store), *SUITE]) == 0
    command = Path(sys.executable).with_name("faultlab")
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}
    run = subprocess.run([str(command), "compare", str(store), "ekf", "--out", str(tmp_path / "out")], cwd=tmp_path,
                         env=env, capture_output=True, text=True)
    assert run.returncode == 0, run.stderr
    assert _report(tmp_path)["pooled"]["verdict"] == "identical"
    # a damaged baseline is an input error naming the file
    case = next((store / "cases").glob("*.json"))
    case.write_text(case.read_text().replace('"errors_mm": [', '"errors_mm": [1.0, '))
    assert _compare(tmp_path / "c", str(store), "ekf") == 2


def test_two_process_slams_a_fix_and_its_bug(tmp_path):
    program = TESTS / "oracles" / "blackbox_process.py"
    fixed = f"{sys.executable} {program}"
    buggy = f"{fixed} --bug turn_first"
    assert _compare(tmp_path, "--baseline-command", fixed, "--candidate-command", buggy, "--cases", "8") == 1
    rep = _report(tmp_path)
    assert rep["baseline"].endswith("blackbox_process.py") and rep["pooled"]["verdict"] == "regression"
