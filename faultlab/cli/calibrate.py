"""``python -m faultlab calibrate``: the detection rules' false-alarm rates on an A/A campaign."""

from __future__ import annotations

import argparse

from faultlab.cli.options import add_examples, add_execution_options, positive_int

__all__ = ["register", "handler"]


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "calibrate", help="measure the detection rules' false-alarm rates on an A/A campaign",
        description="Run the paper's protocol with the variants baseline and baseline_replica (the unmodified "
                    "SLAM with independent seeds) and K repetitions per case, then print per rule and suite "
                    "the empirical false-alarm rate with an interval clustered by case, then the statistical rule's "
                    "per-case A/A rate with its Clopper-Pearson interval and the check: exit 3 when the rule "
                    "rejects too often (lower bound above alpha), 4 for an underpowered calibration (upper "
                    "bound not below 2 alpha), 0 otherwise. Rerunning resumes; --check DIR runs nothing.")
    p.add_argument("--quick", action="store_true",
                   help="smoke version: 1 run, small suites, K = 6, 200 steps, 60 particles")
    p.add_argument("--out", default=None, help="results directory (default: results/calibrate[-quick])")
    p.add_argument("--reports", default=None, metavar="DIR", help="also save the analysis tables (CSV) here")
    p.add_argument("--check", default=None, metavar="DIR",
                   help="run nothing: repeat the check on a saved A/A analysis (its jobs.csv and analysis.json); "
                        "with --reports, write calibration.csv there")
    p.add_argument("--jobs", type=positive_int, default=2, help="worker processes (default: 2)")
    p.add_argument("--repetitions", type=positive_int, default=None, metavar="K",
                   help="SLAM repetitions per case (default 10; 6 with --quick)")
    add_execution_options(p)
    add_examples(p, ["faultlab calibrate --quick --out results/calibrate-quick",
                     "nice -n 10 faultlab calibrate --out results/calibrate --reports results/calibrate/report"])
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    """Exit 0 when calibrated, 3 when miscalibrated (or nothing could be judged), 4 when underpowered."""
    from pathlib import Path

    from faultlab.analysis.calibration import EXIT_CODES, assess_calibration, check_saved, format_calibration
    from faultlab.campaigns.calibrate import calibrate
    from faultlab.precision import write_csv

    if args.check is not None:
        rates, check, rule = check_saved(args.check)
        print(format_calibration(rates, check, alpha=rule.alpha))
        if args.reports is not None:
            Path(args.reports).mkdir(parents=True, exist_ok=True)
            write_csv(rates, Path(args.reports) / "calibration.csv")
        return EXIT_CODES[check.status]
    run = calibrate(out=args.out, quick=args.quick, repetitions=args.repetitions, jobs=args.jobs,
                    backend=args.backend, force_new=args.force_new, progress=not args.no_progress)
    print(run)
    result = assess_calibration(run.out)
    if args.reports is not None:
        result.analysis.save(args.reports)
        write_csv(result.rates, Path(args.reports) / "calibration.csv")
    print(result)
    return EXIT_CODES[result.check.status]
