"""Executing jobs in a worker: one job, or the repetitions of a batch in one batched SLAM.

Each job receives a small :class:`~faultlab.runner.jobs.JobSpec` and loads its saved case itself.
Faults in the SLAM under test never stop the campaign: an exception or a non-finite estimate is
recorded as ``crash`` (with ``"Type: message"``), a SLAM past ``timeout_s`` is stopped and recorded
as ``timeout``.  The limit is enforced with ``SIGALRM`` (``signal.setitimer``) when the job runs in
a process's main thread (loky workers, ``jobs=1``), which also stops a SLAM stuck in a Python loop
or a sleep; elsewhere (a thread) a cooperative deadline check between SLAM steps is
the fallback.  Neither stops a SLAM that spins in compiled code holding the GIL (the SIGALRM handler
runs only between bytecodes): for that the worker announces each call's deadline in a file the
parent watches (:func:`init_worker`), and the parent kills a worker still busy past the deadline
plus a grace (:mod:`faultlab.runner.backends`).

Batched repetitions: when the SLAM under test runs repetitions in a batch (``supports_batch``,
e.g. the reference FastSLAM), the repetitions of one (case, variant) still missing from the store
form one :class:`~faultlab.runner.jobs.JobBatch`, run by one worker as one batched SLAM
(:func:`execute_batch`).  Each repetition keeps its seed and gets its own row, identical to the
row it would get alone (only ``runtime_s`` differs: every row of a batch records the batch's SLAM
time divided by the number of repetitions in it).  A failure of one repetition (non-finite
weights, an exception in a unit called for its filter alone) is recorded as that repetition's
``crash``; an exception the batched SLAM cannot attribute to one repetition makes the worker rerun
the batch's repetitions one at a time, so every row is still the one a single run gives.  A
batch's wall-clock limit is ``timeout_s`` times its number of repetitions; past it, every
repetition is recorded as ``timeout``.

Sensor faults (:class:`~faultlab.faults.sensor.SensorFault`): the SLAM is fed the perturbed
stream of its job (drawn from the job's seed, :func:`faultlab.seeds.sensor_seed_sequence`) while it
is scored against the case's unperturbed ground truth; the SLAM's own generator is the baseline's.
A hardware limit builds the SLAM with its option changed.

The executors tune glibc's allocator once per worker process (:func:`tune_allocator`), so that the
SLAM's large work arrays are reused instead of being mapped and unmapped at every allocation, and
keep the last few cases they loaded (:func:`load_case`): the batches of one case (its variants) are
dispatched one after another, so a case is read, checksummed and validated once per worker
instead of once per batch.
"""

from __future__ import annotations

import collections
import contextlib
import copy
import ctypes
import dataclasses
import faulthandler
import json
import math
import os
import platform
import signal
import threading
import time
import traceback
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np

from faultlab.faults.sensor import SensorFault
from faultlab.runner.variants import resolve_variant
from faultlab.metrics import map_errors, trajectory_error_mm
from faultlab.runner.jobs import JobBatch, JobKey, JobSpec
from faultlab.scenario.feed import fed_scenario, perturbs_stream
from faultlab.scenario.model import Scenario, load_scenario
from faultlab.slam.protocol import Estimate, SlamAdapter, association_of, run_slam, run_slam_batch
from faultlab.slam.twins import warm_up
from faultlab.vocabulary import JobStatus

__all__ = ["JobResult", "TimeLimitExceeded", "time_limit", "execute_job", "execute_batch", "load_case", "tune_allocator", "worker_died",
           "worker_killed", "watch_parent", "init_worker"]


@dataclass(frozen=True)
class JobResult:
    """What a worker sends back for one job (the parent adds the case's parameters).

    ``rms_mm``/``emd_mm``/``ate_mm`` are NaN and the counts 0 unless ``status`` is ok (``ate_mm`` also
    when the SLAM reports no trajectory or the job does not record it); ``error`` is "" when ok.
    """

    key: JobKey
    status: JobStatus
    rms_mm: float = math.nan
    emd_mm: float = math.nan
    ate_mm: float = math.nan
    n_mapped: int = 0
    n_unmapped: int = 0
    runtime_s: float = 0.0
    error: str = ""



class _JobTimeout(BaseException):
    """Raised inside a job past its wall-clock limit (BaseException: a SUT's ``except Exception`` can't eat it)."""


#: The exception :func:`time_limit` raises inside its block past the limit (a BaseException).
TimeLimitExceeded = _JobTimeout


