"""Calibrate the detection rules on an A/A campaign: how often each flags the unmodified SLAM.

:func:`calibrate` runs the paper's protocol (the shipped experiment ``paper``) with the variants
``baseline`` and ``baseline_replica`` -- the unmodified SLAM twice, with independent SLAM seeds --
and K repetitions per case, through :func:`faultlab.runner.run_experiment` (resumable: rerunning
the same call runs only missing jobs).  Every "detection" of the replica is a false alarm, so
the :class:`~faultlab.analysis.Analysis` table ``replica_false_alarms`` is the empirical
false-alarm rate of each rule per suite, with an interval clustered by case.  The statistical
rule is calibrated when its rate is at most ``alpha``, i.e. the interval's lower bound lies
below ``alpha`` (the data do not show a rate above ``alpha``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import json

import pandas as pd

from faultlab.analysis import Analysis, analyse, read_rule
from faultlab.errors import ResultsError
from faultlab.metrics.detection import DetectionRule
from faultlab.report.reproduce import DEFAULT_EXPERIMENT, quick_overrides
from faultlab.stats.calibration import (CalibrationCheck, CalibrationStatus, check_calibration,
                                        false_alarm_rates)
from faultlab.stats.cases import rule_verdicts
from faultlab.stats.detection import outcomes
from faultlab.vocabulary import BASELINE, REPLICA

__all__ = ["CalibrationResult", "calibrate", "check_saved", "replica_calibration", "format_calibration",
           "CALIBRATION_REPS", "QUICK_CALIBRATION_REPS", "default_calibration_out", "EXIT_CODES"]

#: Exit status of ``faultlab calibrate`` per check outcome.
EXIT_CODES = {CalibrationStatus.CALIBRATED: 0, CalibrationStatus.UNDERPOWERED: 4,
              CalibrationStatus.MISCALIBRATED: 3, CalibrationStatus.NOTHING_JUDGED: 3}

#: Repetitions per case of the A/A campaign (K).
CALIBRATION_REPS = 10
#: ``--quick``: repetitions per case.
QUICK_CALIBRATION_REPS = 6


@dataclass(frozen=True)
class CalibrationResult:
    """What :func:`calibrate` did.

    Attributes
    ----------
    experiment : faultlab.runner.Experiment
        The A/A experiment as run.
    summary : faultlab.runner.RunSummary
    analysis : Analysis
        The campaign's analysis (its ``replica_false_alarms`` table is the calibration).
    out : Path
        The results directory.
    rates : DataFrame
        :func:`faultlab.stats.calibration.false_alarm_rates` of the statistical rule.
    check : CalibrationCheck
        :func:`faultlab.stats.calibration.check_calibration`.
    """

    experiment: object
    summary: object
    analysis: Analysis
    out: Path
    rates: pd.DataFrame
    check: CalibrationCheck

    @property
    def calibrated(self) -> bool:
        """Whether the check passed (the per-case rate is compatible with alpha and excludes 2 alpha)."""
        return self.check.status == CalibrationStatus.CALIBRATED

    @property
    def table(self) -> pd.DataFrame:
        """Per rule and suite: the empirical false-alarm rate with its clustered interval."""
        return self.analysis.replica_false_alarms

    def __str__(self) -> str:
        alpha = self.analysis.rule.alpha
        conf = round(100 * (1 - self.analysis.alpha))
        lines = [f"results: {self.out} ({self.summary})",
                 f"A/A false alarms ({REPLICA} vs {BASELINE}, K = {self.experiment.repetitions}; "
                 f"{conf} % interval clustered by case):"]
        for r in self.table.itertuples(index=False):
            if r.rule != "paper":
                continue
            rate = "n/a" if math.isnan(r.rate) else f"{100 * r.rate:.1f} % [{100 * r.low:.1f}, {100 * r.high:.1f}]"
            lines.append(f"  paper rule  {r.suite:<10} {r.flagged:>4}/{r.n_pairs:<5} repetition pairs {rate}")
        lines.append(format_calibration(self.rates, self.check, alpha=alpha))
        return "\n".join(lines)


def format_calibration(rates: pd.DataFrame, check: CalibrationCheck, *, alpha: float) -> str:
    """The statistical rule's A/A rates (cases, exact intervals) and the check's verdict, as text."""
    lines = [f"statistical rule, cases flagged (Clopper-Pearson 95 %): per case = unadjusted p <= {alpha:g}; "
             "family-wise = after Holm within the rule's family"]
    for r in rates.itertuples(index=False):
        rate = "n/a" if math.isnan(r.rate) else f"{100 * r.rate:.1f} % [{100 * r.cp_low:.1f}, {100 * r.cp_high:.1f}]"
        lines.append(f"  {r.scope:<11} {r.suite:<10} {r.k:>4}/{r.n:<5} cases {rate}")
    lines.append(check.reason)
    return "\n".join(lines)


def replica_calibration(jobs: pd.DataFrame, rule: DetectionRule, *, metric: str = "rms"):
    """``(rates, check)`` of the statistical rule (with ``rule``'s alpha, family and direction) on the
    A/A jobs (``baseline`` and ``baseline_replica`` rows of a results or ``jobs`` table)."""
    stat = DetectionRule(abs_mm=rule.abs_mm, rel=rule.rel, rule="statistical", alpha=rule.alpha, family=rule.family,
                         direction=rule.direction)
    aa = jobs[jobs["variant"].isin([BASELINE, REPLICA])]
    if not (aa["variant"] == REPLICA).any():
        raise ResultsError(f"calibration: no {REPLICA} jobs: not an A/A campaign")
    v = rule_verdicts(aa, outcomes(aa, rule=stat), rule=stat, metric=metric)
    rates = false_alarm_rates(v[v["fault"] == REPLICA], alpha=rule.alpha)
    return rates, check_calibration(rates, alpha=rule.alpha)


def check_saved(directory: str | Path) -> tuple[pd.DataFrame, CalibrationCheck, DetectionRule]:
    """The calibration check of a saved A/A analysis (``jobs.csv`` and ``analysis.json``), running nothing."""
    d = Path(directory)
    try:
        jobs = pd.read_csv(d / "jobs.csv")
        meta = json.loads((d / "analysis.json").read_text())
    except (OSError, ValueError) as exc:
        raise ResultsError(f"{d}: not a saved analysis of an A/A campaign ({exc})") from exc
    if "source" in jobs.columns:
        jobs = jobs[jobs["source"] == "this run"]
    rule, _ = read_rule(meta.get("metadata", {}))
    metric = str(meta.get("metadata", {}).get("metric", "rms"))
    rates, check = replica_calibration(jobs, rule, metric=metric)
    return rates, check, rule


def default_calibration_out(*, quick: bool = False) -> Path:
    """``results/calibrate`` (``-quick`` appended for the smoke version)."""
    return Path("results") / ("calibrate" + ("-quick" if quick else ""))


def calibrate(*, experiment_path: str | Path = DEFAULT_EXPERIMENT, out: str | Path | None = None,
              reports: str | Path | None = None, quick: bool = False, repetitions: int | None = None,
              jobs: int = 2, backend: str = "loky", force_new: bool = False, progress: bool = True,
              overrides: dict | None = None) -> CalibrationResult:
    """Run (or resume) the A/A campaign and measure each rule's false-alarm rate.

    Parameters
    ----------
    experiment_path : path or shipped name
        The protocol (default the paper's); its variants are replaced by baseline and replica
        and its detection rule by the statistical one (same alpha and family).
    out : path, optional
        Results directory (default :func:`default_calibration_out`).
    reports : path, optional
        Where to save the Analysis' tables (CSV + JSON); nothing is written when None.
    quick : bool
        1 run, small suites, :data:`QUICK_CALIBRATION_REPS` repetitions, short traces, few
        particles (:func:`faultlab.report.reproduce.quick_overrides`).
    repetitions : int, optional
        K (default :data:`CALIBRATION_REPS`, or the quick one).
    jobs, backend, force_new, progress
        Passed to :func:`faultlab.runner.run_experiment`.
    overrides : dict, optional
        Further experiment overrides applied last (e.g. a smaller test configuration).

    Returns
    -------
    CalibrationResult
    """
    from faultlab.runner import load_experiment, run_experiment

    experiment = load_experiment(experiment_path)
    changes = quick_overrides(experiment) if quick else {}
    k = repetitions if repetitions is not None else (QUICK_CALIBRATION_REPS if quick else CALIBRATION_REPS)
    changes.update(variants=[BASELINE, REPLICA], repetitions=k, detection={"rule": "statistical"})
    changes.update(overrides or {})
    experiment = experiment.replace(**changes)
    out = Path(out) if out is not None else default_calibration_out(quick=quick)
    summary = run_experiment(experiment, out, jobs=jobs, backend=backend, force_new=force_new, progress=progress)
    result = analyse(out, paper=False)
    if reports is not None:
        result.save(reports)
    rates, check = replica_calibration(result.this_run_jobs, result.rule, metric=experiment.metric)
    if reports is not None:
        rates.to_csv(Path(reports) / "calibration.csv", index=False)
    return CalibrationResult(experiment=experiment, summary=summary, analysis=result, out=out, rates=rates,
                             check=check)
