"""The process adapter: the example C SLAM through faultlab equals the program run standalone; failures
(death, timeouts, malformed replies) become SlamProcessErrors carrying the status and stderr."""

import contextlib
import json
import os
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.data import resolve_experiment
from faultlab.errors import ConfigError, SlamProcessError
from faultlab.metrics import map_errors
from faultlab.runner import run_experiment
from faultlab.runner.experiment import parse_experiment
from faultlab.runner.store import case_path, load_results
from faultlab.scenario.model import load_scenario
from faultlab.seeds import slam_seed
from faultlab.slam import DeadReckoning, Observations, run_slam
from faultlab.slam.process import (RULES, ProcessSlam, ProcessSlamConfig, draw_seed, estimate_from_reply,
                                   transcript)
from faultlab.slam.registry import build_slam, normalise_options
from tests.processslam import example_slam  # noqa: F401  (fixture)


def _smoke(slam: dict, **overrides):
    data = tomllib.loads(resolve_experiment("smoke").read_text())
    data["slam"] = slam
    data["variants"] = ["baseline"]
    data.pop("metrics", None)  # both map errors, compared with the program's own below (smoke records the RMS only)
    data.update(overrides)
    return parse_experiment(data)


def _standalone(program, lines) -> str:
    """The program run on a transcript from a file, as a user would; its last stdout line."""
    done = subprocess.run([str(program)], input="\n".join(lines) + "\n", capture_output=True, text=True,
                          check=True, timeout=60)
    return done.stdout.strip().splitlines()[-1]


@pytest.mark.slow
def test_smoke_campaign_through_the_adapter_equals_the_program_run_standalone(example_slam, tmp_path):
    exp = _smoke({"name": "process", "command": [str(example_slam)]}, suites={"random": 2, "fixed": 1})
    out = tmp_path / "res"
    summary = run_experiment(exp, out, jobs=1, progress=False)
    rows = load_results(out)
    assert summary.counts.get("ok") == len(rows) == 3
    for row in rows.itertuples():
        scenario = load_scenario(case_path(out, row.run, row.suite, row.case))
        seed = draw_seed(np.random.default_rng(slam_seed(exp.seed, row.run, row.suite, row.case, row.rep)))
        alone = estimate_from_reply(_standalone(example_slam, list(transcript(scenario, seed=seed))))
        errors = map_errors(scenario, alone)
        assert (row.rms_mm, row.emd_mm, row.n_mapped) == (errors.rms_mm, errors.emd_mm, errors.n_mapped)
        # and the program is dead reckoning with landmark averaging: the Python baseline is an oracle
        ref = run_slam(DeadReckoning(), scenario, rng=np.random.default_rng(0))
        np.testing.assert_allclose(alone.pose, ref.pose, rtol=0, atol=1e-9)
        np.testing.assert_array_equal(alone.landmark_ids, ref.landmark_ids)
        np.testing.assert_allclose(alone.landmarks, ref.landmarks, rtol=0, atol=1e-9)


def test_a_program_killed_mid_step_gives_a_crash_row_with_its_stderr_and_signal(example_slam, tmp_path):
    exp = _smoke({"name": "process", "command": [str(example_slam)], "env": {"EXAMPLE_SLAM_KILL_AT_STEP": "3"}},
                 suites={"fixed": 2})
    out = tmp_path / "res"
    run_experiment(exp, out, jobs=1, progress=False)
    rows = load_results(out)
    assert len(rows) == 2 and set(rows.status) == {"crash"}
    for error in rows.error:
        assert "SlamProcessError" in error and "died while answering step 3" in error
        assert "killed by SIGKILL" in error
        assert "example_slam: step 3 received; killing myself" in error  # the program's own stderr


def _config(program, **kw) -> ProcessSlamConfig:
    return ProcessSlamConfig(command=(str(program),), **kw)


def _scene():
    rng = np.random.default_rng(5)
    return [(rng.uniform(0, 0.2, 2), Observations(rng.uniform(0.5, 2, 3), rng.uniform(-1, 1, 3), [4, 9, 1]))
            for _ in range(10)]


