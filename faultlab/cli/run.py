"""``python -m faultlab run EXPERIMENT --out DIR``: run or resume a campaign."""

from __future__ import annotations

import argparse
from pathlib import Path

from faultlab.cli.options import add_examples, add_execution_options, shipped_experiments
from faultlab.runner import run_experiment

__all__ = ["register", "handler"]


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "run", help="run (or resume) an experiment file",
        description="Run the jobs of an experiment file and store one row per job in OUT/results.sqlite. "
                    "Rerunning the same command resumes: only missing jobs run.")
    p.add_argument("experiment", help="experiment TOML file, e.g. experiments/paper.toml, or the name "
                                      f"of a shipped experiment ({shipped_experiments()})")
    p.add_argument("--out", default=None,
                   help="output directory (default: results/<experiment name, without .toml>)")
    p.add_argument("--jobs", type=int, default=2, help="worker processes (default: 2)")
    add_execution_options(p)
    add_examples(p, ["faultlab run smoke --out results/smoke", "nice -n 10 faultlab run paper --out results/paper --jobs 2",
                     "faultlab run my-campaign.toml --out results/mine --backend dask"])
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    out = Path(args.out) if args.out else Path("results") / Path(args.experiment).stem
    summary = run_experiment(args.experiment, out, jobs=args.jobs, backend=args.backend,
                             force_new=args.force_new, progress=not args.no_progress)
    print(f"results: {summary.results}")
    print(summary)
    return 0
