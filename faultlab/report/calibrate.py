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

import pandas as pd

from faultlab.analysis import Analysis, analyse
from faultlab.report.reproduce import DEFAULT_EXPERIMENT, quick_overrides
from faultlab.vocabulary import BASELINE, REPLICA

__all__ = ["CalibrationResult", "calibrate", "CALIBRATION_REPS", "QUICK_CALIBRATION_REPS", "default_calibration_out"]

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
    calibrated : bool
        Whether the statistical rule's false-alarm rate is at most alpha in every suite (its
        interval's lower bound below alpha); False when nothing could be judged.
    """

    experiment: object
    summary: object
    analysis: Analysis
    out: Path
    calibrated: bool

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
            unit = "repetition pairs" if r.rule == "paper" else "cases"
            rate = "n/a" if math.isnan(r.rate) else f"{100 * r.rate:.1f} % [{100 * r.low:.1f}, {100 * r.high:.1f}]"
            lines.append(f"  {r.rule:<11} {r.suite:<10} {r.flagged:>4}/{r.n_pairs:<5} {unit:<16} {rate}")
        verdict = "holds" if self.calibrated else "does NOT hold"
        lines.append(f"statistical rule: false-alarm rate <= alpha = {alpha:g} {verdict} "
                     f"(lower bound of every suite's interval below alpha)")
        return "\n".join(lines)


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
    stat = result.replica_false_alarms
    stat = stat[(stat["rule"] == "statistical") & (stat["n_pairs"] > 0)]
    calibrated = bool(len(stat)) and bool((stat["low"] < result.rule.alpha).all())
    return CalibrationResult(experiment=experiment, summary=summary, analysis=result, out=out, calibrated=calibrated)
