"""Running a campaign: test cases, jobs on joblib workers, streaming into the store.

The parent process generates every test case once per (run, suite) and saves
it under ``out/cases`` *before* dispatching (as in the paper, all variants see
the same cases).  Each job then receives a small :class:`~faultlab.runner.jobs.JobSpec`
and loads its case itself.  Results stream back with joblib's
``return_as="generator_unordered"`` and are committed to SQLite one row at a
time, so a killed run loses only the jobs in flight and a rerun resumes.

Faults in the SLAM under test never stop the campaign: an exception or a
non-finite estimate is recorded as ``crash`` (with ``"Type: message"``), a SLAM
past ``timeout_s`` is stopped and recorded as ``timeout``.  The limit is
enforced with ``SIGALRM`` (``signal.setitimer``) when the job runs in a
process's main thread (loky workers, ``jobs=1``), which also stops a SLAM stuck
in a Python loop or a sleep; elsewhere (threads, dask workers) a cooperative
deadline check between SLAM steps is the fallback.  A loky worker that dies
(segfault, ``os._exit``, out of memory) is detected, its in-flight jobs are
rerun one by one in a fresh worker, and the job that kills its worker again is
recorded as ``crash``.

Batched repetitions: when the SLAM under test runs repetitions in a batch (``supports_batch``,
e.g. the reference FastSLAM), the repetitions of one (case, variant) still missing from the store
form one :class:`~faultlab.runner.jobs.JobBatch`, run by one worker as one batched SLAM
(:func:`execute_batch`).  Each repetition keeps its seed and gets its own row, identical to the
row it would get alone (only ``runtime_s`` differs: every row of a batch records the batch's SLAM
time divided by the number of repetitions in it).  A resumed campaign batches only the missing
repetitions.  A failure of one repetition (non-finite weights, an exception in a unit called for
its filter alone) is recorded as that repetition's ``crash``; an exception the batched SLAM cannot
attribute to one repetition makes the worker rerun the batch's repetitions one at a time, so every
row is still the one a single run gives.  A batch's wall-clock limit is ``timeout_s`` times its
number of repetitions; past it, every repetition is recorded as ``timeout``.  A batch that kills
its worker twice is recorded as ``crash`` for each of its repetitions.

The executors tune glibc's allocator once per worker process (:func:`tune_allocator`), so that the
SLAM's large work arrays are reused instead of being mapped and unmapped at every allocation.
"""

from __future__ import annotations

import contextlib
import ctypes
import dataclasses
import math
import os
import platform
import signal
import threading
import time
import traceback
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator, Mapping

import numpy as np

from joblib import Parallel, delayed, parallel_config
from joblib.externals.loky.process_executor import BrokenProcessPool, ProcessPoolExecutor

from faultlab.errors import ConfigError, FaultlabError, ResultsError, ScenarioError
from faultlab.faults import FaultNotApplicableWarning, NotApplicable, not_applicable, slam_units
from faultlab.metrics import map_errors
from faultlab.runner.experiment import Experiment, load_experiment
from faultlab.runner.jobs import JobBatch, JobKey, JobSpec, batch_jobs, expand_jobs
from faultlab.runner.progress import format_duration
from faultlab.runner.progress import progress as show_progress
from faultlab.runner.store import ID_COLUMNS, ResultStore, case_path, store_lock
from faultlab.runner.variants import resolve_variant
from faultlab.scenario.model import Scenario, load_scenario, save_scenario
from faultlab.scenario.suite import SuiteCase, draw_suite, generate_case
from faultlab.slam.protocol import Estimate, SlamAdapter, association_of, run_slam, run_slam_batch
from faultlab.space.case import PARAMETER_NAMES, VALUE_KEYS
from faultlab.vocabulary import BACKENDS, UNKNOWN_ASSOCIATION, JobStatus

__all__ = [
    "SKIPPED_VARIANTS_KEY",
    "JobResult",
    "CaseInfo",
    "RunSummary",
    "execute_job",
    "execute_batch",
    "tune_allocator",
    "prepare_cases",
    "run_experiment",
]

