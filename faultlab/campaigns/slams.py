"""The cross-SLAM campaign: one protocol (the shipped experiment ``slams``) on every built-in SLAM.

Every SLAM runs the same protocol (cases, seeds, faults, K, rule); only the ``[slam]`` table
changes (:data:`SUTS`).  The FastSLAMs use 30 particles; every SLAM keeps the paper's noise
settings (Sec. VII-A).  A SLAM that needs an optional dependency that is not installed (gtsam,
:data:`REQUIRES`) is left out and said so.  Each SLAM's store is ``out/<label>``; the comparison is
computed by :func:`faultlab.analysis.slams.compare_slams` and rendered by
:func:`faultlab.report.slams.write_slam_report`.
"""

from __future__ import annotations

import importlib.util
from dataclasses import dataclass
from pathlib import Path

from faultlab.config import ExperimentOverrides
from faultlab.errors import ConfigError
from faultlab.runner import Experiment, RunSummary, load_experiment, parse_experiment, results_path, run_experiment

__all__ = ["SUTS", "REQUIRES", "DEFAULT_EXPERIMENT", "SlamsRun", "slam_experiments", "slam_stores", "run_slams"]

#: The shipped protocol of the cross-SLAM campaign.
DEFAULT_EXPERIMENT = "slams"
#: label -> the [slam] table of that SLAM under test (the protocol's other keys are the file's).
SUTS: dict[str, dict] = {
    "fastslam1": {"name": "fastslam", "particles": 30},
    "fastslam2": {"name": "fastslam2", "particles": 30},
    "ekf": {"name": "ekf"},
    "gtsam": {"name": "gtsam"},
    "fastslam1-unknown": {"name": "fastslam", "particles": 30, "association": "unknown"},
    "fastslam2-unknown": {"name": "fastslam2", "particles": 30, "association": "unknown"},
}
#: SLAM name -> the module it needs.
REQUIRES = {"gtsam": "gtsam"}


def slam_experiments(experiment: str | Path | Experiment = DEFAULT_EXPERIMENT, *,
                     overrides: ExperimentOverrides | None = None) -> dict[str, Experiment | None]:
    """label -> the protocol on that SLAM of :data:`SUTS` (None when its optional dependency is missing).

    ``overrides`` (e.g. a smaller scale) are applied to the protocol before the
    ``[slam]`` table is replaced; the metric follows each SLAM's association (``rms``, or ``emd``
    without landmark ids).
    """
    base = experiment if isinstance(experiment, Experiment) else load_experiment(experiment)
    if overrides:
        base = base.apply(overrides)
    out: dict[str, Experiment | None] = {}
    for label, table in SUTS.items():
        if not _installed(label):
            out[label] = None
            continue
        data = base.to_dict()
        data["slam"] = dict(table)
        data.pop("metric")  # chosen by the SLAM's association: rms, or emd without landmark ids
        out[label] = parse_experiment(data, source=f"{base.source} [{label}]", text=base.text)
    return out


def _installed(label: str) -> bool:
    need = REQUIRES.get(SUTS[label]["name"])
    return need is None or importlib.util.find_spec(need) is not None


def slam_stores(out: str | Path) -> tuple[dict[str, Path], list[str]]:
    """The stores of a cross-SLAM campaign in ``out``.

    Returns (label -> store directory for every label of :data:`SUTS` with a store, the labels without
    a store whose optional dependency is not installed).
    """
    out = Path(out)
    stores = {label: out / label for label in SUTS if results_path(out / label).is_file()}
    return stores, [label for label in SUTS if label not in stores and not _installed(label)]


@dataclass(frozen=True)
class SlamsRun:
    """What :func:`run_slams` ran: per SLAM label its summary, and the SLAMs left out (not installed)."""

    out: Path
    summaries: dict[str, RunSummary]
    not_installed: tuple[str, ...]

    def __str__(self) -> str:
        lines = [f"== {label}: {summary}" for label, summary in self.summaries.items()]
        lines += [f"== {label}: skipped ({SUTS[label]['name']} is not installed)" for label in self.not_installed]
        return "\n".join([*lines, f"stores in {self.out}"])


def run_slams(out: str | Path, *, experiment: str | Path | Experiment = DEFAULT_EXPERIMENT,
              overrides: ExperimentOverrides | None = None, only: list[str] | None = None, jobs: int = 2, backend: str = "loky",
              force_new: bool = False, progress: bool = True) -> SlamsRun:
    """Run (or resume) the protocol on every SLAM of :data:`SUTS`, one store per SLAM in ``out/<label>``.

    Parameters
    ----------
    out : path
        Directory of the stores.
    experiment : path, shipped name or Experiment
        The protocol (default the shipped ``slams``).
    overrides : ExperimentOverrides, optional
        Changes to the protocol (:func:`slam_experiments`).
    only : list of str, optional
        Run only these SLAM labels (default: all of :data:`SUTS`).
    jobs, backend, force_new, progress
        Passed to :func:`faultlab.runner.run_experiment`.

    Raises
    ------
    ConfigError
        An unknown label in ``only``, or a malformed protocol (before anything runs).
    """
    unknown = sorted(set(only or ()) - set(SUTS))
    if unknown:
        raise ConfigError(f"unknown SLAM label(s) {unknown}; known: {', '.join(SUTS)}")
    experiments = {label: exp for label, exp in slam_experiments(experiment, overrides=overrides).items()
                   if only is None or label in only}
    out = Path(out)
    summaries = {}
    for label, exp in experiments.items():
        if exp is not None:
            summaries[label] = run_experiment(exp, out / label, jobs=jobs, backend=backend, force_new=force_new,
                                              progress=progress)
    return SlamsRun(out=out, summaries=summaries,
                    not_installed=tuple(label for label, exp in experiments.items() if exp is None))
