"""``faultlab slams [list|run|report]``: the built-in SLAMs, and the cross-SLAM campaign over them."""

from __future__ import annotations

import argparse

from faultlab.cli.options import add_execution_options, add_verb_group, epilog, positive_int

__all__ = ["register"]


def register(subparsers) -> None:
    sub = add_verb_group(
        subparsers, "slams",
        help="the built-in SLAMs (list), and one protocol run on every one of them (run, report)",
        description="Without a verb, or with 'list': list every built-in SLAM an experiment can name in [slam] "
                    "name: its description, the number of replaceable units, how many built-in faults replace "
                    "one of them (the others do not apply and are skipped in a campaign), and whether optional "
                    "dependencies such as gtsam are installed. 'run' runs one protocol (default: the shipped "
                    "experiment 'slams') on every built-in SLAM, one store per SLAM; 'report' compares them.",
        default=_list,
        examples=["faultlab slams", "faultlab slams run --out results/slams",
                  "faultlab slams report results/slams --reports reports/slams"])

    ls = sub.add_parser("list", help="list the built-in SLAMs: units, applicable built-in faults, optional "
                                     "dependencies",
                        description="List every built-in SLAM with its units, the built-in faults that apply "
                                    "and whether its optional dependencies are installed.",
                        **epilog(["faultlab slams list"]))
    ls.set_defaults(func=_list)

    run = sub.add_parser(
        "run", help="run (or resume) one protocol on every built-in SLAM, one store per SLAM",
        description="Run the experiment once per SLAM under test (FastSLAM 1.0 and 2.0 with 30 particles, "
                    "EKF-SLAM, GTSAM if installed, and both FastSLAMs with unknown data association); only "
                    "the [slam] table changes, so every SLAM sees the same cases, seeds, faults, K and rule. "
                    "Stores go to OUT/<label>. Rerunning the same command resumes.",
        **epilog(["nice -n 10 faultlab slams run --out results/slams",
                  "faultlab slams run my-protocol.toml --out results/mine --only fastslam1,ekf"]))
    run.add_argument("experiment", nargs="?", default=None,
                     help="the protocol: an experiment file or a shipped name (default: slams)")
    run.add_argument("--out", required=True, help="directory of the stores (one subdirectory per SLAM)")
    run.add_argument("--only", default=None, metavar="LABELS",
                     help="comma-separated SLAM labels to run (default: every one)")
    run.add_argument("--jobs", type=positive_int, default=2, help="worker processes (default: 2)")
    add_execution_options(run)
    run.set_defaults(func=_run)

    rep = sub.add_parser(
        "report", help="compare the SLAMs of a cross-SLAM campaign: accuracy, fault sensitivity, figure",
        description="Read the stores of 'faultlab slams run' (runs nothing) and write accuracy, sensitivity and "
                    "not-judged tables, slams.png and README.md.",
        **epilog(["faultlab slams report results/slams",
                  "faultlab slams report reports/slams/store --reports reports/slams --intro reports/slams/intro.md"]))
    rep.add_argument("results", help="directory of the stores (the --out of 'faultlab slams run')")
    rep.add_argument("--reports", default=None, help="where to write (default: RESULTS/report)")
    rep.add_argument("--intro", default=None, metavar="FILE",
                     help="a Markdown file put above the generated page of README.md")
    rep.set_defaults(func=_report)


def _list(args: argparse.Namespace) -> int:
    from faultlab.faults import list_slams

    print(list_slams().format())
    return 0


def _run(args: argparse.Namespace) -> int:
    from faultlab.campaigns.slams import DEFAULT_EXPERIMENT, run_slams

    only = None if args.only is None else [s.strip() for s in args.only.split(",") if s.strip()]
    print(run_slams(args.out, experiment=args.experiment or DEFAULT_EXPERIMENT, only=only, jobs=args.jobs,
                    backend=args.backend, force_new=args.force_new, progress=not args.no_progress))
    return 0


def _report(args: argparse.Namespace) -> int:
    from pathlib import Path

    import matplotlib

    matplotlib.use("Agg")
    from faultlab.analysis.slams import compare_slams
    from faultlab.campaigns.slams import slam_stores
    from faultlab.errors import ConfigError, ResultsError
    from faultlab.report.slams import write_slam_report

    stores, missing = slam_stores(args.results)
    if not stores:
        raise ResultsError(f"{args.results}: no store of a cross-SLAM campaign (expected <label>/results.sqlite)")
    intro = ""
    if args.intro is not None:
        try:
            intro = Path(args.intro).read_text()
        except OSError as exc:
            raise ConfigError(f"--intro {args.intro}: cannot be read ({exc.strerror})") from exc
    reports = Path(args.reports) if args.reports is not None else Path(args.results) / "report"
    reports.mkdir(parents=True, exist_ok=True)
    print(write_slam_report(compare_slams(stores, not_installed=missing), reports, intro=intro))
    return 0
