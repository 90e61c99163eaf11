"""The measured cost of one SLAM execution, read from a committed store (for :mod:`faultlab.inference.planning`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from faultlab.errors import ResultsError
from faultlab.runner.store import load_metadata, load_results
from faultlab.vocabulary import JobStatus

__all__ = ["ExecutionCost", "execution_cost"]


@dataclass(frozen=True)
class ExecutionCost:
    """Mean CPU seconds of one SLAM execution in a store, and the settings they were measured at.

    Attributes
    ----------
    seconds : float
        Mean ``runtime_s`` of the jobs that ran normally (one repetition of one case and variant).
    jobs : int
        Jobs averaged.
    slam, particles, n_steps :
        The store's SLAM, particle count and active steps.
    wall_time_s : float
        The store's wall time; ``load`` is not recorded in every store, so the figure is noisy on
        a shared machine.
    """

    seconds: float
    jobs: int
    slam: str
    particles: int | None
    n_steps: int
    wall_time_s: float


def execution_cost(store: str | Path) -> ExecutionCost:
    """The mean cost of one execution in ``store`` (a results directory with ``results.sqlite``)."""
    results = load_results(store)
    meta = load_metadata(store)
    ok = results[results["status"].astype(str) == JobStatus.OK.value]
    if ok.empty:
        raise ResultsError(f"{store}: no job ran normally, no cost to measure")
    exp = meta["experiment"]
    slam = exp.get("slam", {})
    return ExecutionCost(seconds=float(ok["runtime_s"].mean()), jobs=int(len(ok)), slam=str(slam.get("name", "?")),
                         particles=slam.get("particles"), n_steps=int(exp["n_steps"]),
                         wall_time_s=float(meta.get("wall_time_s") or 0.0))