#: Key of the store's metadata (:func:`faultlab.runner.load_metadata`) listing the variants skipped
#: because their fault does not apply to the SLAM: one dict per variant with ``fault`` (the variant),
#: ``step``, ``slam``, ``n_units`` and ``reason`` (one sentence).
SKIPPED_VARIANTS_KEY = "skipped_variants"


@dataclass(frozen=True)
class JobResult:
    """What a worker sends back for one job (the parent adds the case's parameters).

    ``rms_mm``/``emd_mm`` are NaN and the counts 0 unless ``status`` is ok;
    ``error`` is "" when ok.
    """

    key: JobKey
    status: JobStatus
    rms_mm: float = math.nan
    emd_mm: float = math.nan
    n_mapped: int = 0
    n_unmapped: int = 0
    runtime_s: float = 0.0
    error: str = ""


@dataclass(frozen=True)
class CaseInfo:
    """A prepared test case: identity, saved path, parameters and a cost estimate."""

    run: int
    suite: str
    case: int
    path: Path
    values: Mapping[str, float | str]
    classes: Mapping[str, int]
    n_landmarks: int
    cost: float


@dataclass(frozen=True)
class RunSummary:
    """Result of :func:`run_experiment`.

    Attributes
    ----------
    out : Path
        Output directory.
    results : Path
        The SQLite store (read it with :func:`faultlab.runner.load_results`).
    n_jobs : int
        Jobs of the experiment.
    counts : mapping
        Rows per status (ok, crash, timeout) in the whole store.
    n_new : int
        Jobs executed by this call.
    n_skipped : int
        Jobs already in the store (resumed runs).
    wall_time_s : float
        Wall time of this call, s.
    """

    out: Path
    results: Path
    n_jobs: int
    counts: Mapping[str, int]
    n_new: int
    n_skipped: int
    wall_time_s: float
    experiment_hash: str = ""

    @property
    def complete(self) -> bool:
        return sum(self.counts.values()) == self.n_jobs

    def __str__(self) -> str:
        counts = ", ".join(f"{self.counts.get(s.value, 0)} {s.value}" for s in JobStatus)
        return (f"{self.n_jobs} jobs: {counts} ({self.n_new} run now, {self.n_skipped} already done); "
                f"wall time {format_duration(self.wall_time_s)}")


# ------------------------------------------------------------------ worker side
class _JobTimeout(BaseException):
    """Raised inside a job past its wall-clock limit (BaseException: a SUT's ``except Exception`` can't eat it)."""


class _Guarded(SlamAdapter):
    """Wraps the SUT: checks the job's deadline before every step (cooperative timeout)."""

    def __init__(self, inner: SlamAdapter, deadline: float):
        self.inner = inner
        self.deadline = deadline
        self.name = getattr(inner, "name", type(inner).__name__)
        self.supports_batch = bool(getattr(inner, "supports_batch", False))
        self.association = association_of(inner)

    def _check(self) -> None:
        if time.monotonic() > self.deadline:
            raise _JobTimeout()

    def reset(self, pose, *, rng):
        self._check()
        self.inner.reset(pose, rng=rng)

    def update(self, control, observations):
        self._check()
        self.inner.step(control, observations)

    def estimate(self) -> Estimate:
        self._check()
        return self.inner.estimate()

    def reset_batch(self, pose, *, rngs):
        self._check()
        self.inner.reset_batch(pose, rngs=rngs)

    def estimates(self) -> list:
        self._check()
        return self.inner.estimates()


@contextlib.contextmanager
def _alarm(seconds: float) -> Iterator[bool]:
    """Raise :class:`_JobTimeout` after ``seconds`` via SIGALRM, if this is a main thread on POSIX.

    Yields whether the alarm is armed.
    """
    usable = hasattr(signal, "setitimer") and threading.current_thread() is threading.main_thread()
    if not usable:
        yield False
        return
    armed = [True]

    def handler(signum, frame):
        if armed[0]:
            raise _JobTimeout()

    previous = signal.signal(signal.SIGALRM, handler)
    signal.setitimer(signal.ITIMER_REAL, max(float(seconds), 1e-3))
    try:
        yield True
    finally:
        try:
            armed[0] = False
        finally:  # restored even if the alarm fires right here
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)


