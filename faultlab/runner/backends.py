"""Backends: running batches of jobs on joblib workers and streaming their results back.

:func:`stream_batches` dispatches :class:`~faultlab.runner.jobs.JobBatch` es to loky worker
processes (joblib) and yields each batch's
:class:`~faultlab.runner.execution.JobResult` s together as soon as the batch finishes (joblib's
``return_as="generator_unordered"``), so a caller can commit them in one transaction;
:func:`stream_results` yields the same results one job at a time.  A loky worker that dies
(segfault, ``os._exit``, out of memory) is detected, its in-flight batches are rerun one by one in
a fresh worker, and a batch that kills its worker again is recorded as ``crash`` for each of its
jobs.

Deadlines: each worker process announces the deadline of the job or batch it runs
(:func:`faultlab.runner.execution.init_worker`); a thread of the parent kills (SIGKILL) a worker
still busy :data:`DEADLINE_GRACE_S` seconds past it -- a SLAM spinning in compiled code with the
GIL held, which no signal handler in the worker can stop -- records the jobs of that call as
``timeout``, and the pool goes on.  A job thus ends within ``timeout_s`` (times the repetitions of
its batch) plus the grace plus one poll (:data:`DEADLINE_POLL_S`).  This holds for every
combination :func:`check_backend` accepts: loky with any ``jobs``, and ``jobs = 1`` with loky or
threading -- joblib would run those in the campaign process itself, so they run one after another
in one reusable loky worker process instead (same results: every job draws from its own seed).
Threads (threading with ``jobs >= 2``), dask and ray workers cannot be killed from the campaign
process, so those combinations are refused.

The deadline API, for drivers that run jobs: :func:`check_backend` (before anything is written)
and :func:`stream_batches` / :func:`stream_results`; nothing else is needed to have every job's
``timeout_s`` enforced.
"""

from __future__ import annotations

import atexit
import collections
import contextlib
import json
import os
import shutil
import signal
import tempfile
import threading
import time
from pathlib import Path
from typing import Iterator

from joblib import Parallel, delayed, parallel_config
from joblib.externals.loky.process_executor import BrokenProcessPool, ProcessPoolExecutor

from faultlab.errors import ConfigError
from faultlab.runner.execution import JobResult, execute_batch, init_worker, worker_died, worker_killed
from faultlab.runner.jobs import JobBatch, JobKey
from faultlab.vocabulary import BACKENDS

__all__ = ["stream_results", "stream_batches", "check_backend", "remove_leftovers", "DEADLINE_GRACE_S",
           "DEADLINE_POLL_S"]

#: Seconds past a job's (or batch's) wall-clock limit after which the parent kills its worker.
DEADLINE_GRACE_S = 5.0
#: Seconds between two looks of the parent at its workers' deadlines.
DEADLINE_POLL_S = 0.5
_DEADLINE_PREFIX = "faultlab-deadlines-"


def check_backend(name: str, *, jobs: int = 1) -> None:
    """ConfigError unless backend ``name`` with ``jobs`` workers can enforce every job's ``timeout_s``.

    ``name`` must be one of :data:`faultlab.vocabulary.BACKENDS`; threads (threading with
    ``jobs >= 2``) and dask or ray workers are refused: nothing outside them can stop a SLAM stuck
    in compiled code, which would hang the campaign (see the module's docstring).
    """
    if name not in BACKENDS:
        raise ConfigError(f"unknown backend {name!r}; use one of {', '.join(BACKENDS)}")
    if name == "threading" and jobs >= 2 or name in ("dask", "ray"):
        where = "threads" if name == "threading" else f"{name} workers"
        raise ConfigError(f"backend {name!r} cannot enforce timeout_s: {where} cannot be killed by the campaign "
                          f"when a SLAM is stuck past its limit (e.g. in compiled code); use the loky backend "
                          f"(--backend loky, any --jobs)")


