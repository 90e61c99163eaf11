"""Backends: running batches of jobs on joblib workers and streaming their results back.

:func:`stream_batches` dispatches :class:`~faultlab.runner.jobs.JobBatch` es to a joblib backend
(loky processes, threads, a dask.distributed cluster or ray) and yields each batch's
:class:`~faultlab.runner.execution.JobResult` s together as soon as the batch finishes (joblib's
``return_as="generator_unordered"``), so a caller can commit them in one transaction;
:func:`stream_results` yields the same results one job at a time.  A loky worker that dies
(segfault, ``os._exit``, out of memory) is detected, its in-flight batches are rerun one by one in
a fresh worker, and a batch that kills its worker again is recorded as ``crash`` for each of its
jobs.
"""

from __future__ import annotations

import contextlib
import os
from typing import Iterator

from joblib import Parallel, delayed, parallel_config
from joblib.externals.loky.process_executor import BrokenProcessPool, ProcessPoolExecutor

from faultlab.errors import ConfigError
from faultlab.runner.execution import JobResult, execute_batch, watch_parent, worker_died
from faultlab.runner.jobs import JobBatch, JobKey
from faultlab.vocabulary import BACKENDS

__all__ = ["stream_results", "stream_batches", "check_backend"]


def check_backend(name: str) -> None:
    """ConfigError unless ``name`` is one of :data:`faultlab.vocabulary.BACKENDS`."""
    if name not in BACKENDS:
        raise ConfigError(f"unknown backend {name!r}; use one of {', '.join(BACKENDS)}")


def _find_killer(suspects: list[JobBatch]) -> tuple[list[JobResult], list[JobBatch]]:
    """Run suspects one at a time in a private single-worker pool until one kills its worker.

    Returns the results obtained (every job of the killer recorded as ``crash``) and the
    suspects not run yet, which go back to the parallel pool.
    """
    results: list[JobResult] = []
    executor = ProcessPoolExecutor(max_workers=1, initializer=watch_parent,  # private: joblib's stays untouched
                                   initargs=(os.getpid(),))
    try:
        for i, batch in enumerate(suspects):
            try:
                results.extend(executor.submit(execute_batch, batch).result())
            except BrokenProcessPool as exc:
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

        try:
            watch = {"initializer": watch_parent, "initargs": (os.getpid(),)} if backend == "loky" else {}
            with _backend(backend, jobs) as (name, n_jobs), parallel_config(backend=name, n_jobs=n_jobs, **watch):
                parallel = Parallel(return_as="generator_unordered", batch_size=1)
                for results in parallel(tasks(pending)):
                    returned.add(tuple(r.key for r in results))
                    yield results
            return
        except BrokenProcessPool:
            if backend != "loky":
                raise
            # A worker died. Batches in flight are suspects: rerun each alone; a repeat kill is a crash.
            suspects = [b for b in pending if b.keys in dispatched and b.keys not in returned]
            results, innocent = _find_killer(suspects)
            if results:
                yield results
            pending = innocent + [b for b in pending if b.keys not in dispatched]

