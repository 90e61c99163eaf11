"""``python -m faultlab study run|report|k-report``: which test-design strategy detects faults with fewer cases."""

from __future__ import annotations

import argparse
from pathlib import Path

from faultlab.cli.options import add_examples, add_execution_options, add_verb_group, positive_int, print_paths

__all__ = ["register"]

_HELP = "test-design strategies study: case pools, kill matrix, suites drawn from the pools"
_DESCRIPTION = ("Run a pool of cases of every strategy once per fault and sampled mutant (K repetitions, common "
                "random numbers), keep every case's exact p value (the kill matrix), then evaluate suites of each "
                "size drawn from the pools at no further SLAM cost.")


def register(subparsers) -> None:
    sub = add_verb_group(subparsers, "study", help=_HELP, description=_DESCRIPTION,
                         examples=["faultlab study run --quick --out results/study-quick",
                                   "faultlab study report results/study-quick"])
    run = sub.add_parser("run", help="run (or resume) a study's case pools",
                         description="Run every pool case against the baseline, the file's faults and its "
                                     "[mutation] sample through the runner. Rerunning the same command resumes.")
    run.add_argument("experiment", nargs="?", default="study",
                     help="study file or a shipped name (default: study)")
    run.add_argument("--quick", action="store_true", help="the file's [study.quick] scale")
    run.add_argument("--out", default=None, help="output directory (default: results/<name>[-quick])")
    run.add_argument("--jobs", type=positive_int, default=2, help="worker processes (default: 2)")
    add_execution_options(run)
    add_examples(run, ["faultlab study run --quick --out results/study-quick",
                       "nice -n 10 faultlab study run study --out results/study"])
    run.set_defaults(func=_run)

    rep = sub.add_parser("report", help="kill matrix, detection probabilities, mutation scores, comparisons",
                         description="Read a study's results (runs nothing) and write kill_matrix.csv, "
                                     "detection.csv, scores.csv, comparisons.csv, power.csv, study.md and "
                                     "detection_vs_size.png.")
    rep.add_argument("results", help="output directory of `faultlab study run`")
    rep.add_argument("--reports", default=None, help="where to write (default: RESULTS/report)")
    add_examples(rep, ["faultlab study report results/study", "faultlab study report reports/study/store --reports reports/study"])
    rep.set_defaults(func=_report)

    alloc = sub.add_parser("k-report", help="repetitions K against cases n at a fixed budget (one pool, runs nothing)",
                           description="Judge every case of a study's single pool again on its first K "
                                       "repetitions for each K, draw suites of n = budget / K cases and write "
                                       "allocation.csv, allocation_summary.csv, allocation_meta.json and "
                                       "allocation.md.")
    alloc.add_argument("results", help="output directory of `faultlab study run` (one suite kind)")
    alloc.add_argument("--budget", type=positive_int, required=True, help="paired executions K x n per suite")
    alloc.add_argument("--k", type=positive_int, nargs="+", required=True, help="repetitions compared")
    alloc.add_argument("--draws", type=positive_int, default=2000, help="suites drawn per allocation")
    alloc.add_argument("--seed", type=int, default=0, help="seed of the suite draws")
    alloc.add_argument("--reports", default=None, help="where to write (default: RESULTS/k-report)")
    add_examples(alloc, ["faultlab study k-report results/study-k --budget 72 --k 6 9 12 --reports reports/study-k"])
    alloc.set_defaults(func=_k_report)


def _run(args: argparse.Namespace) -> int:
    from faultlab.campaigns.study import load_study_experiment, run_study

    sexp = load_study_experiment(args.experiment, quick=args.quick)
    out = Path(args.out) if args.out else Path("results") / (Path(args.experiment).stem
                                                             + ("-quick" if args.quick else ""))
    print(run_study(sexp, out, jobs=args.jobs, backend=args.backend, force_new=args.force_new,
                    progress=not args.no_progress))
    return 0


def _report(args: argparse.Namespace) -> int:
    from faultlab.report.study import write_study_report

    reports = args.reports if args.reports is not None else Path(args.results) / "report"
    return print_paths(write_study_report(args.results, reports))


def _k_report(args: argparse.Namespace) -> int:
    from faultlab.report.allocation import write_allocation_report

    reports = args.reports if args.reports is not None else Path(args.results) / "k-report"
    return print_paths(write_allocation_report(args.results, reports, budget=args.budget, ks=args.k,
                                               draws=args.draws, seed=args.seed))