def test_killed_from_outside_the_next_step_reports_the_signal_and_stderr(example_slam):
    slam = ProcessSlam(_config(example_slam))
    slam.reset(np.zeros(3), rng=np.random.default_rng(1))
    steps = _scene()
    for u, obs in steps[:4]:
        slam.step(u, obs)
    pid = slam.pid
    os.kill(pid, signal.SIGKILL)
    with pytest.raises(SlamProcessError, match="killed by SIGKILL") as info:
        slam.step(*steps[4])
    assert "dead reckoning with landmark averaging" in str(info.value)  # stderr banner
    assert info.value.rule == "stays-alive"
    with pytest.raises(SlamProcessError, match="step before reset"):
        slam.step(*steps[5])


def test_every_reset_starts_a_fresh_process_and_same_seed_gives_same_estimate(example_slam):
    slam = ProcessSlam(_config(example_slam))
    pids, estimates = [], []
    for _ in range(2):
        slam.reset(np.array([1.0, 2.0, 0.5]), rng=np.random.default_rng(3))
        pids.append(slam.pid)
        for u, obs in _scene():
            slam.step(u, obs)
        estimates.append(slam.estimate())
    assert pids[0] != pids[1]
    with pytest.raises(ProcessLookupError):  # the first process has been reaped
        os.kill(pids[0], 0)
    np.testing.assert_array_equal(estimates[0].pose, estimates[1].pose)
    np.testing.assert_array_equal(estimates[0].landmarks, estimates[1].landmarks)
    assert slam.close() == 0  # bye: exit status 0


SLOW_ACK = """
import json, sys, time
for line in sys.stdin:
    m = json.loads(line)
    time.sleep(float(sys.argv[1]) if m["type"] == "step" else 0)
    if m["type"] == "reset":
        print(json.dumps({"type": "ready", "protocol": 1}), flush=True)
    elif m["type"] == "step":
        print(json.dumps({"type": "ack", "t": m["t"]}), flush=True)
"""


def test_a_reply_past_the_reply_timeout_is_a_failure_and_the_program_is_stopped():
    # the limit also covers the reset's reply, i.e. the interpreter's start: 2 s leaves room on a loaded machine
    slam = ProcessSlam(ProcessSlamConfig(command=(sys.executable, "-c", SLOW_ACK, "30"), reply_timeout_s=2.0))
    slam.reset(np.zeros(3), rng=np.random.default_rng(1))
    pid = slam.pid
    t0 = time.monotonic()
    with pytest.raises(SlamProcessError, match="no reply to step 0 in time") as info:
        slam.step([0.1, 0.0])
    assert time.monotonic() - t0 < 10  # the step sleeps 30 s: it was cut at the limit
    assert info.value.rule == "reply-timeout"
    with pytest.raises(ProcessLookupError):
        os.kill(pid, 0)


def test_an_execution_past_its_timeout_is_a_failure():
    slam = ProcessSlam(ProcessSlamConfig(command=(sys.executable, "-c", SLOW_ACK, "0.2"), reply_timeout_s=5,
                                         execution_timeout_s=1.0))
    slam.reset(np.zeros(3), rng=np.random.default_rng(1))
    with pytest.raises(SlamProcessError) as info:
        for _ in range(20):
            slam.step([0.1, 0.0])
    assert info.value.rule == "execution-timeout"


def test_a_request_after_the_execution_deadline_names_the_execution_timeout_not_the_reply_one(monkeypatch):
    # on a loaded machine a step may only be sent after the execution's deadline has passed: the failure
    # is the execution's, whichever of sending or reading the request notices it
    slam = ProcessSlam(ProcessSlamConfig(command=(sys.executable, "-c", SLOW_ACK, "0"), reply_timeout_s=30,
                                         execution_timeout_s=60.0))
    slam.reset(np.zeros(3), rng=np.random.default_rng(1))
    slam.step([0.1, 0.0])
    later = time.monotonic() + 61.0
    monkeypatch.setattr(time, "monotonic", lambda: later)  # the clock the deadlines are read on
    with pytest.raises(SlamProcessError) as info:
        slam.step([0.1, 0.0])
    assert info.value.rule == "execution-timeout"


@pytest.mark.parametrize("breaks, rule", [("estimate", "estimate-landmarks"), ("trajectory", "estimate-trajectory")])
def test_a_malformed_estimate_of_the_program_names_the_broken_rule(example_slam, breaks, rule):
    slam = ProcessSlam(_config(example_slam, env=(("EXAMPLE_SLAM_BREAK", breaks),)))
    slam.reset(np.zeros(3), rng=np.random.default_rng(1))
    for u, obs in _scene():
        slam.step(u, obs)
    with pytest.raises(SlamProcessError, match=f"rule {rule}") as info:
        slam.estimate()
    assert info.value.rule == rule


