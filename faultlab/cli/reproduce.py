"""``python -m faultlab reproduce`` (run the paper's protocol and report) and
``python -m faultlab report RESULTS`` (rebuild the report from saved results)."""

from __future__ import annotations

import argparse

from faultlab.cli.options import add_execution_options, epilog, positive_int, shipped_experiments

__all__ = ["register", "reproduce_handler", "report_handler"]


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "reproduce", help="reproduce the paper's Table II and write tables and a PDF report",
        description="Run an experiment (default: the paper's protocol, the shipped experiment 'paper' = "
                    "experiments/paper.toml) through the runner, resuming if its results exist, then "
                    "write Table II beside the paper's "
                    "(CSV, Markdown, LaTeX), detection rates with confidence intervals, the comparison "
                    "with the paper, report.pdf and the HTML report (html/index.html, opens offline) to the reports "
                    "directory (default: OUT/report). Everything "
                    "it writes is under OUT unless --reports names another directory.",
        **epilog(["faultlab reproduce --quick --out results/quick",
                  "nice -n 10 faultlab reproduce --out results/paper --reports reports",
                  "faultlab reproduce --profile paper --quick --out results/paper-quick"]))
    p.add_argument("--experiment", default=None,
                   help=f"experiment TOML file, or the name of a shipped experiment ({shipped_experiments()}) "
                        "(default: paper, i.e. experiments/paper.toml)")
    p.add_argument("--out", default=None,
                   help="results directory (default: results/<experiment name>, with -quick / -runsN "
                        "appended for --quick / --runs)")
    p.add_argument("--reports", default=None,
                   help="report directory (default: OUT/report)")
    p.add_argument("--profile", default=None, metavar="NAME",
                   help="run on a FastSLAM profile: 'paper' is the paper's own filter, shallow-copy aliasing "
                        "included (about 40x slower), with the field-of-view defect on as the paper ran it; "
                        "results go to results/<experiment>-profile-<name> unless --out is given")
    p.add_argument("--runs", type=positive_int, default=None,
                   help="evaluation runs, overriding the file's (e.g. 30 for power)")
    p.add_argument("--quick", action="store_true",
                   help="smoke version: 1 run, systematic 5 + random 2 + fixed 2 cases, baseline + the "
                        "3 paper faults, 200 steps, 60 particles")
    p.add_argument("--ablation", action="store_true",
                   help="with --profile paper: also run each of the paper profile's differences on its own "
                        "(paper against paper_no_aliasing, linear against log weights, ...; same cases and "
                        "seeds, results in OUT/ablation/, resumable) and add the paired effects to the report "
                        "(ablation.md/.csv, pages of report.pdf)")
    p.add_argument("--ablation-runs", type=positive_int, default=1,
                   help="evaluation runs of the ablation's arms other than the main run (default: 1)")
    p.add_argument("--ablation-fixed", type=positive_int, default=None, metavar="CASES",
                   help="run the ablation's arms that are not compared with the main run itself on the fixed "
                        "suite only, with this many cases (the cheapest cases; default: the main run's suites)")
    p.add_argument("--jobs", type=positive_int, default=2, help="worker processes (default: 2)")
    add_execution_options(p)
    p.set_defaults(func=reproduce_handler)

    r = subparsers.add_parser(
        "report", help="rebuild the report from saved results (runs nothing)",
        description="Write Table II, detection rates, the comparison with the paper, the map errors against the "
                    "paper's raw data (fidelity.csv/.md) and report.pdf "
                    "from a results directory written by 'run' or 'reproduce', and with --html the HTML report. "
                    "Nothing is rerun.",
        **epilog(["faultlab report results/quick --html", "faultlab report reports/store --reports reports"]))
    r.add_argument("results", help="results directory (or its results.sqlite)")
    r.add_argument("--reports", default=None, help="report directory (default: RESULTS/report)")
    r.add_argument("--html", action="store_true",
                   help="also write the HTML report to REPORTS/html (index.html: overview, sortable and filterable "
                        "tables of cases and verdicts, a page per case, the figures; opens from the file system, "
                        "works offline)")
    r.add_argument("--no-pdf", action="store_true",
                   help="write the tables, the comparison and fidelity only, without report.pdf (seconds instead of "
                        "tens of seconds)")
    r.set_defaults(func=report_handler)


def _headless() -> None:
    import matplotlib

    matplotlib.use("Agg")  # no display needed, whatever the environment says


def reproduce_handler(args: argparse.Namespace) -> int:
    _headless()
    from faultlab.analysis.ablation import ablation
    from faultlab.campaigns.reproduce import DEFAULT_EXPERIMENT, reproduce
    from faultlab.report.ablation import write_ablation
    from faultlab.report.html.campaign import build_campaign_html
    from faultlab.report.reproduce import rebuild_report

    experiment = DEFAULT_EXPERIMENT if args.experiment is None else args.experiment
    run = reproduce(experiment, out=args.out, reports=args.reports, runs=args.runs,
                    quick=args.quick, profile=args.profile, jobs=args.jobs, backend=args.backend,
                    force_new=args.force_new, progress=not args.no_progress, ablation=args.ablation,
                    ablation_runs=args.ablation_runs,
                    ablation_suites=None if args.ablation_fixed is None else {"fixed": args.ablation_fixed})
    print(run)
    effects = ablation(run.ablation_dirs) if run.ablation_dirs else None
    print(rebuild_report(run.out, run.reports, ablation=effects))
    if effects is not None:
        print(write_ablation(effects, run.reports))
    print(build_campaign_html(run.out, run.reports))
    print(f"reproduce took {run.wall_time_s:.1f} s (campaign)")
    return 0


def report_handler(args: argparse.Namespace) -> int:
    _headless()
    from faultlab.report.reproduce import rebuild_report

    from faultlab.campaigns.reproduce import default_reports
    from faultlab.runner.store import results_path

    reports = args.reports if args.reports is not None else default_reports(results_path(args.results).parent)
    print(rebuild_report(args.results, reports, pdf=not args.no_pdf))
    if args.html:
        from faultlab.report.html.campaign import build_campaign_html

        print(build_campaign_html(args.results, reports))
    return 0
