"""``python -m faultlab run EXPERIMENT --out DIR``: run or resume a campaign."""

from __future__ import annotations

import argparse
from pathlib import Path

from faultlab.cli.options import add_examples, add_execution_options, shipped_experiments

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
    p.add_argument("--adaptive", default=None, metavar="STAGES",
                   help="run the repetitions in stages, e.g. 5,10 (cumulative; the last equals the "
                        "experiment's repetitions), stopping decided (case, variant) pairs: sets the "
                        "experiment's [adaptive] stages (its other keys keep their values or defaults)")
    p.add_argument("--metrics", default=None, metavar="M,...",
                   help="record only these metrics (rms, emd, ate), e.g. rms (default: the experiment's metrics "
                        "option, all three unless it says otherwise); the others are stored as NaN and cost nothing")
    add_execution_options(p)
    add_examples(p, ["faultlab run smoke --out results/smoke --metrics rms",
                     "nice -n 10 faultlab run paper --out results/paper --jobs 2",
                     "faultlab run my-campaign.toml --out results/mine --jobs 1"])
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    from faultlab.errors import ConfigError
    from faultlab.runner import load_experiment, run_experiment

    out = Path(args.out) if args.out else Path("results") / Path(args.experiment).stem
    experiment = load_experiment(args.experiment)
    if args.adaptive is not None:
        try:
            stages = [int(k) for k in args.adaptive.split(",")]
        except ValueError:
            raise ConfigError(f"--adaptive: expected cumulative repetitions such as 5,10, got {args.adaptive!r}") \
                from None
        experiment = experiment.merge(adaptive={"stages": stages})
    if args.metrics is not None:
        experiment = experiment.replace(metrics=[m.strip() for m in args.metrics.split(",")])
    summary = run_experiment(experiment, out, jobs=args.jobs, backend=args.backend,
                             force_new=args.force_new, progress=not args.no_progress)
    print(f"results: {summary.results}")
    print(summary)
    return 0