def test_a_program_that_cannot_start_is_a_slam_failure(tmp_path):
    slam = ProcessSlam(ProcessSlamConfig(command=(str(tmp_path / "missing"),)))
    with pytest.raises(SlamProcessError, match="cannot start it"):
        slam.reset(np.zeros(3), rng=np.random.default_rng(1))


@pytest.mark.parametrize("reply, rule", [
    ("not json", "one-json-object-per-line"),
    ("[1, 2]", "one-json-object-per-line"),
    ('{"type": "ack"}', "reply-type"),
    ('{"type": "error", "message": "boom"}', "error-reply"),
    ('{"type": "estimate", "pose": [0, 0], "landmarks": []}', "estimate-pose"),
    ('{"type": "estimate", "pose": [0, 0, NaN], "landmarks": []}', "estimate-pose"),
    ('{"type": "estimate", "pose": [0, 0, 0]}', "estimate-landmarks"),
    ('{"type": "estimate", "pose": [0, 0, 0], "landmarks": [[1.5, 0, 0]]}', "estimate-landmarks"),
    ('{"type": "estimate", "pose": [0, 0, 0], "landmarks": [[1, 0, 0], [1, 2, 2]]}', "estimate-landmarks"),
    ('{"type": "estimate", "pose": [0, 0, 0], "landmarks": [[true, 0, 0]]}', "estimate-landmarks"),
    ('{"type": "estimate", "pose": [0, 0, 0], "landmarks": [], "trajectory": 3}', "estimate-trajectory"),
    ('{"type": "estimate", "pose": [0, 0, 0], "landmarks": [], "trajectory": [[0, 0]]}', "estimate-trajectory"),
    ('{"type": "estimate", "pose": [0, 0, 0], "landmarks": [], "trajectory": [[0, 0, NaN]]}', "estimate-trajectory"),
    ('{"type": "estimate", "pose": [0, 0, 0], "landmarks": [], "trajectory": [[0, 0, "a"]]}', "estimate-trajectory"),
    ('{"type": "estimate", "pose": [0, 0, 0], "landmarks": [], "trajectory": null}', "estimate-trajectory"),
])
def test_malformed_estimate_replies_name_their_rule(reply, rule):
    with pytest.raises(SlamProcessError) as info:
        estimate_from_reply(reply)
    assert info.value.rule == rule and rule in RULES and f"rule {rule}" in str(info.value)


finite = st.floats(-1e6, 1e6, allow_nan=False)


@settings(max_examples=50, deadline=None)
@given(pose=st.lists(finite, min_size=3, max_size=3),
       lm=st.dictionaries(st.integers(-2 ** 62, 2 ** 62), st.tuples(finite, finite), max_size=20))
def test_an_estimate_reply_round_trips_exactly(pose, lm):
    line = json.dumps({"type": "estimate", "pose": pose, "landmarks": [[k, *v] for k, v in lm.items()]})
    est = estimate_from_reply(line)
    assert est.pose.tolist() == pose
    assert est.as_dict() == {k: tuple(v) for k, v in lm.items()}


def test_a_trajectory_is_optional_and_must_have_one_pose_per_step():
    base = {"type": "estimate", "pose": [0, 0, 0], "landmarks": []}
    assert estimate_from_reply(json.dumps(base), n_steps=4).trajectory is None
    rows = [[0.5, -1.0, 3.0], [1.5, 2.0, -0.25]]
    est = estimate_from_reply(json.dumps(base | {"trajectory": rows}), n_steps=2)
    assert est.trajectory.tolist() == rows and est.trajectory.shape == (2, 3)
    assert estimate_from_reply(json.dumps(base | {"trajectory": []}), n_steps=0).trajectory.shape == (0, 3)
    with pytest.raises(SlamProcessError, match="trajectory has 2 poses after 3 steps") as info:
        estimate_from_reply(json.dumps(base | {"trajectory": rows}), n_steps=3)
    assert info.value.rule == "estimate-trajectory"