class _Guarded(SlamAdapter):
    """Wraps the SUT: checks the job's deadline before every step (cooperative timeout)."""

    def __init__(self, inner: SlamAdapter, deadline: float):
        self.inner = inner
        self.deadline = deadline
        self.name = getattr(inner, "name", type(inner).__name__)
        self.supports_batch = bool(getattr(inner, "supports_batch", False))
        self.association = association_of(inner)
        # what reaches update() was checked by this wrapper's step() or by the driver (run_slam feeds
        # update() only inputs known to pass): the inner SLAM's update() then takes it directly,
        # unless the SLAM does more in a step() of its own
        self._advance = inner.update if type(inner).step is SlamAdapter.step else inner.step

    def _check(self) -> None:
        if time.monotonic() > self.deadline:
            raise _JobTimeout()

    def reset(self, pose, *, rng):
        self._check()
        self.inner.reset(pose, rng=rng)

    def update(self, control, observations):
        self._check()
        self._advance(control, observations)

    def estimate(self) -> Estimate:
        self._check()
        return self.inner.estimate()

    def reset_batch(self, pose, *, rngs):
        self._check()
        self.inner.reset_batch(pose, rngs=rngs)

    def estimates(self) -> list:
        self._check()
        return self.inner.estimates()


#: The directory in which this worker announces its deadlines (set by :func:`init_worker`), or None.
_deadline_dir: Path | None = None


def init_worker(parent_pid: int, deadline_dir: str | None = None) -> None:
    """The initializer of the executors' worker processes: :func:`watch_parent`, and announce deadlines.

    With ``deadline_dir``, every job or batch call writes ``PID.json`` there while it runs:
    ``{"deadline": time.monotonic() at the limit, "limit": seconds, "keys": [job keys]}``, so that the
    parent can kill a worker stuck past the limit in code no signal handler interrupts.  A worker
    that dies of a signal prints nothing (no thread dump that reads like faultlab's traceback) unless
    ``PYTHONFAULTHANDLER`` asks for it.
    """
    global _deadline_dir
    _deadline_dir = Path(deadline_dir) if deadline_dir else None
    if "PYTHONFAULTHANDLER" not in os.environ:  # loky would print every thread's stack when a SUT segfaults:
        faulthandler.enable(file=open(os.devnull, "w"))  # the job's crash row says the worker died
    watch_parent(parent_pid)


@contextlib.contextmanager
def _announced(seconds: float, keys: tuple[JobKey, ...]) -> Iterator[None]:
    """Announce the deadline of the call inside (see :func:`init_worker`); nothing without a directory."""
    if _deadline_dir is None:
        yield
        return
    path = _deadline_dir / f"{os.getpid()}.json"
    tmp = _deadline_dir / f"{os.getpid()}.tmp"
    record = {"deadline": time.monotonic() + float(seconds), "limit": float(seconds),
              "keys": [k.astuple() for k in keys]}
    try:
        tmp.write_text(json.dumps(record))
        os.replace(tmp, path)
    except OSError:  # the parent removed its directory: nothing watches this call
        yield
        return
    try:
        yield
    finally:
        path.unlink(missing_ok=True)


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


@contextlib.contextmanager
def time_limit(seconds: float) -> Iterator[bool]:
    """The jobs' wall-clock limit for other callers: raise :data:`TimeLimitExceeded` inside the block
    after ``seconds`` (SIGALRM; a SLAM stuck in a Python loop or a sleep is stopped).  Armed only in a
    process's main thread (loky workers, the main process); yields whether it is armed."""
    with _alarm(seconds) as armed:
        yield armed


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


#: Cases a worker keeps loaded (:func:`load_case`).
CASE_CACHE_SIZE = 4
_case_cache: collections.OrderedDict = collections.OrderedDict()  # (path, file identities) -> Scenario
_case_cache_lock = threading.Lock()


def _file_identity(path: Path) -> tuple[int, int, int, int]:
    st = os.stat(path)
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns)