_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3  # glibc's mallopt parameters (malloc.h)
_allocator_tuned: bool | None = None


def tune_allocator() -> bool:
    """Make glibc reuse freed memory instead of returning it to the system at every free (once per process).

    A SLAM step allocates and frees dozens of numpy work arrays.  glibc maps arrays above its mmap
    threshold (128 KiB, raised at run time up to what was freed) directly from the system and
    trims the top of the heap when more than twice that threshold is free, so with arrays of a
    few hundred kB and more every new array starts with page faults: the largest Table I case
    took up to 5 million minor page faults and 1.8 times the CPU time with ten batched
    repetitions, 20 % more with one.  Raising both thresholds (mmap: 32 MiB, the maximum; trim:
    1 GiB) keeps the memory in the process for reuse; a worker's resident size then stays at its
    peak.  Only the allocation strategy changes, never a result.  Called by the job executors;
    does nothing off glibc.

    Returns
    -------
    bool
        Whether the thresholds are set (False off glibc or if ``mallopt`` refused).
    """
    global _allocator_tuned
    if _allocator_tuned is None:
        _allocator_tuned = False
        if platform.system() == "Linux" and platform.libc_ver()[0] == "glibc":
            try:
                libc = ctypes.CDLL(None)
                _allocator_tuned = bool(libc.mallopt(_M_MMAP_THRESHOLD, 32 << 20)
                                        and libc.mallopt(_M_TRIM_THRESHOLD, 1 << 30))
            except (OSError, AttributeError):
                pass
    return _allocator_tuned


def _describe(exc: BaseException) -> str:
    """``"Type: message (at file.py:line in func)"`` with the innermost frame."""
    text = f"{type(exc).__name__}: {exc}"
    tb = traceback.extract_tb(exc.__traceback__)
    if tb:
        fr = tb[-1]
        text += f" (at {os.path.basename(fr.filename)}:{fr.lineno} in {fr.name})"
    return text


def _build(spec: JobSpec) -> SlamAdapter:
    """The SLAM under test of ``spec`` with its variant's fault applied."""
    slam = spec.slam.build()
    fault = resolve_variant(spec.key.variant)
    return slam if fault is None else fault.apply(slam)


def _score(key: JobKey, scenario: Scenario, estimate: Estimate, runtime: float, *, association: str) -> JobResult:
    """The ``ok`` result of an estimate, or ``crash`` if the metrics cannot score it.

    ``association`` is the SLAM's (:func:`~faultlab.slam.protocol.association_of`): a map without
    landmark ids is scored by the EMD alone (:func:`~faultlab.metrics.map_errors`).
    """
    try:
        with np.errstate(all="ignore"):
            err = map_errors(scenario, estimate, association=association)
    except Exception as exc:  # e.g. an estimate the metrics cannot score
        return JobResult(key, JobStatus.CRASH, runtime_s=runtime, error=f"metrics: {_describe(exc)}")
    return JobResult(key, JobStatus.OK, rms_mm=float(err.rms_mm), emd_mm=float(err.emd_mm),
                     n_mapped=int(err.n_mapped), n_unmapped=int(err.n_unmapped), runtime_s=runtime)


