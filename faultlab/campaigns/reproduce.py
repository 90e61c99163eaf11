"""The paper's protocol as a campaign: the shipped experiment, its smoke and profile versions, the ablation.

:func:`reproduce` loads the shipped experiment ``paper`` (``experiments/paper.toml``: 3 runs x 3
suites x 5 cases x 4 variants, Sec. VII), optionally shrinks it (``quick``) or repeats it
(``runs``), and runs (or resumes) it with :func:`faultlab.runner.run_experiment`.  The report of
its store is rendered by :func:`faultlab.report.reproduce.rebuild_report` (``faultlab reproduce``
runs both).

``profile`` runs the protocol on a FastSLAM profile (:mod:`faultlab.slam.profiles`): ``"paper"`` is
the paper's own filter, run as the paper ran it, so with ``fov_bug`` on.

``ablation`` (profile ``"paper"`` only) also runs the arms of :data:`faultlab.slam.profiles.ABLATIONS`
on the same cases and seeds (the profile ``paper`` with the field-of-view defect is the main run
itself; every other arm goes to ``<out>/ablation/<arm>``, with at most ``ablation_runs`` evaluation
runs and the variants :data:`ABLATION_VARIANTS`, resumable like the main run); their effects are
computed by :mod:`faultlab.analysis.ablation`.

Where things go: everything a reproduction writes is under one directory ``out`` (default
:func:`default_out`): the store and the cases in ``out`` itself, the ablation's arms under it
(:func:`ablation_dir`) and the report in :func:`default_reports` ``(out)`` unless another report
directory is given.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path

from faultlab.config import ExperimentOverrides, check_int
from faultlab.errors import ConfigError
from faultlab.runner import Experiment, RunSummary, load_experiment, run_experiment
from faultlab.vocabulary import BASELINE, PAPER_FAULTS

__all__ = ["ReproduceRun", "reproduce", "quick_overrides", "profile_overrides", "default_out", "default_reports",
           "ablation_dir", "run_ablation", "DEFAULT_EXPERIMENT", "QUICK_PARTICLES", "QUICK_STEPS", "QUICK_CASES",
           "ABLATION_PROFILE", "DEFAULT_ABLATION_RUNS", "ABLATION_VARIANTS", "ABLATION_DIR", "REPORT_DIR"]

#: The paper's protocol: the shipped experiment ``paper`` (``experiments/paper.toml``, see
#: :mod:`faultlab.data`), found wherever faultlab is installed.
DEFAULT_EXPERIMENT = "paper"
#: ``--quick``: SLAM particles and active steps per case.
QUICK_PARTICLES = 60
QUICK_STEPS = 200
#: ``--quick``: cases of the random and fixed suites (the systematic suite keeps the fewest cases
#: that cover every class of Table I, i.e. 5).
QUICK_CASES = 2
#: The profile whose differences the ablation isolates.
ABLATION_PROFILE = "paper"
#: Evaluation runs of the ablation's arms (the main run keeps its own).
DEFAULT_ABLATION_RUNS = 1
#: Subdirectory of the main run's results directory that holds the ablation's arms (one store per arm).
ABLATION_DIR = "ablation"
#: Subdirectory of the results directory that holds its report unless another is given.
REPORT_DIR = "report"
#: Variants of the ablation's arms: the baseline and the fault the paper profile exists to compare.
ABLATION_VARIANTS = (BASELINE, "missing_angle_wrap")


def quick_overrides(experiment: Experiment) -> ExperimentOverrides:
    """Overrides that turn an experiment into a smoke version (1 run, few cases, short traces).

    One evaluation run; the systematic suite with the fewest cases that cover every class
    ("auto"), the other suites with :data:`QUICK_CASES` cases; the baseline and the paper's three
    faults; one SLAM repetition; :data:`QUICK_STEPS` steps; :data:`QUICK_PARTICLES` particles.
    """
    return ExperimentOverrides(
        runs=1, repetitions=1, n_steps=QUICK_STEPS, variants=(BASELINE, *PAPER_FAULTS),
        suites=tuple((kind, None if kind == "systematic" else QUICK_CASES) for kind in experiment.suite_kinds),
        particles=(min(QUICK_PARTICLES, experiment.slam.config.particles) if experiment.slam.name == "fastslam"
                   else None))


def profile_overrides(experiment, profile: str) -> ExperimentOverrides:
    """Overrides that run ``experiment`` on FastSLAM profile ``profile`` (as the paper did for ``"paper"``).

    The SLAM becomes ``fastslam`` with the profile's settings (the file's SLAM settings are replaced:
    the profile is the system under test); every profile other than ``"reference"`` also gets
    ``fov_bug = true``, the field of view the paper's scenarios had.
    """
    from faultlab.slam.profiles import DEFAULT_PROFILE, get_profile

    p = get_profile(profile)  # ConfigError for an unknown name
    if experiment.slam.name != "fastslam":
        raise ConfigError(f"a FastSLAM profile needs [slam] name = 'fastslam', {experiment.source} has "
                          f"{experiment.slam.name!r}")
    return ExperimentOverrides(slam={"name": "fastslam", "profile": p.name, **p.config.to_options()},
                               fov_bug=p.name != DEFAULT_PROFILE)


def default_out(experiment_path: str | Path, *, quick: bool = False, runs: int | None = None,
                profile: str | None = None) -> Path:
    """``results/<experiment stem>`` with ``-profile-<name>`` / ``-quick`` / ``-runs<N>`` appended, so a
    profile, a shrunk or a repeated protocol never collides with the full one's results store.

    ``experiment_path`` is a path or a shipped name: ``"paper"`` and ``"experiments/paper.toml"``
    both give ``results/paper``."""
    name = (Path(experiment_path).stem + (f"-profile-{profile}" if profile else "")
            + ("-quick" if quick else "") + (f"-runs{runs}" if runs else ""))
    return Path("results") / name


def default_reports(out: str | Path) -> Path:
    """The report directory of the results directory ``out``: ``out/report`` (:data:`REPORT_DIR`)."""
    return Path(out) / REPORT_DIR


def ablation_dir(out: str | Path) -> Path:
    """Where the ablation's arms of the main run stored in ``out`` go: ``<out>/ablation`` (under ``out``, like
    everything a reproduction writes)."""
    return Path(out) / ABLATION_DIR


def run_ablation(experiment, out: str | Path, *, runs: int = DEFAULT_ABLATION_RUNS,
                 suites: dict[str, int] | None = None, jobs: int = 2, backend: str = "loky",
                 progress: bool = True) -> dict[str, Path]:
    """Run (or resume) every arm of :data:`faultlab.slam.profiles.ABLATIONS`.

    Parameters
    ----------
    experiment : faultlab.runner.Experiment
        The main run's experiment, on the profile ``"paper"`` (its results are in ``out``).
    out : path
        The main run's results directory.  The arm that equals the main run (its profile and field of
        view) is read from there; every other arm is ``experiment`` on the arm's profile and field of
        view with at most ``runs`` evaluation runs and the variants of :data:`ABLATION_VARIANTS` that
        ``experiment`` has, stored in ``ablation_dir(out) / arm.name``.
    runs : int
        Evaluation runs of the other arms.
    suites : dict of str to int, optional
        Suites (kind -> cases) of the arms that are not compared with the main run itself (default: the
        main run's suites).  An arm compared with the main run keeps its suites; rows pair by (run, suite,
        case, rep), so the other arms pair with it on the cases they share (the same seeds give the same
        cases and SLAM seeds whatever the other suites).
    jobs, backend, progress
        Passed to :func:`faultlab.runner.run_experiment`.

    Returns
    -------
    dict of str to Path
        Arm name -> its results directory, in the order of :func:`~faultlab.slam.profiles.ablation_arms`
        (what :func:`faultlab.analysis.ablation.ablation` reads).

    Raises
    ------
    ConfigError
        The experiment is not on the profile ``"paper"``, or ``runs`` is not a positive integer.
    """
    from faultlab.slam.profiles import ABLATIONS, Arm, ablation_arms

    if experiment.slam.profile != ABLATION_PROFILE:
        raise ConfigError(f"the ablation isolates the differences of the profile {ABLATION_PROFILE!r}; "
                          f"{experiment.source} runs {experiment.slam.profile!r}")
    check_int(runs, name="ablation runs", minimum=1)
    main = Arm(experiment.slam.profile, experiment.fov_bug)
    with_main = {a.alternative for a in ABLATIONS if a.paper == main} | {a.paper for a in ABLATIONS
                                                                           if a.alternative == main}
    dirs: dict[str, Path] = {}
    for arm in ablation_arms():
        if arm == main:
            dirs[arm.name] = Path(out)
            continue
        arm_experiment = experiment.merge(slam={"profile": arm.profile}).apply(ExperimentOverrides(
            fov_bug=arm.fov_bug, runs=min(runs, experiment.runs),
            variants=tuple(v for v in experiment.variants if v in ABLATION_VARIANTS),
            suites=suites if suites is not None and arm not in with_main else None))
        dirs[arm.name] = ablation_dir(out) / arm.name
        run_experiment(arm_experiment, dirs[arm.name], jobs=jobs, backend=backend, progress=progress)
    return dirs


@dataclass(frozen=True)
class ReproduceRun:
    """What :func:`reproduce` ran.

    Attributes
    ----------
    experiment : Experiment
        The experiment as run (with the ``quick`` / ``runs`` / ``profile`` overrides applied).
    summary : RunSummary
        The runner's summary (jobs run now, resumed, per status, wall time).
    out : Path
        The results directory.
    reports : Path
        Where the report of this run goes (the given directory, or :func:`default_reports`).
    ablation_dirs : dict of str to Path
        Arm name -> results directory of the ablation's arms (empty without ``ablation``).
    wall_time_s : float
        Wall time of the campaign (main run and ablation arms), s.
    """

    experiment: Experiment
    summary: RunSummary
    out: Path
    reports: Path
    wall_time_s: float
    ablation_dirs: dict = field(default_factory=dict)

    def __str__(self) -> str:
        return f"results: {self.out} ({self.summary})"


def reproduce(experiment_path: str | Path = DEFAULT_EXPERIMENT, *, out: str | Path | None = None,
              reports: str | Path | None = None, runs: int | None = None, quick: bool = False,
              profile: str | None = None, jobs: int = 2, backend: str = "loky", force_new: bool = False,
              progress: bool = True, ablation: bool = False, ablation_runs: int = DEFAULT_ABLATION_RUNS,
              ablation_suites: dict[str, int] | None = None) -> ReproduceRun:
    """Run (or resume) an experiment and, with ``ablation``, the ablation's arms.

    Parameters
    ----------
    experiment_path : path or str
        Experiment TOML, or the name of a shipped experiment (default ``"paper"``, the
        paper's protocol; see :func:`faultlab.runner.load_experiment`).
    out : path, optional
        Results directory; default :func:`default_out` (relative to the working directory).
    reports : path, optional
        Report directory recorded in the result; default :func:`default_reports` ``(out)``.
    runs : int, optional
        Evaluation runs (overrides the file's ``runs``; e.g. 30 for power).
    quick : bool
        Run the smoke version (:func:`quick_overrides`).
    profile : str, optional
        Run on this FastSLAM profile (:func:`profile_overrides`; ``"paper"``: the paper's filter with
        ``fov_bug`` on).
    jobs, backend, force_new, progress
        Passed to :func:`faultlab.runner.run_experiment`.
    ablation : bool
        Also run the ablation of the profile ``"paper"``'s differences (:func:`run_ablation`).  Needs
        ``profile="paper"``.
    ablation_runs : int
        Evaluation runs of the ablation's arms other than the main run.
    ablation_suites : dict of str to int, optional
        Suites of the ablation's arms not compared with the main run itself (:func:`run_ablation`).

    Returns
    -------
    ReproduceRun

    Raises
    ------
    ConfigError
        Malformed experiment or options (before anything runs); ``ablation`` without ``profile="paper"``.
    ResultsError
        ``out`` holds another experiment's results and ``force_new`` is False.
    """
    start = time.perf_counter()
    changes = ExperimentOverrides(runs=runs)  # ConfigError for runs that are not a positive integer
    check_int(jobs, name="jobs", minimum=1)
    experiment = load_experiment(experiment_path)
    if profile is not None:
        experiment = experiment.apply(profile_overrides(experiment, profile))
    if quick:
        changes = quick_overrides(experiment).then(changes)
    experiment = experiment.apply(changes)
    if ablation and profile != ABLATION_PROFILE:
        raise ConfigError(f"ablation needs profile={ABLATION_PROFILE!r} (it isolates that profile's differences), "
                          f"got {profile!r}")
    check_int(ablation_runs, name="ablation_runs", minimum=1)
    out = Path(out) if out is not None else default_out(experiment_path, quick=quick, runs=runs, profile=profile)
    reports = Path(reports) if reports is not None else default_reports(out)
    summary = run_experiment(experiment, out, jobs=jobs, backend=backend, force_new=force_new,
                             progress=progress)
    dirs = (run_ablation(experiment, out, runs=ablation_runs, suites=ablation_suites, jobs=jobs, backend=backend,
                         progress=progress) if ablation else {})
    return ReproduceRun(experiment=experiment, summary=summary, out=out, reports=reports,
                        wall_time_s=time.perf_counter() - start, ablation_dirs=dirs)