def load_case(path: str | os.PathLike) -> Scenario:
    """The saved case at ``path`` (:func:`~faultlab.scenario.model.load_scenario`), read once per worker.

    The last :data:`CASE_CACHE_SIZE` cases loaded stay in memory, keyed by the path and the identity
    (device, inode, size, modification time) of both its files, so a case rewritten on disk (a new
    store in the same directory) is read again.  Every call returns its own copy of the arrays and
    metadata: a SLAM that writes into what it is fed cannot change what the next batch is fed.

    Raises
    ------
    ScenarioError
        As :func:`~faultlab.scenario.model.load_scenario` (a missing, damaged or foreign file).
    """
    base = Path(path)
    if base.suffix in (".npz", ".json"):
        base = base.with_suffix("")
    try:
        key = (str(base), _file_identity(base.with_name(base.name + ".npz")),
               _file_identity(base.with_name(base.name + ".json")))
    except OSError:
        return load_scenario(path)  # its own clear error for a missing file
    with _case_cache_lock:
        cached = _case_cache.get(key)
        if cached is not None:
            _case_cache.move_to_end(key)
    if cached is None:
        cached = load_scenario(path)
        with _case_cache_lock:
            _case_cache[key] = cached
            while len(_case_cache) > CASE_CACHE_SIZE:
                _case_cache.popitem(last=False)
    copies = {f.name: getattr(cached, f.name).copy() for f in dataclasses.fields(cached)
              if isinstance(getattr(cached, f.name), np.ndarray)}
    return dataclasses.replace(cached, meta=copy.deepcopy(cached.meta), **copies)


#: Seconds between two checks of a worker that its parent is still alive.
PARENT_POLL_S = 0.5


def watch_parent(parent_pid: int, interval_s: float = PARENT_POLL_S) -> None:
    """Make this worker process end within ``interval_s`` once the process ``parent_pid`` is gone.

    The initializer of the executors' worker processes.  A campaign killed by SIGKILL cannot shut
    its pool down, and idle loky workers would otherwise wait for work for minutes.  A daemon
    thread polls :func:`os.getppid`: an orphan is re-parented, so a different parent means the
    campaign is gone and the worker exits at once (``os._exit``: nothing of the dead campaign is
    left to clean up).  The thread needs the GIL: a worker inside one long call that holds it exits
    when that call returns (numpy and the SLAMs' kernels return to Python at every step).
    (``prctl(PR_SET_PDEATHSIG)`` is not used: it fires when the *thread* that started the worker
    ends, which for a reused pool need not be the campaign's end.)
    """
    if os.getppid() != parent_pid:  # died before the watch began
        os._exit(1)

    def watch() -> None:
        while os.getppid() == parent_pid:
            time.sleep(interval_s)
        os._exit(1)

    threading.Thread(target=watch, name="faultlab-parent-watch", daemon=True).start()


def _describe(exc: BaseException) -> str:
    """``"Type: message (at file.py:line in func)"`` with the innermost frame."""
    text = f"{type(exc).__name__}: {exc}"
    tb = traceback.extract_tb(exc.__traceback__)
    if tb:
        fr = tb[-1]
        text += f" (at {os.path.basename(fr.filename)}:{fr.lineno} in {fr.name})"
    return text


def _build(spec: JobSpec) -> SlamAdapter:
    """The SLAM under test of ``spec`` with its variant's fault applied (a hardware limit sets its option)."""
    fault = resolve_variant(spec.key.variant)
    if callable(getattr(fault, "build_slam", None)):  # a mutant of user source: the SLAM built from it
        return fault.build_slam(spec.slam)
    if isinstance(fault, SensorFault):
        options = fault.configure_options(dict(spec.slam.options))
        return dataclasses.replace(spec.slam, options=tuple(options.items())).build()
    slam = spec.slam.build()
    return slam if fault is None else fault.apply(slam)


def _fed(spec: JobSpec, scenario: Scenario) -> Scenario:
    """The scenario the SLAM of ``spec`` is fed: perturbed by a sensor fault (its own seed stream), else ``scenario``.

    The metrics always score against ``scenario`` itself (the ground truth).
    """
    return fed_scenario(resolve_variant(spec.key.variant), scenario, seed=spec.seed)


def _perturbs_stream(spec: JobSpec) -> bool:
    return perturbs_stream(resolve_variant(spec.key.variant))