def execute_job(spec: JobSpec) -> JobResult:
    """Run one job: load its case, build the SLAM (+ fault), drive it, score the map.

    SUT failures become ``crash``/``timeout`` results; only infrastructure
    errors (e.g. a missing case file) raise.
    """
    tune_allocator()
    scenario = load_scenario(spec.case_path)
    t0 = time.perf_counter()
    try:
        try:
            with _alarm(spec.timeout_s):
                deadline = time.monotonic() + spec.timeout_s
                slam = _build(spec)
                with np.errstate(all="ignore"):  # a NaN estimate is reported as a crash row, not as warnings
                    estimate = run_slam(_Guarded(slam, deadline), scenario,
                                        rng=np.random.default_rng(spec.seed))
        finally:
            runtime = time.perf_counter() - t0
    except _JobTimeout:
        return JobResult(spec.key, JobStatus.TIMEOUT, runtime_s=runtime,
                         error=f"timeout: wall-clock limit of {spec.timeout_s:g} s exceeded")
    except (Exception, SystemExit) as exc:  # the SUT's fault, never the campaign's
        return JobResult(spec.key, JobStatus.CRASH, runtime_s=runtime, error=_describe(exc))
    return _score(spec.key, scenario, estimate, runtime, association=association_of(slam))


def execute_batch(batch: JobBatch) -> list[JobResult]:
    """Run the repetitions of a batch in one batched SLAM; one result per job, in the batch's order.

    Each repetition's result is the one :func:`execute_job` gives for it, except ``runtime_s``
    (the batch's SLAM time divided by its number of repetitions).  A repetition that fails on
    its own is a ``crash`` with its own message; an exception the batched SLAM cannot attribute
    to one repetition reruns every repetition alone with :func:`execute_job`.  Past the batch's
    limit (:attr:`JobBatch.timeout_s`) every repetition is a ``timeout``.  A SLAM without
    ``supports_batch``, or a batch of one, runs job by job.
    """
    specs = batch.jobs
    if len(specs) == 1:
        return [execute_job(specs[0])]
    tune_allocator()
    scenario = load_scenario(specs[0].case_path)
    t0 = time.perf_counter()
    try:
        try:
            with _alarm(batch.timeout_s):
                deadline = time.monotonic() + batch.timeout_s
                slam = _build(specs[0])
                if not getattr(slam, "supports_batch", False):
                    outcomes = None
                else:
                    with np.errstate(all="ignore"):
                        outcomes = run_slam_batch(_Guarded(slam, deadline), scenario,
                                                  rngs=[np.random.default_rng(s.seed) for s in specs])
        finally:
            runtime = time.perf_counter() - t0
    except _JobTimeout:
        share = runtime / len(specs)
        return [JobResult(s.key, JobStatus.TIMEOUT, runtime_s=share,
                          error=f"timeout: wall-clock limit of {batch.timeout_s:g} s exceeded by a batch of "
                                f"{len(specs)} repetitions ({s.timeout_s:g} s each)") for s in specs]
    except (Exception, SystemExit):  # not attributable to one repetition: run each alone
        outcomes = None
    if outcomes is None:
        return [execute_job(s) for s in specs]
    share = runtime / len(specs)
    association = association_of(slam)
    return [JobResult(s.key, JobStatus.CRASH, runtime_s=share, error=_describe(out))
            if isinstance(out, BaseException) else _score(s.key, scenario, out, share, association=association)
            for s, out in zip(specs, outcomes)]


def _worker_died(spec: JobSpec, exc: BaseException) -> JobResult:
    return JobResult(spec.key, JobStatus.CRASH,
                     error=f"WorkerDied: the worker process running this job died "
                           f"(segfault, os._exit or out of memory): {type(exc).__name__}")


def _find_killer(suspects: list[JobBatch]) -> tuple[list[JobResult], list[JobBatch]]:
    """Run suspects one at a time in a private single-worker pool until one kills its worker.

    Returns the results obtained (every job of the killer recorded as ``crash``) and the
    suspects not run yet, which go back to the parallel pool.
    """
    results: list[JobResult] = []
    executor = ProcessPoolExecutor(max_workers=1)  # private: joblib's reusable executor stays untouched
    try:
        for i, batch in enumerate(suspects):
            try:
                results.extend(executor.submit(execute_batch, batch).result())
            except BrokenProcessPool as exc:
                results.extend(_worker_died(spec, exc) for spec in batch.jobs)
                return results, suspects[i + 1:]
    finally:
        executor.shutdown(wait=True)
    return results, []