class _DeadlineWatch:
    """The parent's side of the deadlines: one directory and one daemon thread per campaign process."""

    def __init__(self) -> None:
        remove_leftovers()
        self.dir = Path(tempfile.mkdtemp(prefix=f"{_DEADLINE_PREFIX}{os.getpid()}-"))
        self._lock = threading.Lock()
        self._killed: dict[tuple, float] = {}  # job key tuple -> its call's limit
        threading.Thread(target=self._watch, name="faultlab-deadline-watch", daemon=True).start()
        atexit.register(shutil.rmtree, self.dir, True)

    def _watch(self) -> None:
        while True:
            time.sleep(DEADLINE_POLL_S)
            try:
                announced = list(self.dir.glob("*.json"))
            except OSError:
                continue
            for path in announced:
                try:
                    record = json.loads(path.read_text())
                except (OSError, ValueError):
                    continue  # finished meanwhile
                if time.monotonic() <= record["deadline"] + DEADLINE_GRACE_S:
                    continue
                with self._lock:
                    self._killed.update({tuple(k): record["limit"] for k in record["keys"]})
                with contextlib.suppress(ProcessLookupError, ValueError):
                    os.kill(int(path.stem), signal.SIGKILL)
                path.unlink(missing_ok=True)

    def take(self, batches: list[JobBatch]) -> tuple[list[JobResult], list[JobBatch], list[JobBatch]]:
        """Split ``batches`` (in flight when a worker died) by the kills of this watch.

        Returns the ``timeout`` results of the killed calls' jobs, the other jobs of the batches
        they belonged to (one batch each, to run again), and the batches no kill touched.
        """
        with self._lock:
            killed, self._killed = self._killed, {}
        timed: list[JobResult] = []
        again: list[JobBatch] = []
        untouched: list[JobBatch] = []
        for b in batches:
            hit = [s for s in b.jobs if s.key.astuple() in killed]
            if not hit:
                untouched.append(b)
                continue
            timed.extend(worker_killed(s.key, killed[s.key.astuple()], DEADLINE_GRACE_S) for s in hit)
            again.extend(JobBatch((s,)) for s in b.jobs if s.key.astuple() not in killed)
        return timed, again, untouched


def _gone(pid: str) -> bool:
    """Whether no process ``pid`` exists (False if it does, or if ``pid`` is no pid)."""
    try:
        os.kill(int(pid), 0)
    except ProcessLookupError:
        return True
    except (ValueError, OverflowError, PermissionError):  # not a pid; another user's live process
        return False
    return False


def remove_leftovers(roots: list[Path] | None = None) -> list[Path]:
    """Remove what campaign processes killed by SIGKILL left behind; returns the paths removed.

    Nothing of a process that still exists is touched: faultlab's deadline directories
    (``faultlab-deadlines-PID-*``), loky's named semaphores (``/dev/shm/sem.loky-PID-*``) and
    joblib's memmapping folders (``joblib_memmapping_folder_PID_*``, in ``/dev/shm``, the
    temporary directory or ``JOBLIB_TEMP_FOLDER``; or in ``roots``).  Called when a loky pool starts.
    """
    if roots is None:
        roots = [Path(tempfile.gettempdir()), Path("/dev/shm")]
        if os.environ.get("JOBLIB_TEMP_FOLDER"):
            roots.append(Path(os.environ["JOBLIB_TEMP_FOLDER"]))
    patterns = ((_DEADLINE_PREFIX, "-"), ("sem.loky-", "-"), ("joblib_memmapping_folder_", "_"))
    removed = []
    for root in dict.fromkeys(roots):
        for prefix, sep in patterns:
            try:
                found = list(root.glob(f"{prefix}*"))
            except OSError:
                continue
            for path in found:
                if not _gone(path.name[len(prefix):].split(sep)[0]):
                    continue
                try:
                    if path.is_dir():
                        shutil.rmtree(path)
                    else:
                        path.unlink()
                except OSError:  # another user's, or removed meanwhile
                    continue
                removed.append(path)
    return removed


_watch: _DeadlineWatch | None = None


def _deadline_watch() -> _DeadlineWatch:
    """This process's deadline watch (started on first use: the loky workers' initargs stay the same)."""
    global _watch
    if _watch is None or not _watch.dir.is_dir():
        _watch = _DeadlineWatch()
    return _watch


def _find_killer(suspects: list[JobBatch], watch: _DeadlineWatch) -> tuple[list[JobResult], list[JobBatch]]:
    """Run suspects one at a time in a private single-worker pool until one kills its worker.

    Returns the results obtained (every job of the killer recorded as ``crash``; of a suspect the
    deadline watch killed, ``timeout``) and the suspects not run yet, which go back to the
    parallel pool.
    """
    results: list[JobResult] = []
    executor = ProcessPoolExecutor(max_workers=1, initializer=init_worker,  # private: joblib's stays untouched
                                   initargs=(os.getpid(), str(watch.dir)))
    try:
        for i, batch in enumerate(suspects):
            try:
                results.extend(executor.submit(execute_batch, batch).result())
            except BrokenProcessPool as exc:
                timed, again, _ = watch.take([batch])
                if timed:
                    results.extend(timed)
                    return results, again + suspects[i + 1:]
                results.extend(worker_died(spec, exc) for spec in batch.jobs)
                return results, suspects[i + 1:]
    finally:
        executor.shutdown(wait=True)
    return results, []


#: Seconds an idle worker of :func:`_one_worker` waits for more work before it exits (joblib's default).
IDLE_WORKER_TIMEOUT_S = 300
_single: tuple[tuple, ProcessPoolExecutor] | None = None  # (initargs, executor) of _one_worker


