"""Orchestration: running (or resuming) a whole experiment into its results store.

The parent process generates every test case once per (run, suite) and saves it under
``out/cases`` *before* dispatching (as in the paper, all variants see the same cases).  The jobs
missing from the store are batched (:func:`~faultlab.runner.jobs.batch_jobs`), executed on a
backend (:func:`~faultlab.runner.backends.stream_batches`) and committed to SQLite one batch at a
time as it returns (:func:`result_row`, one transaction per batch), so a killed run loses only the
jobs in flight and a rerun resumes;
a resumed campaign batches only the missing repetitions.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import os
import time
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Iterator, Mapping, Sequence

from faultlab.errors import ConfigError, FaultlabError, InvalidCaseError, ResultsError, ScenarioError
from faultlab.faults import FaultNotApplicableWarning, NotApplicable, not_applicable, slam_units
from faultlab.runner.variants import resolve_variant
from faultlab.runner.backends import check_backend, stream_batches
from faultlab.runner.execution import JobResult
from faultlab.runner.experiment import Experiment, load_experiment
from faultlab.runner.jobs import batch_jobs, expand_jobs
from faultlab.runner.progress import format_duration
from faultlab.runner.progress import progress as show_progress
from faultlab.runner.staging import STOPS_KEY, look_before_stage, record_stops, stage_jobs
from faultlab.runner.store import (ID_COLUMNS, SKIPPED_VARIANTS_KEY, ResultStore, case_path, check_store,
                                   check_store_meta,
                                   job_metrics, load_results, store_lock)
from faultlab.scenario.model import Scenario, load_scenario, save_scenario
from faultlab.scenario.suite import SuiteCase, draw_suite, generate_case
from faultlab.slam.process import ProcessSlam
from faultlab.slam.protocol import SlamAdapter, association_of
from faultlab.space.case import PARAMETER_NAMES, VALUE_KEYS
from faultlab.vocabulary import UNKNOWN_ASSOCIATION, JobStatus

__all__ = ["CaseInfo", "RunSummary", "prepare_cases", "result_row", "run_experiment", "store_session"]


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
        Jobs of the experiment (with ``[adaptive]`` repetitions: those its stages needed).
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



def prepare_cases(experiment: Experiment, out: str | Path, *,
                  drawn: Sequence[SuiteCase] | None = None) -> list[CaseInfo]:
    """Generate and save every test case of ``experiment`` (idempotent).

    Cases come from the one case pipeline (:func:`faultlab.scenario.suite.draw_suite`,
    :func:`~faultlab.scenario.suite.generate_case`), so they are exactly those
    ``faultlab generate`` writes for the same seed, suite and run.  A case already on disk is
    loaded and checked against the experiment (seed and parameter values) instead of being
    regenerated.  ``drawn`` replaces the suites' draws by given cases (a designed experiment,
    :mod:`faultlab.space.design`); they are generated from their own seeds the same way.

    Raises
    ------
    ResultsError
        If a saved case belongs to another experiment.
    """
    if drawn is None:
        space = experiment.parameter_space()
        drawn = [case for run in range(1, experiment.runs + 1) for suite in experiment.suites
                 for case in draw_suite(suite.kind, space, root_seed=experiment.seed, run=run,
                                        n_cases=suite.n_cases)]
    infos: list[CaseInfo] = []
    for case in drawn:
        path = case_path(out, case.run, case.suite, case.case)
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
    except InvalidCaseError:
        raise  # intact files with invalid content: never silently replaced
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


#: Bytes a particle needs at the least: pose (3), weight (1), one landmark's mean (2) and covariance (4), float64.
MIN_BYTES_PER_PARTICLE = 8 * (3 + 1 + 2 + 4)


def _physical_memory() -> int | None:
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):
        return None


def _check_memory(experiment: Experiment) -> None:
    """ConfigError if one execution's particles cannot fit in this machine's memory, even with one landmark."""
    particles = dict(experiment.slam.options).get("particles")
    memory = _physical_memory()
    if isinstance(particles, bool) or not isinstance(particles, int) or memory is None:
        return
    need = particles * MIN_BYTES_PER_PARTICLE
    if need > memory:
        raise ConfigError(f"{experiment.source}: [slam] particles = {particles} needs at least {need / 2 ** 30:.3g} "
                          f"GiB for one execution ({MIN_BYTES_PER_PARTICLE} bytes a particle with a single "
                          f"landmark), more than this machine's {memory / 2 ** 30:.3g} GiB of memory")


def _preflight(experiment: Experiment) -> tuple[SlamAdapter, tuple[NotApplicable, ...]]:
    """Build the SUT and apply every fault once in the parent: configuration errors fail fast.

    A fault that replaces a unit the SUT does not have (:func:`faultlab.faults.not_applicable`:
    e.g. a resampling fault and EKF-SLAM, or any fault and dead reckoning), or a hardware limit whose
    option the SUT does not have (a particle budget and EKF-SLAM), does not apply: its
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
    _check_memory(experiment)
    if isinstance(slam, ProcessSlam):
        slam.check_startable(where=f"{experiment.source}: [slam] command")
    if association_of(slam) == UNKNOWN_ASSOCIATION and experiment.metric != "emd":
        raise ConfigError(f"{experiment.source}: metric = {experiment.metric!r}, but [slam] {experiment.slam.name!r} "
                          f"associates landmarks itself (no ids, no RMS): use metric = \"emd\"")
    units = slam_units(slam)
    skipped: list[NotApplicable] = []
    for i, variant in enumerate(experiment.variants):
        fault = resolve_variant(variant)  # known: parse_experiment checked every name
        if fault is None or callable(getattr(fault, "build_slam", None)):  # a mutant of user source: screened
            continue
        reason = not_applicable(fault, experiment.slam.name, units=units, options=dict(experiment.slam.options))
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