# ------------------------------------------------------------------ parent side
def prepare_cases(experiment: Experiment, out: str | Path) -> list[CaseInfo]:
    """Generate and save every test case of ``experiment`` (idempotent).

    Cases come from the one case pipeline (:func:`faultlab.scenario.suite.draw_suite`,
    :func:`~faultlab.scenario.suite.generate_case`), so they are exactly those
    ``faultlab generate`` writes for the same seed, suite and run.  A case already on disk is
    loaded and checked against the experiment (seed and parameter values) instead of being
    regenerated.

    Raises
    ------
    ResultsError
        If a saved case belongs to another experiment.
    """
    space = experiment.parameter_space()
    infos: list[CaseInfo] = []
    for run in range(1, experiment.runs + 1):
        for suite in experiment.suites:
            for case in draw_suite(suite.kind, space, root_seed=experiment.seed, run=run, n_cases=suite.n_cases):
                path = case_path(out, run, suite.kind, case.case)
                scenario = _saved_case(path, case, experiment)
                if scenario is None:
                    scenario = generate_case(case, n_steps=experiment.n_steps, sensor_range=experiment.sensor_range,
                                             min_distance=experiment.min_distance, fov_bug=experiment.fov_bug)
                    save_scenario(scenario, path)
                infos.append(_case_info(case, path, scenario))
    return infos


def _saved_case(path: Path, case: SuiteCase, experiment: Experiment) -> Scenario | None:
    """The case saved at ``path`` by an earlier (possibly killed) run; None if absent or half-written."""
    if not path.exists():
        return None
    try:
        scenario = load_scenario(path)
    except ScenarioError:
        return None  # half-written by a killed run: regenerate
    if scenario.seed != case.seed or dict(scenario.case.values) != dict(case.spec.values):
        raise ResultsError(f"saved test case {path} does not match {experiment.source} "
                           f"(seed or parameter values differ); use --force-new")
    saved_bug = bool(scenario.meta.get("config", {}).get("fov_bug", False))
    if saved_bug != experiment.fov_bug:
        raise ResultsError(f"saved test case {path} does not match {experiment.source} "
                           f"(fov_bug = {saved_bug} there, {experiment.fov_bug} here); use --force-new")
    return scenario


def _case_info(case: SuiteCase, path: Path, scenario: Scenario) -> CaseInfo:
    n_lm = int(scenario.landmarks.shape[0])
    n_obs = int(scenario.obs_offsets[-1])
    cost = scenario.n_steps * (1.0 + n_lm / 64.0) + n_obs  # rough: per-step work grows with the map
    return CaseInfo(run=case.run, suite=case.suite, case=case.case, path=path, values=dict(case.spec.values),
                    classes={p: int(case.spec.classes.get(p, -1)) for p in PARAMETER_NAMES},
                    n_landmarks=n_lm, cost=cost)


def _preflight(experiment: Experiment) -> tuple[SlamAdapter, tuple[NotApplicable, ...]]:
    """Build the SUT and apply every fault once in the parent: configuration errors fail fast.

    A fault that replaces a unit the SUT does not have (:func:`faultlab.faults.not_applicable`:
    e.g. a resampling fault and EKF-SLAM, or any fault and dead reckoning) does not apply: its
    variant is skipped with a :class:`~faultlab.faults.FaultNotApplicableWarning` naming fault,
    unit and SLAM, and returned so that the caller drops its jobs and records it in the store.
    Returns the built SUT (without fault) and the skipped variants.
    """
    try:
        slam = experiment.slam.build()
    except FaultlabError:
        raise
    except Exception as exc:
        raise ConfigError(f"{experiment.source}: [slam] {experiment.slam.name!r} cannot be built "
                          f"({type(exc).__name__}: {exc})") from exc
    if not isinstance(slam, SlamAdapter):
        raise ConfigError(f"{experiment.source}: [slam] {experiment.slam.name!r} built a "
                          f"{type(slam).__name__}, not a SlamAdapter")
    if association_of(slam) == UNKNOWN_ASSOCIATION and experiment.metric != "emd":
        raise ConfigError(f"{experiment.source}: metric = {experiment.metric!r}, but [slam] {experiment.slam.name!r} "
                          f"associates landmarks itself (no ids, no RMS): use metric = \"emd\"")
    units = slam_units(slam)
    skipped: list[NotApplicable] = []
    for i, variant in enumerate(experiment.variants):
        fault = resolve_variant(variant)  # known: parse_experiment checked every name
        if fault is None:
            continue
        reason = not_applicable(fault, experiment.slam.name, units=units)
        if reason is not None:
            reason = dataclasses.replace(reason, fault=variant)  # as the experiment names it
            warnings.warn(f"{experiment.source}: variants[{i}] skipped: {reason}", FaultNotApplicableWarning,
                          stacklevel=3)
            skipped.append(reason)
            continue
        try:
            fault.apply(slam)
        except FaultlabError as exc:
            raise ConfigError(f"{experiment.source}: variants[{i}] = {variant!r} cannot be applied to "
                              f"slam {experiment.slam.name!r}: {exc}") from exc
    return slam, tuple(skipped)


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
        raise ConfigError(f"unknown backend {name!r}; use one of {', '.join(BACKENDS)}")


