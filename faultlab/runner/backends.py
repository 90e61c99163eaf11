"""Backends: running batches of jobs on joblib workers and streaming their results back.

:func:`stream_batches` dispatches :class:`~faultlab.runner.jobs.JobBatch` es to a joblib backend
(loky processes, threads, a dask.distributed cluster or ray) and yields each batch's
:class:`~faultlab.runner.execution.JobResult` s together as soon as the batch finishes (joblib's
``return_as="generator_unordered"``), so a caller can commit them in one transaction;
:func:`stream_results` yields the same results one job at a time.  A loky worker that dies
(segfault, ``os._exit``, out of memory) is detected, its in-flight batches are rerun one by one in
a fresh worker, and a batch that kills its worker again is recorded as ``crash`` for each of its
jobs.

Deadlines (loky): each worker announces the deadline of the job or batch it runs
(:func:`faultlab.runner.execution.init_worker`); a thread of the parent kills (SIGKILL) a worker
still busy :data:`DEADLINE_GRACE_S` seconds past it -- a SLAM spinning in compiled code with the
GIL held, which no signal handler in the worker can stop -- records the jobs of that call as
``timeout``, and the pool goes on.  A job thus ends within ``timeout_s`` (times the repetitions of
its batch) plus the grace plus one poll (:data:`DEADLINE_POLL_S`).  The threading, dask and ray
backends have only the workers' own limits.
"""

from __future__ import annotations

import atexit
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


def check_backend(name: str) -> None:
    """ConfigError unless ``name`` is one of :data:`faultlab.vocabulary.BACKENDS`."""
    if name not in BACKENDS:
        raise ConfigError(f"unknown backend {name!r}; use one of {', '.join(BACKENDS)}")


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


@contextlib.contextmanager
def _backend(name: str, jobs: int) -> Iterator[tuple[str, int]]:
    """Set up a joblib backend; yields (joblib backend name, n_jobs)."""
    if name in ("loky", "threading"):
        yield name, jobs
    elif name == "dask":
        try:
            import dask
            from distributed import Client, LocalCluster, get_client
        except ImportError as exc:
            raise ConfigError("backend 'dask' needs dask.distributed: pip install 'faultlab[dask]'") from exc
        try:
            get_client()
            owned = None
        except ValueError:  # no client yet: connect to a configured scheduler, or start a local one
            address = dask.config.get("scheduler-address", None)
            if address:
                owned = (Client(address), None)
            else:
                cluster = LocalCluster(n_workers=jobs, threads_per_worker=1, processes=True,
                                       dashboard_address=None)
                owned = (Client(cluster), cluster)
        try:
            yield "dask", -1
        finally:
            if owned is not None:
                owned[0].close()
                if owned[1] is not None:
                    owned[1].close()
    elif name == "ray":
        try:
            from ray.util.joblib import register_ray
        except ImportError as exc:
            raise ConfigError("backend 'ray' needs ray: pip install 'faultlab[ray]'") from exc
        register_ray()
        yield "ray", jobs
    else:
        check_backend(name)


def stream_results(todo: list[JobBatch], *, jobs: int, backend: str) -> Iterator[JobResult]:
    """Execute the batches of ``todo`` and yield their jobs' results as they finish (any order).

    The results of :func:`stream_batches`, one job at a time.

    Parameters
    ----------
    todo : list of JobBatch
        The batches, dispatched in this order.
    jobs : int
        Worker processes (joblib ``n_jobs``); ignored by ``dask`` (the cluster decides).
    backend : {"loky", "threading", "dask", "ray"}
        joblib backend (see :func:`faultlab.runner.run_experiment`).

    Yields
    ------
    JobResult
        One per job of ``todo``, in the order they finish.
    """
    for results in stream_batches(todo, jobs=jobs, backend=backend):
        yield from results


def stream_batches(todo: list[JobBatch], *, jobs: int, backend: str) -> Iterator[list[JobResult]]:
    """Execute the batches of ``todo`` and yield each batch's results together as soon as it finishes.

    Parameters are those of :func:`stream_results`.  A loky worker that dies is handled as there:
    the batches it may have been running are rerun one at a time, and the jobs of one that kills
    its worker again are yielded as ``crash`` results.

    Yields
    ------
    list of JobResult
        The results of one batch (in the batch's order), or of the batches a dead worker left, in
        the order they finish; every job of ``todo`` appears exactly once.
    """
    pending = list(todo)
    while pending:
        dispatched: set[tuple[JobKey, ...]] = set()
        returned: set[tuple[JobKey, ...]] = set()

        def tasks(batches: list[JobBatch]):
            for b in batches:
                dispatched.add(b.keys)
                yield delayed(execute_batch)(b)

        deadlines = _deadline_watch() if backend == "loky" else None
        try:
            watch = ({"initializer": init_worker, "initargs": (os.getpid(), str(deadlines.dir))}
                     if deadlines is not None else {})
            with _backend(backend, jobs) as (name, n_jobs), parallel_config(backend=name, n_jobs=n_jobs, **watch):
                parallel = Parallel(return_as="generator_unordered", batch_size=1)
                for results in parallel(tasks(pending)):
                    returned.add(tuple(r.key for r in results))
                    yield results
            return
        except BrokenProcessPool:
            if backend != "loky":
                raise
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

