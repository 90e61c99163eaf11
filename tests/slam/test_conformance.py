"""``check_program``: the example C SLAM passes every check; planted defects fail exactly their checks."""

import sys
import time

import pytest

from faultlab.errors import SlamProcessError
from faultlab.slam.conformance import CHECKS, check_program
from tests.processslam import example_slam  # noqa: F401  (fixture)

# A second conforming SLAM (dead reckoning, landmarks at their last observation), in Python, whose
# argv[1] plants one defect.
REFERENCE = r"""
import json, math, os, random, sys
defect = sys.argv[1]
pose, lms = None, {}
for line in sys.stdin:
    m = json.loads(line)
    if m["type"] == "reset":
        if m["protocol"] != 1 and defect != "any-version":
            print(json.dumps({"type": "error", "message": "protocol 1 only"}), flush=True)
            continue
        pose, lms, traj = list(m["pose"]), {}, []
        if defect == "clamped-heading":  # assumes a start heading in [-pi, pi]
            pose[2] = max(-math.pi, min(math.pi, pose[2]))
        print(json.dumps({"type": "ready", "protocol": 1}), flush=True)
    elif m["type"] == "step":
        if defect == "trajectory-before":  # logs the pose before the step's motion
            traj.append(list(pose))
        v, w = m["control"]
        pose = [pose[0] + v * math.cos(pose[2]), pose[1] + v * math.sin(pose[2]), pose[2] + w]
        for r, b, i in zip(m["ranges"], m["bearings"], m["ids"]):
            if defect == "int32-ids":
                i = (i + 2 ** 31) % 2 ** 32 - 2 ** 31
            a = pose[2] + b
            lms[i] = [pose[0] + r * math.cos(a), pose[1] + r * math.sin(a)]
        if defect == "with-trajectory":
            traj.append(list(pose))
        print(json.dumps({"type": "ack", "t": m["t"]}), flush=True)
    elif m["type"] == "estimate":
        p = list(pose)
        if defect == "unseeded":
            p[0] += random.SystemRandom().gauss(0, 1e-9)
        reply = {"type": "estimate", "pose": p, "landmarks": [[i, *xy] for i, xy in lms.items()]}
        if defect.endswith("trajectory") or defect.startswith("trajectory"):
            reply["trajectory"] = traj
        print(json.dumps(reply), flush=True)
    elif m["type"] == "bye":
        sys.exit(3 if defect == "bye-status" else 0)
sys.exit(4 if defect == "eof-status" else 0)
"""


def _failed(report) -> set[str]:
    return {r.name for r in report.results if not r.passed}


def test_the_example_c_slam_passes_every_check(example_slam):
    report = check_program([str(example_slam)])
    assert [r.name for r in report.results] == list(CHECKS)
    assert report.passed, report.format()
    assert report.format().splitlines()[-1] == f"{len(CHECKS)} of {len(CHECKS)} checks passed"


def test_a_broken_estimate_fails_every_check_with_landmarks_naming_the_rule(example_slam):
    report = check_program([str(example_slam)], env=[("EXAMPLE_SLAM_BREAK", "estimate")])
    assert not report.passed
    # the checks whose estimate has landmarks fail; those with an empty map do not see the defect
    assert _failed(report) == {"empty-steps", "inactivity", "rotation-offsets", "large-map", "trajectory",
                               "same-seed"}
    for r in report.results:
        if not r.passed:
            assert "rule estimate-landmarks" in r.message and "[id, x, y]" in r.message


def test_a_malformed_trajectory_fails_every_check_with_steps_naming_the_rule(example_slam):
    report = check_program([str(example_slam)], env=[("EXAMPLE_SLAM_BREAK", "trajectory")])
    # every check whose execution has a step ends in an estimate with a malformed trajectory; the empty
    # run's trajectory is an empty list, which is well formed
    assert _failed(report) == {"empty-steps", "zero-observations", "inactivity", "rotation-offsets", "large-map",
                               "trajectory", "same-seed", "exit-on-bye"}, report.format()
    for r in report.results:
        if not r.passed:
            assert "rule estimate-trajectory" in r.message and "[x, y, theta]" in r.message


def test_a_trajectory_is_optional_and_a_right_one_passes():
    assert check_program([sys.executable, "-c", REFERENCE, "with-trajectory"]).passed


def test_the_python_reference_passes_every_check():
    report = check_program([sys.executable, "-c", REFERENCE, "none"])
    assert report.passed, report.format()


@pytest.mark.parametrize("defect, failing, words", [
    ("any-version", {"protocol-version"}, "reply {\"type\":\"error\""),
    ("bye-status", {"exit-on-bye"}, "exit status 3; exit with status 0"),
    ("eof-status", {"exit-on-eof"}, "exit status 4; exit with status 0 at the end of input"),
    ("unseeded", {"same-seed"}, "different estimates"),
    ("int32-ids", {"large-map"}, "missing ids"),
    ("clamped-heading", {"rotation-offsets"}, "modulo 2 pi"),
    ("trajectory-before", {"trajectory"}, "row t of \"trajectory\" is the pose after step t"),
])
def test_each_planted_defect_fails_its_check_with_a_message_to_fix_it(defect, failing, words):
    report = check_program([sys.executable, "-c", REFERENCE, defect])
    assert _failed(report) == failing, report.format()
    message = next(r.message for r in report.results if not r.passed)
    assert words in message


def test_a_silent_program_is_one_error_after_one_reply_timeout():
    start = time.monotonic()
    with pytest.raises(SlamProcessError, match="rule reply-timeout.*no check was run"):
        check_program([sys.executable, "-c", "import time; time.sleep(30)"], reply_timeout_s=0.5)
    assert time.monotonic() - start < 5  # one timeout, not one per check


def test_a_missing_program_is_one_error():
    with pytest.raises(SlamProcessError, match="cannot start it.*no check was run"):
        check_program(["/nonexistent/faultlab-slam"])


# Answers the reset, then never replies to a step: the first check with a step times out.
HANGS_ON_STEP = r"""
import json, sys, time
for line in sys.stdin:
    if json.loads(line)["type"] == "reset":
        print(json.dumps({"type": "ready", "protocol": 1}), flush=True)
    else:
        time.sleep(30)
"""


def test_a_check_that_times_out_ends_the_run_and_the_rest_are_not_run():
    start = time.monotonic()
    report = check_program([sys.executable, "-c", HANGS_ON_STEP], reply_timeout_s=0.5)
    elapsed = time.monotonic() - start
    # empty-run asks for the estimate at once (no step): it times out there, and nothing else is waited for
    assert [r.name for r in report.results] == ["empty-run"] and not report.passed
    assert "rule reply-timeout" in report.results[0].message
    assert report.not_run == tuple(list(CHECKS)[1:])
    assert "not run" in report.format() and report.format().endswith(f"0 of {len(CHECKS)} checks passed; "
                                                                      f"1 failed, {len(CHECKS) - 1} not run")
    assert elapsed < 5