def test_a_covariance_is_optional_and_must_be_a_symmetric_psd_matrix_of_the_state():
    base = {"type": "estimate", "pose": [0, 0, 0], "landmarks": [[7, 1.0, 2.0]]}
    assert estimate_from_reply(json.dumps(base)).covariance is None
    good = (np.diag([1.0, 2, 3, 4, 5]) + 0.1).tolist()
    assert np.array_equal(estimate_from_reply(json.dumps(base | {"covariance": good})).covariance, good)
    asym = [row[:] for row in good]
    asym[0][1] += 0.5
    negative = np.diag([1.0, 1, 1, 1, -1]).tolist()
    for bad, match in [(good[:3], "not 5 rows of 5"), ("x", "covariance is"), (asym, "not symmetric"),
                       (negative, "not positive semi-definite")]:
        with pytest.raises(SlamProcessError, match=match) as info:
            estimate_from_reply(json.dumps(base | {"covariance": bad}))
        assert info.value.rule == "estimate-covariance"



def test_options_are_validated_and_round_trip():
    opts = normalise_options("process", {"command": "prog --fast 'a b'", "env": {"X": "1"}}, where="slam")
    config = build_slam("process", opts).config
    assert config.command == ("prog", "--fast", "a b") and config.env == (("X", "1"),)
    assert config.reply_timeout_s == opts["reply_timeout_s"] == ProcessSlamConfig.reply_timeout_s
    assert ProcessSlamConfig.from_options(config.to_options()) == config
    for bad, match in [({}, "slam.command is required"), ({"command": []}, "non-empty list"),
                       ({"command": ["p"], "colour": 1}, "slam.colour is not a known key"),
                       ({"command": ["p"], "reply_timeout_s": 0}, "reply_timeout_s"),
                       ({"command": ["p"], "env": {"X": 1}}, "env must be a table of strings")]:
        with pytest.raises(ConfigError, match=match):
            normalise_options("process", bad, where="slam")


@pytest.mark.slow
def test_past_the_campaigns_timeout_the_job_is_a_timeout_row_and_the_program_is_stopped(tmp_path):
    marker = tmp_path / "pids"
    silent = (f"import os, sys, time\nopen({str(marker)!r}, 'a').write(f'{{os.getpid()}}\\n')\n"
              "for line in sys.stdin:\n    time.sleep(60)\n")
    exp = _smoke({"name": "process", "command": [sys.executable, "-c", silent], "reply_timeout_s": 100},
                 suites={"fixed": 1}, timeout_s=0.5)
    run_experiment(exp, tmp_path / "res", jobs=1, progress=False)
    rows = load_results(tmp_path / "res")
    assert rows.status.tolist() == ["timeout"]
    for pid in map(int, marker.read_text().split()):
        with pytest.raises(ProcessLookupError):
            os.kill(pid, 0)


@settings(max_examples=30, deadline=None)
@given(data=st.data())
def test_the_example_equals_python_dead_reckoning_on_any_input(example_slam, data):
    """Random steps (empty ones, large ids, bearings offset by turns): the C program through the adapter
    equals the built-in DeadReckoning, an independent implementation of the same algorithm."""
    n_steps = data.draw(st.integers(0, 12))
    start = data.draw(st.lists(st.floats(-50, 50), min_size=3, max_size=3))
    ids_pool = st.integers(0, 2 ** 52)
    steps = []
    for _ in range(n_steps):
        u = data.draw(st.lists(st.floats(-2, 2), min_size=2, max_size=2))
        ids = data.draw(st.lists(ids_pool, max_size=6, unique=True))
        r = [data.draw(st.floats(0, 30)) for _ in ids]
        b = [data.draw(st.floats(-20, 20)) for _ in ids]
        steps.append((u, Observations(r, b, ids)))
    results = []
    for slam in (ProcessSlam(_config(example_slam)), DeadReckoning()):
        slam.reset(np.array(start), rng=np.random.default_rng(0))
        for u, obs in steps:
            slam.step(u, obs)
        results.append(slam.estimate())
    ours, ref = results
    assert ours.trajectory.shape == ref.trajectory.shape == (n_steps, 3)
    np.testing.assert_allclose(ours.trajectory, ref.trajectory, rtol=0, atol=1e-9)
    np.testing.assert_allclose(ours.pose, ref.pose, rtol=0, atol=1e-9)
    np.testing.assert_array_equal(ours.landmark_ids, ref.landmark_ids)
    np.testing.assert_allclose(ours.landmarks, ref.landmarks, rtol=0, atol=1e-9)