def result_row(case: CaseInfo, res: JobResult) -> dict:
    """The store row of a job's result: its identity, its case's parameters and classes, its outcome."""
    row: dict = dict(zip(ID_COLUMNS, res.key.astuple()))
    for k in VALUE_KEYS:
        v = case.values[k]
        row[k] = str(v) if k == "directionality" else float(v)
    for p in PARAMETER_NAMES:
        row[f"class_{p}"] = int(case.classes.get(p, -1))
    row["n_landmarks"] = case.n_landmarks
    ok = res.status == JobStatus.OK
    row.update(rms_mm=res.rms_mm if ok else math.nan, emd_mm=res.emd_mm if ok else math.nan,
               ate_mm=res.ate_mm if ok else math.nan,
               n_mapped=res.n_mapped if ok else 0, n_unmapped=res.n_unmapped if ok else 0,
               runtime_s=float(res.runtime_s), status=str(res.status.value), error="" if ok else res.error)
    return row


@contextlib.contextmanager
def store_session(store: ResultStore, session: int, *, t0: float) -> Iterator[dict]:
    """End ``session`` when the block ends: ``complete``, or ``interrupted`` if it raised.

    Yields a dict whose ``n_new`` the block keeps up to date.  If ending the session fails while
    the block is already failing (the disk is full: the store cannot take the final update
    either), the block's error is the one raised; the session is then closed as ``killed`` when
    the store is next opened.
    """
    ended = {"n_new": 0}
    try:
        yield ended
    except BaseException:
        with contextlib.suppress(FaultlabError):
            store.end_session(session, state="interrupted", n_new=ended["n_new"],
                              wall_time_s=time.perf_counter() - t0)
        raise
    store.end_session(session, state="complete", n_new=ended["n_new"], wall_time_s=time.perf_counter() - t0)


