"""Jobs of a campaign: one per (run, suite, case, variant, rep), each with its SLAM seed.

Seeds follow the scheme of :mod:`faultlab.seeds`: repetition ``rep`` of a case uses the same SLAM
seed for every variant (common random numbers), except the A/A control ``baseline_replica``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterable

from faultlab.runner.experiment import Experiment, SlamSpec
from faultlab.seeds import slam_seed
from faultlab.vocabulary import REPLICA

__all__ = ["JobKey", "JobSpec", "expand_jobs"]


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
    """

    key: JobKey
    case_path: str
    slam: SlamSpec
    seed: int
    timeout_s: float
    cost: float = 0.0


def expand_jobs(experiment: Experiment, cases: Iterable[tuple[int, str, int, str, float]]) -> list[JobSpec]:
    """All jobs of ``experiment`` in canonical order.

    Parameters
    ----------
    experiment : Experiment
    cases : iterable of (run, suite, case, path, cost)
        The prepared test cases; every variant and repetition of each case becomes a job.
    """
    jobs = []
    for run, suite, case, path, cost in cases:
        for variant in experiment.variants:
            for rep in range(experiment.repetitions):
                jobs.append(JobSpec(key=JobKey(run, suite, case, variant, rep), case_path=str(path),
                                    slam=experiment.slam,
                                    seed=slam_seed(experiment.seed, run, suite, case, rep,
                                                   replica=variant == REPLICA),
                                    timeout_s=experiment.timeout_s, cost=float(cost)))
    return jobs
