"""``serve``: a Python SlamAdapter behind the process protocol passes the conformance checks and gives the
in-process estimate to the last bit; planted failures become error replies, not tracebacks."""

import io
import json
import sys

import numpy as np
import pytest

from faultlab.scenario import generate_scenario
from faultlab.slam import DeadReckoning, run_slam
from faultlab.slam.conformance import check_program
from faultlab.slam.process import ProcessSlam, ProcessSlamConfig, transcript
from faultlab.slam.protocol import SlamAdapter
from faultlab.slam.serve import serve
from faultlab.space import FIXED_VALUES, CaseSpec

SERVED = ("from faultlab.slam.serve import serve; from faultlab.slam import DeadReckoning; "
          "raise SystemExit(serve(DeadReckoning))")


def test_the_served_dead_reckoning_passes_every_check():
    report = check_program([sys.executable, "-c", SERVED], reply_timeout_s=30.0)
    assert report.passed, report.format()


def test_a_served_run_gives_the_in_process_estimate_bit_for_bit():
    case = generate_scenario(CaseSpec(dict(FIXED_VALUES)), rng=np.random.default_rng(3), n_steps=40)
    direct = run_slam(DeadReckoning(), case, rng=np.random.default_rng(0))
    slam = ProcessSlam(ProcessSlamConfig.from_options({"command": [sys.executable, "-c", SERVED],
                                                       "reply_timeout_s": 30.0}))
    try:
        served = run_slam(slam, case, rng=np.random.default_rng(0))
    finally:
        slam.close()
    assert np.array_equal(served.pose, direct.pose)
    order = np.argsort(served.landmark_ids)
    assert np.array_equal(served.landmark_ids[order], np.sort(direct.landmark_ids))
    assert np.array_equal(served.landmarks[order], direct.landmarks[np.argsort(direct.landmark_ids)])


class _Exploding(DeadReckoning):
    def update(self, control, observations):
        raise ZeroDivisionError("planted")


def _replies(factory, lines):
    out = io.StringIO()
    assert serve(factory, stdin=io.StringIO("".join(line + "\n" for line in lines)), stdout=out) == 0
    return [json.loads(line) for line in out.getvalue().splitlines()]


def test_a_failing_slam_answers_with_an_error_naming_the_exception_and_keeps_serving():
    case = generate_scenario(CaseSpec(dict(FIXED_VALUES)), rng=np.random.default_rng(1), n_steps=2)
    lines = list(transcript(case, seed=5))
    replies = _replies(_Exploding, lines[:2] + ["not json", json.dumps({"type": "estimate"})])
    assert replies[0] == {"type": "ready", "protocol": 1}
    assert replies[1]["type"] == "error" and "ZeroDivisionError: planted" in replies[1]["message"]
    assert replies[2]["type"] == "error" and "JSONDecodeError" in replies[2]["message"]
    assert replies[3]["type"] == "estimate"


def test_requests_before_a_reset_and_unknown_versions_are_refused():
    replies = _replies(DeadReckoning, [json.dumps({"type": "estimate"}),
                                       json.dumps({"type": "reset", "protocol": 2, "pose": [0, 0, 0], "seed": 1}),
                                       json.dumps({"type": "bye"}), json.dumps({"type": "estimate"})])
    assert [r["type"] for r in replies] == ["error", "error"]  # nothing after bye
    assert "before any reset" in replies[0]["message"] and "protocol 2" in replies[1]["message"]


def test_serve_builds_a_fresh_slam_on_every_reset():
    made = []

    def factory() -> SlamAdapter:
        made.append(DeadReckoning())
        return made[-1]

    reset = json.dumps({"type": "reset", "protocol": 1, "pose": [0, 0, 0], "seed": 1})
    _replies(factory, [reset, reset])
    assert len(made) == 2 and made[0] is not made[1]


@pytest.mark.parametrize("bad", ["[1, 2]", "3"])
def test_a_request_that_is_not_an_object_is_an_error(bad):
    assert _replies(DeadReckoning, [bad])[0]["type"] == "error"
