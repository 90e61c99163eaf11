"""Jobs of a campaign: one per (run, suite, case, variant, rep), each with its SLAM seed.

Seeds follow the scheme of :mod:`faultlab.seeds`: repetition ``rep`` of a case uses the same SLAM
seed for every variant (common random numbers), except the A/A control ``baseline_replica``.

When the SLAM under test runs repetitions in a batch (``supports_batch``, e.g. the reference
FastSLAM), the repetitions of one (case, variant) still to be run are grouped into one
:class:`JobBatch` (:func:`batch_jobs`), executed by one worker in one batched SLAM; every
repetition keeps its own job identity, seed and result row.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable, Sequence

from faultlab.errors import ConfigError
from faultlab.runner.experiment import Experiment, SlamSpec
from faultlab.seeds import slam_seed
from faultlab.vocabulary import METRICS, REPLICA

__all__ = ["JobKey", "JobSpec", "JobBatch", "expand_jobs", "batch_jobs"]


@dataclass(frozen=True, order=True)
class JobKey:
    """Identity of one job: run (1-based), suite, case (1-based), variant, rep (0-based)."""

    run: int
    suite: str
    case: int
    variant: str
    rep: int

    def astuple(self) -> tuple[int, str, int, str, int]:
        return (self.run, self.suite, self.case, self.variant, self.rep)

    def __str__(self) -> str:
        return f"run {self.run} {self.suite} case {self.case} {self.variant} rep {self.rep}"


@dataclass(frozen=True)
class JobSpec:
    """Everything a worker needs for one job: small and picklable (the case is loaded from ``case_path``).

    Attributes
    ----------
    key : JobKey
    case_path : str
        A saved scenario (see :func:`faultlab.scenario.model.save_scenario`).
    slam : SlamSpec
    seed : int
        The SLAM's seed (:func:`slam_seed`).
    timeout_s : float
        Wall-clock limit of the SLAM execution, s.
    cost : float
        Rough relative cost estimate, used only to dispatch long jobs first.
    metrics : tuple of str
        The map errors to compute (the experiment's ``metrics``); the others are stored as NaN.
    """

    key: JobKey
    case_path: str
    slam: SlamSpec
    seed: int
    timeout_s: float
    cost: float = 0.0
    metrics: tuple[str, ...] = METRICS


def expand_jobs(experiment: Experiment, cases: Iterable[tuple[int, str, int, str, float]], *,
                metrics: tuple[str, ...] | None = None) -> list[JobSpec]:
    """All jobs of ``experiment`` in canonical order.

    Parameters
    ----------
    experiment : Experiment
    cases : iterable of (run, suite, case, path, cost)
        The prepared test cases; every variant and repetition of each case becomes a job.
    metrics : tuple of str, optional
        The metrics the jobs record (default: the experiment's); a resumed store's
        (:func:`faultlab.runner.store.job_metrics`).
    """
    jobs = []
    for run, suite, case, path, cost in cases:
        for variant in experiment.variants:
            for rep in range(experiment.repetitions):
                jobs.append(JobSpec(key=JobKey(run, suite, case, variant, rep), case_path=str(path),
                                    slam=experiment.slam,
                                    seed=slam_seed(experiment.seed, run, suite, case, rep,
                                                   replica=variant == REPLICA),
                                    timeout_s=experiment.timeout_s, cost=float(cost),
                                    metrics=experiment.metrics if metrics is None else tuple(metrics)))
    return jobs


@dataclass(frozen=True)
class JobBatch:
    """Jobs executed together by one worker: repetitions of one (run, suite, case, variant).

    A batch of one job is an ordinary job.  Several jobs run as one batched SLAM
    (:func:`faultlab.slam.protocol.run_slam_batch`), each with its own seed; their results are
    recorded as separate rows, exactly as if each had run alone.

    Attributes
    ----------
    jobs : tuple of JobSpec
        Same case, variant and SLAM; distinct repetitions.
    """

    jobs: tuple[JobSpec, ...]

    def __post_init__(self) -> None:
        if not self.jobs:
            raise ConfigError("a JobBatch needs at least one job")
        first = self.jobs[0].key
        for spec in self.jobs[1:]:
            k = spec.key
            if (k.run, k.suite, k.case, k.variant) != (first.run, first.suite, first.case, first.variant):
                raise ConfigError(f"a JobBatch holds repetitions of one case and variant, got {first} and {k}")

    def __len__(self) -> int:
        return len(self.jobs)

    @property
    def keys(self) -> tuple[JobKey, ...]:
        return tuple(s.key for s in self.jobs)

    @property
    def cost(self) -> float:
        """Sum of the jobs' cost estimates (used only to dispatch long batches first)."""
        return float(sum(s.cost for s in self.jobs))

    @property
    def timeout_s(self) -> float:
        """Wall-clock limit of the batch: each job's limit times the number of jobs."""
        return float(sum(s.timeout_s for s in self.jobs))

    def __str__(self) -> str:
        k = self.jobs[0].key
        reps = ",".join(str(s.key.rep) for s in self.jobs)
        return f"run {k.run} {k.suite} case {k.case} {k.variant} reps {reps}"


def batch_jobs(specs: Sequence[JobSpec], *, size: int | None = None) -> list[JobBatch]:
    """Group jobs into batches of repetitions of one (run, suite, case, variant).

    Parameters
    ----------
    specs : sequence of JobSpec
        The jobs to run (e.g. those missing from the store); their order is kept within a batch.
    size : int, optional
        At most this many jobs per batch (None: all repetitions of a case and variant together;
        1: one job per batch, i.e. no batching).

    Returns
    -------
    list of JobBatch
        In order of the first job of each group.
    """
    if size is not None and (isinstance(size, bool) or not isinstance(size, int) or size < 1):
        raise ConfigError(f"batch size must be an integer >= 1 or None, got {size!r}")
    groups: dict[tuple, list[JobSpec]] = {}
    for spec in specs:
        k = spec.key
        groups.setdefault((k.run, k.suite, k.case, k.variant), []).append(spec)
    batches = []
    for group in groups.values():
        step = len(group) if size is None else size
        batches += [JobBatch(tuple(group[i:i + step])) for i in range(0, len(group), step)]
    return batches