def _score(spec: JobSpec, scenario: Scenario, estimate: Estimate, runtime: float, *, association: str) -> JobResult:
    """The ``ok`` result of an estimate, or ``crash`` if the metrics cannot score it.

    ``association`` is the SLAM's (:func:`~faultlab.slam.protocol.association_of`): a map without
    landmark ids is scored by the EMD alone (:func:`~faultlab.metrics.map_errors`).  Only the
    job's ``metrics`` are computed; the others are NaN.  The trajectory is scored against the
    unperturbed ground truth too (:func:`~faultlab.metrics.trajectory_error_mm`; NaN without one).
    """
    key = spec.key
    try:
        with np.errstate(all="ignore"):
            err = map_errors(scenario, estimate, association=association, metrics=spec.metrics)
            ate = trajectory_error_mm(scenario, estimate) if "ate" in spec.metrics else math.nan
    except Exception as exc:  # e.g. an estimate the metrics cannot score
        return JobResult(key, JobStatus.CRASH, runtime_s=runtime, error=f"metrics: {_describe(exc)}")
    return JobResult(key, JobStatus.OK, rms_mm=float(err.rms_mm), emd_mm=float(err.emd_mm), ate_mm=float(ate),
                     n_mapped=int(err.n_mapped), n_unmapped=int(err.n_unmapped), runtime_s=runtime)


def execute_job(spec: JobSpec) -> JobResult:
    """Run one job: load its case, build the SLAM (+ fault), drive it, score the map.

    SUT failures become ``crash``/``timeout`` results; only infrastructure
    errors (e.g. a missing case file) raise.
    """
    tune_allocator()
    warm_up()  # compile or load the SLAM kernels before the clock starts
    scenario = load_case(spec.case_path)
    t0 = time.perf_counter()
    try:
        try:
            with _announced(spec.timeout_s, (spec.key,)), _alarm(spec.timeout_s):
                deadline = time.monotonic() + spec.timeout_s
                slam = _build(spec)
                fed = _fed(spec, scenario)
                with np.errstate(all="ignore"):  # a NaN estimate is reported as a crash row, not as warnings
                    estimate = run_slam(_Guarded(slam, deadline), fed,
                                        rng=np.random.default_rng(spec.seed))
        finally:
            runtime = time.perf_counter() - t0
    except _JobTimeout:
        return JobResult(spec.key, JobStatus.TIMEOUT, runtime_s=runtime,
                         error=f"timeout: wall-clock limit of {spec.timeout_s:g} s exceeded")
    except (Exception, SystemExit) as exc:  # the SUT's fault, never the campaign's
        return JobResult(spec.key, JobStatus.CRASH, runtime_s=runtime, error=_describe(exc))
    return _score(spec, scenario, estimate, runtime, association=association_of(slam))


def execute_batch(batch: JobBatch) -> list[JobResult]:
    """Run the repetitions of a batch in one batched SLAM; one result per job, in the batch's order.

    Each repetition's result is the one :func:`execute_job` gives for it, except ``runtime_s``
    (the batch's SLAM time divided by its number of repetitions).  A repetition that fails on
    its own is a ``crash`` with its own message; an exception the batched SLAM cannot attribute
    to one repetition reruns every repetition alone with :func:`execute_job`.  Past the batch's
    limit (:attr:`JobBatch.timeout_s`) every repetition is a ``timeout``.  A SLAM without
    ``supports_batch``, a batch of one, or a sensor fault that perturbs the stream (each repetition
    sees its own perturbed stream) runs job by job.
    """
    specs = batch.jobs
    if len(specs) == 1 or _perturbs_stream(specs[0]):  # a sensor fault feeds each repetition its own stream
        return [execute_job(s) for s in specs]
    tune_allocator()
    warm_up()
    scenario = load_case(specs[0].case_path)
    t0 = time.perf_counter()
    try:
        try:
            with _announced(batch.timeout_s, batch.keys), _alarm(batch.timeout_s):
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
            if isinstance(out, BaseException) else _score(s, scenario, out, share, association=association)
            for s, out in zip(specs, outcomes)]



def worker_killed(key: JobKey, limit_s: float, grace_s: float) -> JobResult:
    """The ``timeout`` result of a job whose worker the parent killed past its deadline."""
    return JobResult(key, JobStatus.TIMEOUT, runtime_s=limit_s + grace_s,
                     error=f"timeout: wall-clock limit of {limit_s:g} s exceeded; the worker was still busy "
                           f"{grace_s:g} s later (e.g. a loop in compiled code) and was killed")


def worker_died(spec: JobSpec, exc: BaseException) -> JobResult:
    """The ``crash`` result of a job whose worker process died under it."""
    return JobResult(spec.key, JobStatus.CRASH,
                     error=f"WorkerDied: the worker process running this job died "
                           f"(segfault, os._exit or out of memory): {type(exc).__name__}")
