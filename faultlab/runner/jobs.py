"""Jobs of a campaign and the seeds that make them reproducible.

An experiment expands into one job per (run, suite, case, variant, rep).
Every random draw derives from ``numpy.random.SeedSequence(entropy=root,
spawn_key=...)`` keyed by the *identity* of what is drawn, never by the order
in which jobs are executed, so results do not depend on ``--jobs``, the
scheduling or a resume:

- the suite of (run, suite) is built from ``spawn_key=(SUITE, run, code(suite))``;
- case c of that suite is generated from ``spawn_key=(CASE, run, code(suite), c)``;
- repetition k of a case runs the SLAM with ``spawn_key=(SLAM, run, code(suite), c, k)``,
  the same for every variant (common random numbers: a difference between a
  faulty variant and the baseline comes from the fault, not from the SLAM's
  own noise).

``code(name)`` is a stable 32-bit hash (sha256) of the suite name, so adding,
removing or reordering suites changes no other suite's draws.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass
from typing import Iterable

import numpy as np

from faultlab.runner.experiment import Experiment, SlamSpec

__all__ = ["JobKey", "JobSpec", "stable_code", "suite_seed_sequence", "case_seed", "slam_seed", "expand_jobs"]

# Spawn-key tags: what a seed is for.
_SUITE, _CASE, _SLAM = 1, 2, 3


def stable_code(name: str) -> int:
    """A stable 32-bit code of ``name`` (first 4 bytes of its sha256; never Python's ``hash``)."""
    return int.from_bytes(hashlib.sha256(name.encode("utf-8")).digest()[:4], "big")


def suite_seed_sequence(root: int, run: int, suite: str) -> np.random.SeedSequence:
    """The SeedSequence the suite builder of (run, suite) draws from."""
    return np.random.SeedSequence(entropy=int(root), spawn_key=(_SUITE, int(run), stable_code(suite)))


def _seed(root: int, *key: int) -> int:
    ss = np.random.SeedSequence(entropy=int(root), spawn_key=tuple(int(k) for k in key))
    return int(ss.generate_state(1, np.uint64)[0] >> np.uint64(1))  # 63 bits: fits int64 / SQLite


def case_seed(root: int, run: int, suite: str, case: int) -> int:
    """Seed (63-bit int) of case ``case`` (1-based) of (run, suite); ``default_rng(seed)`` generates it."""
    return _seed(root, _CASE, run, stable_code(suite), case)


def slam_seed(root: int, run: int, suite: str, case: int, rep: int) -> int:
    """Seed (63-bit int) of the SLAM's own randomness in repetition ``rep`` of a case.

    Independent of the variant: common random numbers across variants.
    """
    return _seed(root, _SLAM, run, stable_code(suite), case, rep)


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
                                    seed=slam_seed(experiment.seed, run, suite, case, rep),
                                    timeout_s=experiment.timeout_s, cost=float(cost)))
    return jobs