def run_experiment(experiment: Experiment | str | Path, out: str | Path, *, jobs: int = 2,
                   backend: str = "loky", force_new: bool = False, progress: bool = True,
                   batch_size: int | None = None,
                   on_start: Callable[[], None] | None = None,
                   cases: Sequence[SuiteCase] | None = None,
                   meta: Mapping[str, object] | None = None) -> RunSummary:
    """Run (or resume) a campaign and store one row per job in ``out/results.sqlite``.

    Parameters
    ----------
    experiment : Experiment or path
        The experiment (a path is loaded with :func:`load_experiment`).
    out : path
        Output directory (created).  Rerunning the same call resumes: only jobs
        missing from the store are executed.
    jobs : int
        Worker processes (joblib ``n_jobs``); with 1, the jobs run one after another in one
        worker process, so that the parent can enforce their ``timeout_s``.
    backend : {"loky", "threading"}
        joblib backend.  Only those whose workers the campaign can kill past a job's deadline are
        accepted (:func:`faultlab.runner.backends.check_backend`): loky with any ``jobs``,
        threading with ``jobs = 1``; threads, dask and ray workers are refused.
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
    on_start : callable, optional
        Called once every check passed and the store is open, before the first write to ``out``
        (a driver writing files of its own next to the store writes them there, so that a refused
        run writes nothing).
    cases : sequence of SuiteCase, optional
        Run these cases instead of drawing the experiment's suites (a designed experiment); their
        scenarios are generated from their own seeds and checked on a resume like drawn ones.
    meta : mapping, optional
        Entries recorded in the store's metadata (covered by its checksum) when the store is
        created, before the first job (e.g. a study's declared analyses).  A store that holds a
        different value under one of these keys is refused, writing nothing; a store without the
        key (created before) is refused too, since the entry would be recorded after its rows.

    Returns
    -------
    RunSummary

    Raises
    ------
    ConfigError
        Bad experiment, backend or ``jobs`` (or a backend that cannot enforce ``timeout_s``).
    ResultsError
        ``out`` belongs to another experiment (without ``force_new``) or is in use.
    """
    if not isinstance(experiment, Experiment):
        experiment = load_experiment(experiment)
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise ConfigError(f"jobs must be an integer >= 1, got {jobs!r}")
    check_backend(backend, jobs=jobs)
    if batch_size is not None and (isinstance(batch_size, bool) or not isinstance(batch_size, int)
                                   or batch_size < 1):
        raise ConfigError(f"batch_size must be an integer >= 1 or None, got {batch_size!r}")
    t0 = time.perf_counter()
    out = Path(out)
    sut, skipped = _preflight(experiment)
    check_store(out, experiment, force_new=force_new)  # a refusal writes nothing, not even the lock file
    if meta:
        check_store_meta(out, meta, force_new=force_new)
    with store_lock(out), ResultStore.open(out, experiment, force_new=force_new) as store:
        if on_start is not None:
            on_start()
        for key, value in (meta or {}).items():
            if key not in store.meta:
                store.set_meta(key, value)
        store.set_meta(SKIPPED_VARIANTS_KEY, [dataclasses.asdict(r) | {"reason": str(r)} for r in skipped])
        prepared = prepare_cases(experiment, out, drawn=cases)
        info = {(c.run, c.suite, c.case): c for c in prepared}
        specs = expand_jobs(experiment, ((c.run, c.suite, c.case, c.path, c.cost) for c in prepared),
                            metrics=job_metrics(experiment.metrics, store.meta))
        if skipped:  # variants whose fault does not apply to the SLAM have no jobs
            names = {r.fault for r in skipped}
            specs = [s for s in specs if s.key.variant not in names]
        design = experiment.adaptive
        stages = range(len(design.stages)) if design is not None else [None]
        n_needed, n_new, running = 0, 0, None
        for stage in stages:
            if stage is None:
                todo_specs = specs
            else:
                if stage > 0:
                    decisions, running = look_before_stage(load_results(out), design=design, stage=stage,
                                                           metric=experiment.metric, running=running)
                    store.set_meta(STOPS_KEY, record_stops(decisions, design=design, stage=stage,
                                                           previous=store.meta.get(STOPS_KEY, [])))
                todo_specs = stage_jobs(specs, design=design, stage=stage, running=running)
            n_needed += len(todo_specs)
            n_new += _run_specs(store, todo_specs, info, sut, jobs=jobs, backend=backend, batch_size=batch_size,
                                progress=progress, t0=t0)
        counts = {s.value: 0 for s in JobStatus} | store.status_counts()
        n_stored = sum(counts.values())
        return RunSummary(out=out, results=store.path, n_jobs=n_needed, counts=counts, n_new=n_new,
                          n_skipped=n_stored - n_new, wall_time_s=time.perf_counter() - t0,
                          experiment_hash=experiment.hash)


def _run_specs(store, specs: list, info: dict, sut, *, jobs: int, backend: str, batch_size, progress: bool,
               t0: float) -> int:
    """Run the jobs of ``specs`` missing from ``store`` in one session; the number of rows written."""
    done = store.done_keys()
    todo = [s for s in specs if s.key.astuple() not in done]
    # the missing repetitions of a (case, variant) run as one batched SLAM if the SUT can
    batches = batch_jobs(todo, size=batch_size if getattr(sut, "supports_batch", False) else 1)
    batches.sort(key=lambda b: (-b.cost, b.keys))  # longest first: shorter tail on few workers
    counts = {s.value: 0 for s in JobStatus} | store.status_counts()
    session = store.begin_session(jobs=jobs, backend=backend, n_todo=len(todo))
    n_new = 0
    with store_session(store, session, t0=t0) as ended:
        with show_progress(len(specs), done=len(specs) - len(todo), desc="faultlab run", unit="job",
                           enabled=progress,
                           counts={"crash": counts["crash"], "timeout": counts["timeout"]}) as bar:
            for results in stream_batches(batches, jobs=jobs, backend=backend):
                store.write_many([result_row(info[(r.key.run, r.key.suite, r.key.case)], r) for r in results],
                                 session=session)
                n_new += len(results)
                ended["n_new"] = n_new
                for res in results:
                    counts[res.status.value] = counts.get(res.status.value, 0) + 1
                bar.update(len(results), crash=counts["crash"], timeout=counts["timeout"])
    return n_new
