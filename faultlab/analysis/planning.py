"""The measured cost of one SLAM execution, read from a committed store (for :mod:`faultlab.inference.planning`),
and the runs a confirmatory study needs, planned from a pilot study's saved kill matrix."""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
from statsmodels.stats.power import TTestPower

from faultlab.errors import ConfigError, ResultsError
from faultlab.inference.clusters import cluster_differences, clusters_for_difference, equivalence_power
from faultlab.mutation.variants import is_mutant_variant
from faultlab.runner.store import load_metadata, load_results
from faultlab.stats.killmatrix import KillMatrix, case_scores
from faultlab.vocabulary import BASELINE, JobStatus

__all__ = ["ExecutionCost", "execution_cost", "ConfirmationPlan", "confirmation_plan"]


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


@dataclass(frozen=True)
class ConfirmationPlan:
    """The number of evaluation runs a confirmatory study's declared run-level analyses need, from a pilot.

    Attributes
    ----------
    pilot : str
        The pilot study's saved analysis (``kill_matrix.csv`` and ``study_meta.json``).
    strategy_a, strategy_b : str
        The declared pair (``detection_means``, the mean single-case detection over the faults).
    pilot_runs : int
        Runs of the pilot holding both strategies.
    effect, sd : float
        The pilot's mean and standard deviation of the runs' differences (a - b): the planned effect
        and spread.
    alpha, level : float
        The declared level, and Holm's first step over the declared analyses (``alpha / analyses``)
        at which the plan is made.
    power : float
        The power asked for.
    runs_needed : int
        Runs at which the t test over the runs' differences detects ``effect`` with ``power`` at ``level``
        (:func:`faultlab.inference.clusters.clusters_for_difference`).
    runs : int
        Runs of the study file.
    power_at_runs : float
        The difference test's power at ``runs`` (statsmodels ``TTestPower``).
    margin : float or None
        The declared equivalence margin, if any.
    equivalence_power_at_runs : float
        Power of the two one-sided tests at ``level`` to show the margin at ``runs`` when the true
        difference is ``effect`` (:func:`faultlab.inference.clusters.equivalence_power`).
    executions_per_run : int
        SLAM executions of one run (both pools, every variant, K repetitions).
    """

    pilot: str
    strategy_a: str
    strategy_b: str
    pilot_runs: int
    effect: float
    sd: float
    alpha: float
    level: float
    power: float
    runs_needed: int
    runs: int
    power_at_runs: float
    margin: float | None
    equivalence_power_at_runs: float
    executions_per_run: int


def confirmation_plan(sexp, pilot: str | Path, *, power: float) -> ConfirmationPlan:
    """Plan a study's declared run-level ``detection_means`` analyses from a pilot study's saved kill matrix.

    ``sexp`` is a :class:`faultlab.campaigns.study.StudyExperiment` with a declaration whose unit is
    the run and which declares a ``detection_means`` difference test of one pair.

    Raises
    ------
    ConfigError
        No such declaration; the pilot lacks the pair or holds fewer than two runs of it.
    ResultsError
        The pilot is not a saved study analysis.
    """
    d = sexp.declaration
    diff = [a for a in (d.analyses if d is not None else ()) if a.table == "detection_means"
            and a.test == "difference" and "*" not in (a.strategy_a, a.strategy_b)]
    if d is None or d.unit != "run" or not diff:
        raise ConfigError("study plan --pilot: the study declares no run-level detection_means difference test of "
                          "one pair ([declaration] unit = \"run\", table = \"detection_means\")")
    x = diff[0]
    equivalence = [a for a in d.analyses if a.table == "detection_means" and a.test == "equivalence"
                   and {a.strategy_a, a.strategy_b} == {x.strategy_a, x.strategy_b}]
    try:
        km = KillMatrix.from_frame(pd.read_csv(Path(pilot) / "kill_matrix.csv", keep_default_na=False,
                                               na_values=[""]))
    except (OSError, ValueError) as exc:
        raise ResultsError(f"{pilot}: not a saved study analysis ({exc})") from exc
    faults = [v for v in km.variants if v != BASELINE and not is_mutant_variant(v)]
    keep = km.cases["strategy"].isin([x.strategy_a, x.strategy_b]).to_numpy()
    if not {x.strategy_a, x.strategy_b} <= set(km.strategies):
        raise ConfigError(f"study plan --pilot: {pilot} has no pool of {x.strategy_a} and {x.strategy_b}")
    score = case_scores(km, faults, alpha=d.alpha)
    _, runs_d = cluster_differences(score[keep], arm=km.cases["strategy"].to_numpy()[keep] == x.strategy_a,
                                    cluster=km.cases["run"].to_numpy()[keep])
    if runs_d.size < 2:
        raise ConfigError(f"study plan --pilot: {pilot} holds {runs_d.size} run(s) of the pair; a spread needs two")
    effect, sd = float(runs_d.mean()), float(runs_d.std(ddof=1))
    level = d.alpha / len(d.analyses) if d.family == "holm" else d.alpha
    alt = {"two-sided": "two-sided", "greater": "larger", "less": "smaller"}[d.sidedness]
    exp = sexp.experiment
    runs = int(exp.runs)
    margin = equivalence[0].margin if equivalence else None
    per_run = sum(s.n_cases or 0 for s in exp.suites) * len(exp.variants) * int(exp.repetitions)
    return ConfirmationPlan(
        pilot=str(pilot), strategy_a=x.strategy_a, strategy_b=x.strategy_b, pilot_runs=int(runs_d.size),
        effect=effect, sd=sd, alpha=d.alpha, level=level, power=power,
        runs_needed=clusters_for_difference(effect, sd=sd, alpha=level, power=power, alternative=d.sidedness),
        runs=runs, power_at_runs=float(TTestPower().power(effect / sd, runs, level, alternative=alt)),
        margin=margin,
        equivalence_power_at_runs=math.nan if margin is None else equivalence_power(runs, margin=margin,
                                                                                     difference=effect, sd=sd,
                                                                                     alpha=level),
        executions_per_run=per_run)
