"""``faultlab robustness run|report``: every sensor and hardware fault on FastSLAM 1.0, 2.0, EKF-SLAM and GTSAM."""

from __future__ import annotations

import argparse

from faultlab.cli.options import add_execution_options, add_verb_group, epilog, positive_int
from faultlab.vocabulary import DEFAULT_ALPHA

__all__ = ["register"]


def register(subparsers) -> None:
    sub = add_verb_group(
        subparsers, "robustness",
        help="robustness to sensor and hardware faults: run the campaign on every SLAM, report the degradation",
        description="'run' runs the robustness protocol (default: the shipped experiment 'robustness': the "
                    "baseline and every built-in sensor fault) once per SLAM under test (FastSLAM 1.0 and 2.0, "
                    "EKF-SLAM, GTSAM if installed), one store per SLAM; 'report' computes the degradation per "
                    "SLAM and fault (paired ratio faulty/baseline with an interval over cases, per-case "
                    "verdicts) and the per-parameter view, and writes tables, figures and README.md.",
        examples=["nice -n 10 faultlab robustness run --out results/robustness",
                  "faultlab robustness report results/robustness --reports reports/robustness"])

    run = sub.add_parser(
        "run", help="run (or resume) the robustness protocol on every SLAM, one store per SLAM",
        description="Run the protocol once per SLAM (only the [slam] table changes). The scale options "
                    "override the file's. Rerunning the same command resumes.",
        **epilog(["nice -n 10 faultlab robustness run --out results/robustness",
                  "faultlab robustness run --out results/tiny --cases 4 --steps 30 --repetitions 5 --particles 10"]))
    run.add_argument("experiment", nargs="?", default=None,
                     help="the protocol: an experiment file or a shipped name (default: robustness)")
    run.add_argument("--out", required=True, help="directory of the stores (one subdirectory per SLAM)")
    run.add_argument("--only", default=None, metavar="LABELS",
                     help="comma-separated SLAM labels (fastslam1, fastslam2, ekf, gtsam; default: all)")
    run.add_argument("--cases", type=positive_int, default=None, help="random cases (default: the file's)")
    run.add_argument("--steps", type=positive_int, default=None, help="active steps (default: the file's)")
    run.add_argument("--repetitions", type=positive_int, default=None, metavar="K",
                     help="repetitions per case (default: the file's)")
    run.add_argument("--particles", type=positive_int, default=None,
                     help="particles of the FastSLAMs (default: 30)")
    run.add_argument("--jobs", type=positive_int, default=2, help="worker processes (default: 2)")
    add_execution_options(run)
    run.set_defaults(func=_run)

    rep = sub.add_parser(
        "report", help="analyse the stores of 'robustness run' and write the report",
        description="Read the stores (runs nothing) and write degradation.csv, parameters.csv, "
                    "not_applicable.csv, protocol.json, degradation.png, parameters.png and README.md.",
        **epilog(["faultlab robustness report results/robustness --reports reports/robustness"]))
    rep.add_argument("results", help="directory of the stores (the --out of 'faultlab robustness run')")
    rep.add_argument("--reports", default=None, help="where to write (default: RESULTS/report)")
    rep.add_argument("--intro", default=None, metavar="FILE",
                     help="a Markdown file put above the generated page of README.md")
    rep.add_argument("--alpha", type=float, default=DEFAULT_ALPHA, help=f"level of the tests, 1 - confidence (default {DEFAULT_ALPHA:g})")
    rep.set_defaults(func=_report)


def _run(args: argparse.Namespace) -> int:
    from faultlab.campaigns.robustness import DEFAULT_EXPERIMENT, run_robustness, scale_overrides

    only = None if args.only is None else [s.strip() for s in args.only.split(",") if s.strip()]
    overrides = scale_overrides(cases=args.cases, steps=args.steps, repetitions=args.repetitions)
    print(run_robustness(args.out, experiment=args.experiment or DEFAULT_EXPERIMENT, overrides=overrides,
                         particles=args.particles, only=only, jobs=args.jobs, backend=args.backend,
                         force_new=args.force_new, progress=not args.no_progress))
    return 0


def _report(args: argparse.Namespace) -> int:
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    from faultlab.analysis.robustness import robustness
    from faultlab.campaigns.robustness import robustness_stores
    from faultlab.errors import ConfigError, ResultsError
    from faultlab.report.robustness import write_robustness_report

    if not 0 < args.alpha < 1:
        raise ConfigError(f"--alpha must lie in (0, 1), got {args.alpha}")
    stores = robustness_stores(args.results)
    if not stores:
        raise ResultsError(f"{args.results}: no store of a robustness campaign (expected <label>/results.sqlite)")
    intro = ""
    if args.intro is not None:
        try:
            intro = Path(args.intro).read_text()
        except OSError as exc:
            raise ConfigError(f"--intro {args.intro}: cannot be read ({exc.strerror})") from exc
    reports = Path(args.reports) if args.reports is not None else Path(args.results) / "report"
    print(write_robustness_report(robustness(stores, alpha=args.alpha), reports, intro=intro))
    return 0
