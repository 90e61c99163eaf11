"""Progress: a tqdm bar on a terminal, a log line every tenth of the work elsewhere."""

from __future__ import annotations

import contextlib
import io
import re

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.runner import run_experiment
from faultlab.runner.progress import format_duration, progress
from tests.runner.suts import write_experiment

LINE = re.compile(r"^demo: (\d+)/(\d+) jobs \((\d+) %\), (\d+) crash, elapsed (.+), ETA (.+)$")


class Clock:
    """A fake monotonic clock: ``tick`` seconds per call after the first."""

    def __init__(self, tick: float):
        self.t, self.tick = -tick, tick

    def __call__(self) -> float:
        self.t += self.tick
        return self.t


class Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _ceil_div(a: int, b: int) -> int:
    return -(-a // b)


def test_log_lines_every_tenth_with_counts_elapsed_and_eta():
    log, clock = io.StringIO(), Clock(2.0)
    with progress(25, desc="demo", stream=log, clock=clock, counts={"crash": 0}, interval_s=1e9) as p:
        for i in range(1, 26):
            p.update(1, crash=i // 5)
    lines = log.getvalue().splitlines()
    assert lines[0] == "demo: 25 jobs, 0 already done, 25 to run"
    # a line when the k-th tenth is reached: at the first done >= k * 25 / 10
    expected = [_ceil_div(k * 25, 10) for k in range(1, 11)]
    assert expected == [3, 5, 8, 10, 13, 15, 18, 20, 23, 25]
    rows = [LINE.match(line) for line in lines[1:]]
    assert all(rows) and len(rows) == 10
    assert [int(m[1]) for m in rows] == expected
    for m in rows:
        done = int(m[1])
        elapsed = 2.0 * done  # the clock ticks once at the start and once per update
        assert int(m[2]) == 25 and int(m[3]) == round(100 * done / 25)
        assert int(m[4]) == done // 5
        assert m[5] == format_duration(elapsed)
        assert m[6] == format_duration(elapsed / done * (25 - done))
    assert lines[-1].startswith("demo: 25/25 jobs (100 %), 5 crash, elapsed 50.0 s, ETA 0.0 s")


@settings(max_examples=60, deadline=None)
@given(total=st.integers(1, 400), done=st.integers(0, 400), steps=st.integers(1, 20))
def test_one_line_per_step_crossed(total, done, steps):
    done = min(done, total)
    log = io.StringIO()
    with progress(total, done=done, desc="demo", stream=log, steps=steps, interval_s=1e9) as p:
        for _ in range(total - done):
            p.update()
    lines = log.getvalue().splitlines()
    assert lines[0] == f"demo: {total} jobs, {done} already done, {total - done} to run"
    # the steps not yet reached when the block starts: thresholds k * total / steps above `done`
    crossed = {_ceil_div(k * total, steps) for k in range(1, steps + 1)} - set(range(done + 1))
    assert len(lines) - 1 == len(crossed)
    if done == 0:
        assert len(lines) - 1 == min(total, steps)  # >= 10 lines for >= 10 jobs at the default
    if crossed:
        assert lines[-1].startswith(f"demo: {total}/{total} jobs (100 %)")


def test_resumed_work_counts_towards_done_not_the_rate():
    log = io.StringIO()
    with progress(20, done=10, desc="demo", stream=log, clock=Clock(3.0), interval_s=1e9) as p:
        p.update(2)
    lines = log.getvalue().splitlines()
    assert lines[0] == "demo: 20 jobs, 10 already done, 10 to run"
    # 2 new jobs in 3 s: 8 left take 12 s
    assert lines[1] == "demo: 12/20 jobs (60 %), elapsed 3.0 s, ETA 12.0 s"


def test_resumed_work_counts_towards_done_not_the_rate_of_the_bar():
    import time

    term = Terminal()
    with progress(100, done=90, desc="demo", stream=term) as p:
        time.sleep(0.5)
        p.update(1)
        meter = p._bar.format_dict
    # 1 new job in >= 0.5 s: 9 left take >= 4.5 s (counting the 90 resumed jobs as work would give 0.05 s)
    rate = (meter["n"] - meter["initial"]) / meter["elapsed"]
    assert meter["n"] == 91 and meter["initial"] == 90 and (100 - 91) / rate >= 4.5
    assert re.search(r"91/100 \[00:00<00:0[4-9]", term.getvalue()), term.getvalue()


def test_a_slow_step_still_logs_every_interval():
    log = io.StringIO()
    with progress(1000, desc="demo", stream=log, clock=Clock(61.0), interval_s=60.0) as p:
        for _ in range(5):
            p.update()
    lines = log.getvalue().splitlines()
    assert [line.split(" (")[0] for line in lines[1:]] == [f"demo: {i}/1000 jobs" for i in range(1, 6)]


def test_terminal_gets_the_tqdm_bar_and_no_log_lines():
    term = Terminal()
    with progress(20, desc="demo", stream=term, counts={"crash": 0}) as p:
        assert p.mode == "bar"
        for _ in range(20):
            p.update(1, crash=1)
    out = term.getvalue()
    assert "demo" in out and "20/20" in out and "crash=1" in out
    assert "already done" not in out and "ETA" not in out


@pytest.mark.parametrize("stream", [io.StringIO(), Terminal()])
def test_disabled_is_silent_everywhere(stream):
    with progress(20, desc="demo", stream=stream, enabled=False) as p:
        assert p.mode == "off"
        for _ in range(20):
            p.update()
    assert stream.getvalue() == "" and p.done == 20


def test_format_duration():
    assert format_duration(0.04) == "0.0 s" and format_duration(59.94) == "59.9 s"
    assert format_duration(61.4) == "1 min 1 s" and format_duration(3600) == "1 h 0 min 0 s"
    assert format_duration(3 * 3600 + 62) == "3 h 1 min 2 s"
    assert format_duration(float("nan")) == "?" and format_duration(None) == "?"  # a session never timed


def test_a_run_logs_progress_when_stderr_is_not_a_terminal(tmp_path):
    exp = write_experiment(tmp_path / "e.toml", variants=["baseline", "tests.runner.suts:CRASH"])
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        summary = run_experiment(exp, tmp_path / "out", jobs=1, backend="threading")
    assert summary.n_jobs == 24 and summary.counts["crash"] == 12
    lines = err.getvalue().splitlines()
    assert lines[0] == "faultlab run: 24 jobs, 0 already done, 24 to run"
    progress_lines = [line for line in lines if re.match(r"faultlab run: \d+/24 jobs \(\d+ %\)", line)]
    assert len(progress_lines) >= 10
    done = [int(re.search(r"(\d+)/24", line)[1]) for line in progress_lines]
    assert done == sorted(done) and done[-1] == 24
    assert all(re.search(r", \d+ crash, \d+ timeout, elapsed .+, ETA .+$", line) for line in progress_lines)
    assert progress_lines[-1].startswith("faultlab run: 24/24 jobs (100 %), 12 crash, 0 timeout, elapsed ")

    # resumed: nothing to run, one line says so; --no-progress (progress=False) is silent
    err = io.StringIO()
    with contextlib.redirect_stderr(err):
        run_experiment(exp, tmp_path / "out", jobs=1, backend="threading")
        run_experiment(exp, tmp_path / "quiet", jobs=1, backend="threading", progress=False)
    assert err.getvalue().splitlines() == ["faultlab run: 24 jobs, 24 already done, 0 to run"]
