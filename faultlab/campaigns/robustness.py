"""The robustness campaign: every sensor and hardware fault on FastSLAM 1.0, 2.0, EKF-SLAM and GTSAM.

The protocol is the shipped experiment ``robustness`` (its variants: the baseline and every built-in
sensor fault, :mod:`faultlab.faults.sensorfaults`); it runs once per SLAM of :data:`LABELS`, whose
``[slam]`` tables are those of the cross-SLAM campaign (:data:`faultlab.campaigns.slams.SUTS`), one
store per SLAM in ``out/<label>``.  A hardware limit a SLAM does not have an option for (the
particle budget on EKF-SLAM and GTSAM) is skipped and recorded as not applicable.  The analysis is
:func:`faultlab.analysis.robustness.robustness`, the rendering
:func:`faultlab.report.robustness.write_robustness_report`.
"""

from __future__ import annotations

from pathlib import Path

from faultlab.campaigns.slams import SlamsRun, slam_experiments
from faultlab.config import ExperimentOverrides
from faultlab.errors import ConfigError
from faultlab.runner import results_path, run_experiment

__all__ = ["DEFAULT_EXPERIMENT", "LABELS", "RobustnessRun", "scale_overrides", "robustness_stores",
           "run_robustness"]

#: The shipped protocol.
DEFAULT_EXPERIMENT = "robustness"
#: The SLAMs under test (labels of :data:`faultlab.campaigns.slams.SUTS`).
LABELS: tuple[str, ...] = ("fastslam1", "fastslam2", "ekf", "gtsam")


def scale_overrides(*, cases: int | None = None, steps: int | None = None,
                    repetitions: int | None = None) -> ExperimentOverrides:
    """The scale: one random suite of ``cases`` cases, active steps, repetitions K (None: the file's)."""
    return ExperimentOverrides(suites=None if cases is None else (("random", cases),), n_steps=steps,
                               repetitions=repetitions)


def robustness_stores(out: str | Path) -> dict[str, Path]:
    """label -> store directory of every SLAM of :data:`LABELS` with a store in ``out``."""
    out = Path(out)
    return {label: out / label for label in LABELS if results_path(out / label).is_file()}


#: What :func:`run_robustness` ran: the cross-SLAM campaign's record (per SLAM its summary, the SLAMs
#: left out because not installed).
RobustnessRun = SlamsRun


def run_robustness(out: str | Path, *, experiment=DEFAULT_EXPERIMENT, overrides: ExperimentOverrides | None = None,
                   particles: int | None = None, only: list[str] | None = None, jobs: int = 2,
                   backend: str = "loky", force_new: bool = False, progress: bool = True) -> RobustnessRun:
    """Run (or resume) the robustness protocol on every SLAM of :data:`LABELS`.

    Parameters
    ----------
    out : path
        Directory of the stores (``out/<label>``).
    experiment : path, shipped name or Experiment
        The protocol (default the shipped ``robustness``).
    overrides : ExperimentOverrides, optional
        Changes applied first (:func:`scale_overrides`).
    particles : int, optional
        Particles of the FastSLAMs (default: their ``[slam]`` table's).
    only : list of str, optional
        A subset of :data:`LABELS`.
    jobs, backend, force_new, progress
        Passed to :func:`faultlab.runner.run_experiment`.
    """
    unknown = sorted(set(only or ()) - set(LABELS))
    if unknown:
        raise ConfigError(f"unknown SLAM label(s) {unknown}; known: {', '.join(LABELS)}")
    chosen = [label for label in LABELS if only is None or label in only]
    experiments = {label: exp for label, exp in slam_experiments(experiment, overrides=overrides).items()
                   if label in chosen}
    out = Path(out)
    summaries = {}
    for label, exp in experiments.items():
        if exp is None:
            continue
        if particles is not None and "particles" in dict(exp.slam.options):
            exp = exp.apply(ExperimentOverrides(particles=particles))
        summaries[label] = run_experiment(exp, out / label, jobs=jobs, backend=backend, force_new=force_new,
                                          progress=progress)
    return RobustnessRun(out=out, summaries=summaries,
                         not_installed=tuple(label for label, exp in experiments.items() if exp is None))