def _stream(todo: list[JobBatch], *, jobs: int, backend: str) -> Iterator[JobResult]:
    """Execute the batches of ``todo`` and yield their jobs' results as they finish (any order)."""
    pending = list(todo)
    while pending:
        dispatched: set[tuple[JobKey, ...]] = set()
        returned: set[tuple[JobKey, ...]] = set()

        def tasks(batches: list[JobBatch]):
            for b in batches:
                dispatched.add(b.keys)
                yield delayed(execute_batch)(b)

        try:
            with _backend(backend, jobs) as (name, n_jobs), parallel_config(backend=name, n_jobs=n_jobs):
                parallel = Parallel(return_as="generator_unordered", batch_size=1)
                for results in parallel(tasks(pending)):
                    returned.add(tuple(r.key for r in results))
                    yield from results
            return
        except BrokenProcessPool:
            if backend != "loky":
                raise
            # A worker died. Batches in flight are suspects: rerun each alone; a repeat kill is a crash.
            suspects = [b for b in pending if b.keys in dispatched and b.keys not in returned]
            results, innocent = _find_killer(suspects)
            yield from results
            pending = innocent + [b for b in pending if b.keys not in dispatched]


def _row(case: CaseInfo, res: JobResult) -> dict:
    row: dict = dict(zip(ID_COLUMNS, res.key.astuple()))
    for k in VALUE_KEYS:
        v = case.values[k]
        row[k] = str(v) if k == "directionality" else float(v)
    for p in PARAMETER_NAMES:
        row[f"class_{p}"] = int(case.classes.get(p, -1))
    row["n_landmarks"] = case.n_landmarks
    ok = res.status == JobStatus.OK
    row.update(rms_mm=res.rms_mm if ok else math.nan, emd_mm=res.emd_mm if ok else math.nan,
               n_mapped=res.n_mapped if ok else 0, n_unmapped=res.n_unmapped if ok else 0,
               runtime_s=float(res.runtime_s), status=str(res.status.value), error="" if ok else res.error)
    return row


