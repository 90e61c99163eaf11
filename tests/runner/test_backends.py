"""Backends: a dying worker is a crash row; a worker past its deadline is killed, with any --jobs."""

import contextlib
import dataclasses
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

from faultlab.runner import load_metadata, load_results, run_experiment
from tests.runner.suts import SUTS, fastslam_batches, one_case, write_experiment


def test_worker_death_is_recorded_as_crash(tmp_path):
    exp = write_experiment(tmp_path / "e.toml", **one_case(variants=["baseline", f"{SUTS}:EXIT"]))
    summary = run_experiment(exp, tmp_path / "out", jobs=2, progress=False)
    df = load_results(tmp_path / "out").set_index("variant")
    assert df.loc[f"{SUTS}:EXIT", "status"] == "crash"
    assert df.loc[f"{SUTS}:EXIT", "error"].startswith("WorkerDied:")
    assert df.loc["baseline", "status"] == "ok"
    assert summary.n_jobs == 2 and summary.complete


@pytest.mark.parametrize("backend, jobs", [("threading", 2), ("dask", 1), ("ray", 4)])
def test_backends_whose_workers_cannot_be_killed_are_refused_before_anything_is_written(tmp_path, capsys, backend,
                                                                                        jobs):
    from faultlab.cli import main
    from faultlab.errors import ConfigError

    exp = write_experiment(tmp_path / "e.toml", **one_case())
    with pytest.raises(ConfigError, match=f"backend '{backend}' cannot enforce timeout_s"):
        run_experiment(exp, tmp_path / "api", jobs=jobs, backend=backend, progress=False)
    assert main(["run", str(exp), "--out", str(tmp_path / "cli"), "--jobs", str(jobs), "--backend", backend,
                 "--no-progress"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--backend loky" in err[0], err
    assert sorted(p.name for p in tmp_path.iterdir()) == ["e.toml"]


def test_one_job_at_a_time_runs_in_a_worker_process_and_gives_the_in_process_results(tmp_path):
    from faultlab.runner import batch_jobs, execute_batch, expand_jobs, load_experiment, prepare_cases, stream_batches

    exp = load_experiment(fastslam_batches(tmp_path, repetitions=2, variants=["baseline", "missing_angle_wrap"]))
    infos = prepare_cases(exp, tmp_path / "out")
    batches = batch_jobs(expand_jobs(exp, ((i.run, i.suite, i.case, i.path, i.cost) for i in infos)), size=2)
    here = [execute_batch(b) for b in batches]  # the reference: this process, as joblib runs n_jobs = 1
    for backend in ("loky", "threading"):
        there = list(stream_batches(batches, jobs=1, backend=backend))
        assert [[dataclasses.replace(r, runtime_s=0.0) for r in g] for g in there] == \
            [[dataclasses.replace(r, runtime_s=0.0) for r in g] for g in here]
    assert all(r.status.value == "ok" for g in here for r in g)


def test_a_batch_that_kills_its_worker_is_a_crash_of_each_repetition(tmp_path):
    exp = fastslam_batches(tmp_path, variants=["baseline", f"{SUTS}:FS_EXIT"], suites={"random": 1},
                            repetitions=2)
    summary = run_experiment(exp, tmp_path / "out", jobs=2, progress=False)
    df = load_results(tmp_path / "out")
    died = df[df.variant == f"{SUTS}:FS_EXIT"]
    assert list(died.status) == ["crash", "crash"] and died.error.str.startswith("WorkerDied:").all()
    assert (df[df.variant == "baseline"].status == "ok").all() and summary.complete


def _descendants(pid: int) -> set[int]:
    """Every live descendant of ``pid`` (Linux /proc)."""
    parents = {}
    for d in os.listdir("/proc"):
        if d.isdigit():
            try:
                with open(f"/proc/{d}/stat") as f:
                    parents[int(d)] = int(f.read().rsplit(")", 1)[1].split()[1])
            except (OSError, ValueError, IndexError):
                pass
    found, frontier = set(), {pid}
    while frontier:
        frontier = {c for c, p in parents.items() if p in frontier} - found
        found |= frontier
    return found


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except OSError:
        return False


def _working_workers(parent: int) -> set[int]:
    """Pids of the workers of campaign ``parent`` running a job now (each announces its deadline while it runs one:
    it has passed its initializer, so it is watching its parent)."""
    found = set()
    for d in Path(tempfile.gettempdir()).glob(f"faultlab-deadlines-{parent}-*"):
        with contextlib.suppress(OSError):
            found |= {int(f.stem) for f in d.glob("*.json") if f.stem.isdigit()}
    return found


def _describe(pids) -> str:
    out = []
    for pid in sorted(pids):
        with contextlib.suppress(OSError):
            with open(f"/proc/{pid}/cmdline", "rb") as f:
                command = f.read().replace(b"\0", b" ").decode(errors="replace")
            out.append(f"{pid}: {command[:120]}")
    return "; ".join(out)


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="lists processes through Linux's /proc")
def test_workers_end_when_the_parent_alone_is_killed(tmp_path):
    """Killed while both workers are running jobs, so each is past its start-up (under heavy load a worker still
    importing its libraries notices its parent is gone only once they are loaded, which can take longer than the
    limit below): each then ends within a poll of its parent watch, whatever the load."""
    exp = write_experiment(tmp_path / "e.toml", runs=1, repetitions=3, n_steps=40,
                           slam={"name": "tests.runner.suts:make_tiny", "options": {"noise": 0.02, "delay": 0.05}})
    out = tmp_path / "out"
    root = Path(__file__).resolve().parents[2]
    proc = subprocess.Popen([sys.executable, "-m", "faultlab", "run", str(exp), "--out", str(out), "--jobs", "2",
                             "--no-progress"], cwd=root, env=dict(os.environ, PYTHONPATH=str(root)),
                            start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    children: set[int] = set()
    try:
        deadline = time.monotonic() + 300
        working: set[int] = set()
        while proc.poll() is None and time.monotonic() < deadline:  # both workers seen running a job
            working |= _working_workers(proc.pid)
            if len(working) >= 2:
                break
            time.sleep(0.02)
        children = _descendants(proc.pid)
        assert proc.poll() is None and len(working) >= 2, "the campaign ended before both workers were seen working"
        assert working <= children, (working, children)
        proc.send_signal(signal.SIGKILL)  # the parent alone: its workers get no signal
        proc.wait(timeout=30)
        killed = time.monotonic()
        while {c for c in children if _alive(c)} and time.monotonic() - killed < 10:
            time.sleep(0.1)
        alive = {c for c in children if _alive(c)}
        assert not alive, f"processes alive 10 s after the parent died: {_describe(alive)}"
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        for c in _descendants(proc.pid) | children:
            with contextlib.suppress(OSError):
                os.kill(c, signal.SIGKILL)


def test_stream_batches_yields_each_batchs_results_together_and_every_job_once(tmp_path):
    from faultlab.runner import batch_jobs, expand_jobs, load_experiment, prepare_cases, stream_batches

    exp = load_experiment(fastslam_batches(tmp_path, repetitions=3, variants=["baseline", "missing_angle_wrap"]))
    infos = prepare_cases(exp, tmp_path / "out")
    batches = batch_jobs(expand_jobs(exp, ((i.run, i.suite, i.case, i.path, i.cost) for i in infos)), size=2)
    assert sorted(len(b) for b in batches) == [1] * 4 + [2] * 4  # 3 repetitions: a batch of 2 and one of 1
    groups = list(stream_batches(batches, jobs=2, backend="loky"))
    assert sorted(tuple(r.key for r in g) for g in groups) == sorted(b.keys for b in batches)
    assert all(r.status.value == "ok" for g in groups for r in g)


@pytest.mark.slow
@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="lists processes through Linux's /proc")
@pytest.mark.parametrize("jobs", ["1", "2"])
def test_a_slam_spinning_in_compiled_code_is_killed_past_its_deadline_and_the_pool_goes_on(tmp_path, jobs):
    """The spin never ends by itself: the campaign can only finish if the parent kills its workers."""
    from faultlab.runner.backends import DEADLINE_GRACE_S

    exp = write_experiment(tmp_path / "e.toml", **one_case(variants=["baseline", f"{SUTS}:SPIN", f"{SUTS}:BIAS"],
                                                           repetitions=2, timeout_s=2.0))
    out = tmp_path / "out"
    root = Path(__file__).resolve().parents[2]
    proc = subprocess.Popen([sys.executable, "-m", "faultlab", "run", str(exp), "--out", str(out), "--jobs", jobs,
                             "--no-progress"], cwd=root, env=dict(os.environ, PYTHONPATH=str(root)),
                            start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        proc.wait(timeout=600)  # generous for a loaded machine; without the deadline it never returns
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 0, proc.stderr.read().decode()
    df = load_results(out)
    spun = df[df.variant == f"{SUTS}:SPIN"]
    assert list(spun.status) == ["timeout", "timeout"]
    assert spun.error.str.contains("was killed").all()
    assert (spun.runtime_s == 2.0 + DEADLINE_GRACE_S).all()
    assert (df[df.variant != f"{SUTS}:SPIN"].status == "ok").all() and len(df) == 6
    assert load_metadata(out)["sessions"][-1]["state"] == "complete"


def test_leftovers_of_dead_campaign_processes_are_removed_and_nothing_of_live_ones(tmp_path):
    from faultlab.runner.backends import remove_leftovers

    done = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    dead, live = int(done.stdout), os.getpid()  # a pid just reaped (reuse within the test is negligible)
    planted = {}
    for pid in (dead, live):
        planted[pid] = [tmp_path / f"sem.loky-{pid}-abc123", tmp_path / f"joblib_memmapping_folder_{pid}_1a_2b",
                        tmp_path / f"faultlab-deadlines-{pid}-xyz"]
        planted[pid][0].write_bytes(b"")
        for d in planted[pid][1:]:
            d.mkdir()
            (d / "inside").write_text("x")
    other = tmp_path / "sem.other-1"
    other.write_bytes(b"")
    removed = remove_leftovers([tmp_path])
    assert sorted(removed) == sorted(planted[dead])
    assert not any(p.exists() for p in planted[dead])
    assert all(p.exists() for p in planted[live]) and other.exists()


def test_a_segfaulting_sut_is_a_crash_row_and_prints_no_thread_dump(tmp_path):
    exp = write_experiment(tmp_path / "e.toml", **one_case(variants=["baseline", f"{SUTS}:SEGV"]))
    out = tmp_path / "out"
    root = Path(__file__).resolve().parents[2]
    env = {k: v for k, v in os.environ.items() if k != "PYTHONFAULTHANDLER"}
    done = subprocess.run([sys.executable, "-m", "faultlab", "run", str(exp), "--out", str(out), "--jobs", "2",
                           "--no-progress"], cwd=root, env=dict(env, PYTHONPATH=str(root)), capture_output=True,
                          text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    assert "Fatal Python error" not in done.stderr and "Thread 0x" not in done.stderr, done.stderr
    df = load_results(out).set_index("variant")
    assert df.loc[f"{SUTS}:SEGV", "status"] == "crash" and df.loc[f"{SUTS}:SEGV", "error"].startswith("WorkerDied")