def _single_worker(initargs: tuple) -> ProcessPoolExecutor:
    """This process's one-worker executor, kept between calls (as joblib keeps its pool); a new one if it broke.

    Private: joblib's own reusable executor (``jobs >= 2``) is never touched.
    """
    global _single
    if _single is None or _single[0] != initargs:
        if _single is not None:
            _single[1].shutdown(wait=False, kill_workers=True)
        _single = (initargs, ProcessPoolExecutor(max_workers=1, timeout=IDLE_WORKER_TIMEOUT_S,
                                                 initializer=init_worker, initargs=initargs))
    return _single[1]


def _drop_single_worker() -> None:
    """Kill the one-worker executor's process (broken, or busy with a batch nobody waits for)."""
    global _single
    if _single is not None:
        _single[1].shutdown(wait=False, kill_workers=True)
        _single = None


atexit.register(_drop_single_worker)  # the command's end ends its worker, not the worker's idle timeout


def _one_worker(pending: list[JobBatch], watch: _DeadlineWatch) -> Iterator[list[JobResult]]:
    """Run ``pending`` one batch after another in one loky worker process; yield each batch's results.

    The parent's deadline thus holds for ``jobs = 1`` too.  A batch whose worker the deadline watch
    killed is ``timeout`` for the jobs of the killed call (the others run again); a batch whose
    worker died otherwise is rerun alone once and is a ``crash`` of each job if it kills its worker
    again (:func:`_find_killer`), as with more workers.  If the caller stops early (an exception,
    Ctrl-C, SIGTERM), the worker is killed at once instead of finishing a batch nobody waits for.
    """
    queue = collections.deque(pending)
    busy = False
    try:
        while queue:
            batch = queue.popleft()
            busy = True
            try:
                results = _single_worker((os.getpid(), str(watch.dir))).submit(execute_batch, batch).result()
            except BrokenProcessPool:
                _drop_single_worker()
                results, again, _ = watch.take([batch])
                if not results:  # died of something else: a suspect, rerun alone
                    results, again = _find_killer([batch], watch)
                queue.extendleft(reversed(again))
            busy = False
            yield results
    finally:
        if busy:
            _drop_single_worker()


def stream_results(todo: list[JobBatch], *, jobs: int, backend: str) -> Iterator[JobResult]:
    """Execute the batches of ``todo`` and yield their jobs' results as they finish (any order).

    The results of :func:`stream_batches`, one job at a time.

    Parameters
    ----------
    todo : list of JobBatch
        The batches, dispatched in this order.
    jobs : int
        Worker processes (joblib ``n_jobs``); with 1 the batches run one after another in one.
    backend : {"loky", "threading"}
        joblib backend; see :func:`check_backend` for the combinations refused.

    Yields
    ------
    JobResult
        One per job of ``todo``, in the order they finish.

    Raises
    ------
    ConfigError
        A backend and ``jobs`` that cannot enforce the jobs' deadlines (:func:`check_backend`).
    """
    for results in stream_batches(todo, jobs=jobs, backend=backend):
        yield from results


def stream_batches(todo: list[JobBatch], *, jobs: int, backend: str) -> Iterator[list[JobResult]]:
    """Execute the batches of ``todo`` and yield each batch's results together as soon as it finishes.

    Parameters are those of :func:`stream_results`.  A worker that dies is handled as there: the
    batches it may have been running are rerun one at a time, and the jobs of one that kills its
    worker again are yielded as ``crash`` results; a worker the deadline watch killed gives
    ``timeout`` results for the jobs of the call it was running.

    Yields
    ------
    list of JobResult
        The results of one batch (in the batch's order), or of the batches a dead worker left, in
        the order they finish; every job of ``todo`` appears exactly once.
    """
    check_backend(backend, jobs=jobs)
    pending = list(todo)
    deadlines = _deadline_watch()
    if jobs == 1:  # joblib would run them in this process, out of the deadline watch's reach
        yield from _one_worker(pending, deadlines)
        return
    while pending:
        dispatched: set[tuple[JobKey, ...]] = set()
        returned: set[tuple[JobKey, ...]] = set()

        def tasks(batches: list[JobBatch]):
            for b in batches:
                dispatched.add(b.keys)
                yield delayed(execute_batch)(b)

        try:
            with parallel_config(backend=backend, n_jobs=jobs, initializer=init_worker,
                                 initargs=(os.getpid(), str(deadlines.dir))):
                parallel = Parallel(return_as="generator_unordered", batch_size=1)
                for results in parallel(tasks(pending)):
                    returned.add(tuple(r.key for r in results))
                    yield results
            return
        except BrokenProcessPool:
            in_flight = [b for b in pending if b.keys in dispatched and b.keys not in returned]
            timed, again, untouched = deadlines.take(in_flight)
            if timed:  # the deadline watch killed a worker: the others' batches go back to the pool
                yield timed
                pending = again + untouched + [b for b in pending if b.keys not in dispatched]
                continue
            # A worker died. Batches in flight are suspects: rerun each alone; a repeat kill is a crash.
            results, innocent = _find_killer(untouched, deadlines)
            if results:
                yield results
            pending = innocent + [b for b in pending if b.keys not in dispatched]
