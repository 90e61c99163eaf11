"""The A/A campaign that calibrates the detection rules: the unmodified SLAM against itself.

:func:`calibrate` runs the paper's protocol (the shipped experiment ``paper``) with the variants
``baseline`` and ``baseline_replica`` -- the unmodified SLAM twice, with independent SLAM seeds --
and K repetitions per case, through :func:`faultlab.runner.run_experiment` (resumable: rerunning
the same call runs only missing jobs).  Every "detection" of the replica is a false alarm:
:func:`faultlab.analysis.calibration.assess_calibration` turns the store into each rule's
empirical false-alarm rate.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from faultlab.config import ExperimentOverrides
from faultlab.campaigns.reproduce import DEFAULT_EXPERIMENT, quick_overrides
from faultlab.runner import Experiment, RunSummary, load_experiment, run_experiment
from faultlab.vocabulary import BASELINE, REPLICA

__all__ = ["CalibrationRun", "calibrate", "CALIBRATION_REPS", "QUICK_CALIBRATION_REPS", "default_calibration_out"]

#: Repetitions per case of the A/A campaign (K).
CALIBRATION_REPS = 10
#: ``--quick``: repetitions per case.
QUICK_CALIBRATION_REPS = 6


@dataclass(frozen=True)
class CalibrationRun:
    """What :func:`calibrate` ran: the A/A experiment, the runner's summary and the results directory."""

    experiment: Experiment
    summary: RunSummary
    out: Path

    def __str__(self) -> str:
        return f"results: {self.out} ({self.summary})"


def default_calibration_out(*, quick: bool = False) -> Path:
    """``results/calibrate`` (``-quick`` appended for the smoke version)."""
    return Path("results") / ("calibrate" + ("-quick" if quick else ""))


def calibrate(*, experiment_path: str | Path = DEFAULT_EXPERIMENT, out: str | Path | None = None,
              quick: bool = False, repetitions: int | None = None, jobs: int = 2, backend: str = "loky",
              force_new: bool = False, progress: bool = True, overrides: ExperimentOverrides | None = None) -> CalibrationRun:
    """Run (or resume) the A/A campaign.

    Parameters
    ----------
    experiment_path : path or shipped name
        The protocol (default the paper's); its variants are replaced by baseline and replica
        and its detection rule by the statistical one (same alpha and family).
    out : path, optional
        Results directory (default :func:`default_calibration_out`).
    quick : bool
        1 run, small suites, :data:`QUICK_CALIBRATION_REPS` repetitions, short traces, few
        particles (:func:`faultlab.campaigns.reproduce.quick_overrides`).
    repetitions : int, optional
        K (default :data:`CALIBRATION_REPS`, or the quick one).
    jobs, backend, force_new, progress
        Passed to :func:`faultlab.runner.run_experiment`.
    overrides : ExperimentOverrides, optional
        Further changes applied last (e.g. a smaller test configuration).

    Returns
    -------
    CalibrationRun
    """
    experiment = load_experiment(experiment_path)
    k = repetitions if repetitions is not None else (QUICK_CALIBRATION_REPS if quick else CALIBRATION_REPS)
    changes = (quick_overrides(experiment) if quick else ExperimentOverrides()).then(
        ExperimentOverrides(variants=(BASELINE, REPLICA), repetitions=k, rule="statistical"))
    experiment = experiment.apply(changes.then(overrides or ExperimentOverrides()))
    out = Path(out) if out is not None else default_calibration_out(quick=quick)
    summary = run_experiment(experiment, out, jobs=jobs, backend=backend, force_new=force_new, progress=progress)
    return CalibrationRun(experiment=experiment, summary=summary, out=out)