def run_experiment(experiment: Experiment | str | Path, out: str | Path, *, jobs: int = 2,
                   backend: str = "loky", force_new: bool = False, progress: bool = True,
                   batch_size: int | None = None) -> RunSummary:
    """Run (or resume) a campaign and store one row per job in ``out/results.sqlite``.

    Parameters
    ----------
    experiment : Experiment or path
        The experiment (a path is loaded with :func:`load_experiment`).
    out : path
        Output directory (created).  Rerunning the same call resumes: only jobs
        missing from the store are executed.
    jobs : int
        Worker processes (joblib ``n_jobs``); ignored by ``dask`` (the cluster decides).
    backend : {"loky", "threading", "dask", "ray"}
        joblib backend.  ``dask`` uses the current dask.distributed client, else
        the scheduler in dask's ``scheduler-address`` config, else a local
        cluster of ``jobs`` processes; workers need the output directory on a
        shared file system.  ``ray`` uses ``ray.util.joblib``.
    force_new : bool
        Start afresh: move existing results and cases to ``out/previous-<time>/``
        (never deleted).  Without it, ``out`` holding another experiment's
        results is an error.
    progress : bool
        Show progress on stderr (:func:`faultlab.runner.progress.progress`): a tqdm bar on a
        terminal, otherwise a log line every 10 % of the jobs (done/total, crashes and
        timeouts so far, elapsed time, ETA).
    batch_size : int, optional
        For a SLAM that runs repetitions in a batch (``supports_batch``): at most this many
        repetitions of a (case, variant) per job (default: all that are missing from the store;
        1: one repetition per job).  The results are the same whatever the batch size, except
        ``runtime_s``.

    Returns
    -------
    RunSummary

    Raises
    ------
    ConfigError
        Bad experiment, backend or ``jobs``.
    ResultsError
        ``out`` belongs to another experiment (without ``force_new``) or is in use.
    """
    if not isinstance(experiment, Experiment):
        experiment = load_experiment(experiment)
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise ConfigError(f"jobs must be an integer >= 1, got {jobs!r}")
    if backend not in BACKENDS:
        raise ConfigError(f"unknown backend {backend!r}; use one of {', '.join(BACKENDS)}")
    if batch_size is not None and (isinstance(batch_size, bool) or not isinstance(batch_size, int)
                                   or batch_size < 1):
        raise ConfigError(f"batch_size must be an integer >= 1 or None, got {batch_size!r}")
    t0 = time.perf_counter()
    out = Path(out)
    sut, skipped = _preflight(experiment)
    with store_lock(out), ResultStore.open(out, experiment, force_new=force_new) as store:
        store.set_meta(SKIPPED_VARIANTS_KEY, [dataclasses.asdict(r) | {"reason": str(r)} for r in skipped])
        cases = prepare_cases(experiment, out)
        info = {(c.run, c.suite, c.case): c for c in cases}
        specs = expand_jobs(experiment, ((c.run, c.suite, c.case, c.path, c.cost) for c in cases))
        if skipped:  # variants whose fault does not apply to the SLAM have no jobs
            names = {r.fault for r in skipped}
            specs = [s for s in specs if s.key.variant not in names]
        done = store.done_keys()
        todo = [s for s in specs if s.key.astuple() not in done]
        # the missing repetitions of a (case, variant) run as one batched SLAM if the SUT can
        batches = batch_jobs(todo, size=batch_size if getattr(sut, "supports_batch", False) else 1)
        batches.sort(key=lambda b: (-b.cost, b.keys))  # longest first: shorter tail on few workers
        counts = {s.value: 0 for s in JobStatus} | store.status_counts()
        session = store.begin_session(jobs=jobs, backend=backend, n_todo=len(todo))
        n_new, state = 0, "interrupted"
        try:
            with show_progress(len(specs), done=len(specs) - len(todo), desc="faultlab run", unit="job",
                               enabled=progress,
                               counts={"crash": counts["crash"], "timeout": counts["timeout"]}) as bar:
                for res in _stream(batches, jobs=jobs, backend=backend):
                    k = res.key
                    store.write(_row(info[(k.run, k.suite, k.case)], res), session=session)
                    n_new += 1
                    counts[res.status.value] = counts.get(res.status.value, 0) + 1
                    bar.update(1, crash=counts["crash"], timeout=counts["timeout"])
            state = "complete"
        finally:
            store.end_session(session, state=state, n_new=n_new, wall_time_s=time.perf_counter() - t0)
        counts = {s.value: 0 for s in JobStatus} | store.status_counts()
        return RunSummary(out=out, results=store.path, n_jobs=len(specs), counts=counts, n_new=n_new,
                          n_skipped=len(specs) - len(todo), wall_time_s=time.perf_counter() - t0,
                          experiment_hash=experiment.hash)
