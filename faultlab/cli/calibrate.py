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
                    "the empirical false-alarm rate with an interval clustered by case, and whether the "
                    "statistical rule's rate is at most alpha. Rerunning resumes.")
    p.add_argument("--quick", action="store_true",
                   help="smoke version: 1 run, small suites, K = 6, 200 steps, 60 particles")
    p.add_argument("--out", default=None, help="results directory (default: results/calibrate[-quick])")
    p.add_argument("--reports", default=None, metavar="DIR", help="also save the analysis tables (CSV) here")
    p.add_argument("--jobs", type=positive_int, default=2, help="worker processes (default: 2)")
    p.add_argument("--repetitions", type=positive_int, default=None, metavar="K",
                   help="SLAM repetitions per case (default 10; 6 with --quick)")
    add_execution_options(p)
    add_examples(p, ["faultlab calibrate --quick --out results/calibrate-quick",
                     "nice -n 10 faultlab calibrate --out results/calibrate --reports results/calibrate/report"])
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    from faultlab.analysis.calibration import assess_calibration
    from faultlab.campaigns.calibrate import calibrate

    run = calibrate(out=args.out, quick=args.quick, repetitions=args.repetitions, jobs=args.jobs,
                    backend=args.backend, force_new=args.force_new, progress=not args.no_progress)
    print(run)
    result = assess_calibration(run.out)
    if args.reports is not None:
        result.analysis.save(args.reports)
    print(result)
    return 0 if result.calibrated else 3