# ------------------------------------------------------------------ no descendant survives
#: A SLAM program that answers the reset, then ignores every request, EOF, SIGTERM and SIGHUP (gone after 5 min).
HANGER = """
import json, os, signal, sys, time
for s in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT):
    signal.signal(s, signal.SIG_IGN)
open(os.path.join(sys.argv[1], str(os.getpid())), "w").close()
sys.stdin.readline()
print(json.dumps({"type": "ready", "protocol": 1}), flush=True)
end = time.monotonic() + 300
while time.monotonic() < end:
    time.sleep(0.2)
"""


def _behind_a_wrapper(tmp_path) -> tuple[list[str], "os.PathLike"]:
    """``sh -c "python hanger.py PIDS; echo"``: sh forks the program (no exec) and waits for it."""
    script = tmp_path / "hanger.py"
    script.write_text(HANGER)
    pids = tmp_path / "pids"
    pids.mkdir()
    return ["sh", "-c", f'"{sys.executable}" "{script}" "{pids}"; echo wrapper-done'], pids


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _survivors(pids, wait_s: float = 15.0) -> set[int]:
    """The programs (pids written to ``pids``) still alive after up to ``wait_s`` seconds; kills them."""
    started = {int(p.name) for p in pids.iterdir()}
    assert started, "no program was started"
    end = time.monotonic() + wait_s
    while {p for p in started if _alive(p)} and time.monotonic() < end:
        time.sleep(0.1)
    alive = {p for p in started if _alive(p)}
    for p in alive:
        with contextlib.suppress(OSError):
            os.kill(p, signal.SIGKILL)
    return alive


linux_only = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="lists processes through /proc")


@linux_only
def test_a_hanging_program_behind_a_wrapper_leaves_no_process_after_a_campaign(tmp_path):
    command, pids = _behind_a_wrapper(tmp_path)
    exp = _smoke({"name": "process", "command": command, "reply_timeout_s": 1.0}, suites={"fixed": 1})
    run_experiment(exp, tmp_path / "res", jobs=2, progress=False)
    rows = load_results(tmp_path / "res")
    assert (rows.status == "crash").all() and rows.error.str.contains("reply-timeout").all()
    assert not _survivors(pids)


@linux_only
def test_a_hanging_program_behind_a_wrapper_leaves_no_process_after_adapter_check(tmp_path):
    from faultlab.slam.conformance import check_program

    command, pids = _behind_a_wrapper(tmp_path)
    report = check_program(command, reply_timeout_s=1.0, execution_timeout_s=5.0)
    assert not any(r.passed for r in report.results if r.name != "eof")
    assert not _survivors(pids)


@pytest.mark.slow
@linux_only
def test_a_program_that_ignores_eof_ends_when_the_campaign_alone_is_killed(tmp_path):
    from tests.runner.suts import write_experiment

    command, pids = _behind_a_wrapper(tmp_path)
    exp = write_experiment(tmp_path / "e.toml", runs=1, repetitions=1, suites={"random": 2}, variants=["baseline"],
                           slam={"name": "process", "command": command, "reply_timeout_s": 100.0})
    root = Path(__file__).resolve().parents[2]
    proc = subprocess.Popen([sys.executable, "-m", "faultlab", "run", str(exp), "--out", str(tmp_path / "out"),
                             "--jobs", "2", "--no-progress"], cwd=root, env=dict(os.environ, PYTHONPATH=str(root)),
                            start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        end = time.monotonic() + 120
        while proc.poll() is None and len(list(pids.iterdir())) < 2 and time.monotonic() < end:
            time.sleep(0.1)
        assert proc.poll() is None and len(list(pids.iterdir())) == 2, "the programs never started"
        proc.send_signal(signal.SIGKILL)  # the campaign alone: its workers and programs get no signal
        proc.wait(timeout=30)
        assert not _survivors(pids, wait_s=20.0)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)


def test_a_program_that_closes_its_output_but_runs_on_is_not_said_to_have_died():
    closes = "import os, sys, time\nsys.stdin.readline()\nos.close(1)\ntime.sleep(30)\n"
    slam = ProcessSlam(ProcessSlamConfig(command=(sys.executable, "-c", closes), reply_timeout_s=20.0))
    with pytest.raises(SlamProcessError) as info:
        slam.reset(np.zeros(3), rng=np.random.default_rng(1))
    text = str(info.value)
    assert "closed its output while answering" in text and "died" not in text
    assert "still running (then stopped by faultlab)" in text
