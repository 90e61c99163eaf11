"""Calibration of the detection rules from an A/A store: how often each flags the unmodified SLAM.

The store of :func:`faultlab.campaigns.calibrate.calibrate` holds the variants ``baseline`` and
``baseline_replica`` (the unmodified SLAM twice, independent SLAM seeds).  Every "detection" of
the replica is a false alarm, so the :class:`~faultlab.analysis.Analysis` table
``replica_false_alarms`` is the empirical false-alarm rate of each rule per suite, with an
interval clustered by case.  The statistical rule's per-case (unadjusted) and family-wise rates
with exact Clopper-Pearson intervals, and the check that can fail -- miscalibrated when the
per-case rate's lower bound exceeds ``alpha``, underpowered when its upper bound does not exclude
``2 alpha`` -- are :mod:`faultlab.stats.calibration`.  :func:`check_saved` repeats the check on a
saved analysis (its ``jobs.csv`` and ``analysis.json``) without the store.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from faultlab.stats.metadata import read_rule
from faultlab.analysis.result import Analysis, analyse
from faultlab.errors import ResultsError
from faultlab.metrics.detection import DetectionRule
from faultlab.stats.calibration import CalibrationCheck, CalibrationStatus, check_calibration, false_alarm_rates
from faultlab.stats.cases import rule_verdicts
from faultlab.stats.detection import outcomes
from faultlab.vocabulary import BASELINE, REPLICA

__all__ = ["Calibration", "assess_calibration", "check_saved", "replica_calibration", "format_calibration",
           "EXIT_CODES"]

#: Exit status of ``faultlab calibrate`` per check outcome.
EXIT_CODES = {CalibrationStatus.CALIBRATED: 0, CalibrationStatus.UNDERPOWERED: 4,
              CalibrationStatus.MISCALIBRATED: 3, CalibrationStatus.NOTHING_JUDGED: 3}


@dataclass(frozen=True)
class Calibration:
    """The false-alarm rates of an A/A store and the statistical rule's check.

    Attributes
    ----------
    analysis : Analysis
        The store's analysis (its ``replica_false_alarms`` table: both rules, clustered intervals).
    repetitions : int
        K of the A/A campaign.
    rates : DataFrame
        :func:`faultlab.stats.calibration.false_alarm_rates` of the statistical rule.
    check : CalibrationCheck
        :func:`faultlab.stats.calibration.check_calibration`.
    """

    analysis: Analysis
    repetitions: int
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
        lines = [f"A/A false alarms ({REPLICA} vs {BASELINE}, K = {self.repetitions}; "
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
    rates, check = replica_calibration(jobs, rule, metric=_campaign_metric(meta.get("metadata", {})))
    return rates, check, rule


def assess_calibration(out: str | Path) -> Calibration:
    """The :class:`Calibration` of the A/A store in ``out`` (runs nothing)."""
    result = analyse(out, paper=False)
    rates, check = replica_calibration(result.this_run_jobs, result.rule, metric=_campaign_metric(result.metadata))
    return Calibration(analysis=result, repetitions=result.n_reps, rates=rates, check=check)


def _campaign_metric(metadata) -> str:
    """The campaign's primary metric as stored (``rms`` when none is)."""
    metadata = metadata or {}
    return str(metadata.get("metric") or (metadata.get("experiment") or {}).get("metric") or "rms")
