"""Benchmark: the paper's full protocol (experiments/paper.toml) end to end on this machine.

    python benchmarks/bench_paper.py                 # 180 SLAM executions, 2 workers, fresh temp dir
    python benchmarks/bench_paper.py --runs 1        # one evaluation run only (60 executions)
    python benchmarks/bench_paper.py --repetitions 10                  # K = 10: 1800 executions, batched
    python benchmarks/bench_paper.py --repetitions 10 --batch-size 1   # the same, one repetition per job
    python benchmarks/bench_paper.py --out results/bench --json bench.json

Reports the wall time (case generation + all jobs + store), the per-job
breakdown of ``runtime_s`` (the SLAM execution itself; in a batched job each
repetition's share of the batch) by suite and variant, the slowest jobs, how
well the workers were used, and an estimate of the time spent scoring the maps
(``map_errors``, mostly the earth mover's distance: each case's map scored once
against a dead-reckoning map of the same landmarks, times its executions).
The load average is printed before and after.  Targets: the paper's 180
executions in under 10 minutes on 2 cores (the original took ~26 hours); with
``--repetitions 10`` (1800 executions) also under 10 minutes.  Not a test:
nothing is asserted.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
TARGET_S = 600.0


def metrics_estimate(out: Path, df) -> float:
    """CPU seconds to score every execution's map: one timed ``map_errors`` per case x its executions.

    The map scored is the dead-reckoning map of the case (every observed landmark), so its size is
    that of a SLAM's map; the earth mover's distance dominates and depends on the size only.
    """
    import numpy as np

    from faultlab.metrics import map_errors
    from faultlab.runner import case_path
    from faultlab.scenario import load_scenario
    from faultlab.slam import DeadReckoning, run_slam

    total = 0.0
    counts = df.groupby(["run", "suite", "case"]).size()
    for (run, suite, case), executions in counts.items():
        sc = load_scenario(case_path(out, run, suite, case))
        est = run_slam(DeadReckoning(), sc, rng=np.random.default_rng(0))
        t0 = time.process_time()
        map_errors(sc, est)
        total += (time.process_time() - t0) * executions
    return total


def main(argv: list[str] | None = None) -> int:
    import pandas as pd

    from faultlab import __version__
    from faultlab.runner import load_experiment, load_results, run_experiment

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--experiment", default=str(ROOT / "experiments" / "paper.toml"))
    ap.add_argument("--out", default=None, help="output directory (default: a fresh temporary directory)")
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--backend", default="loky")
    ap.add_argument("--runs", type=int, default=None, help="override the number of evaluation runs")
    ap.add_argument("--repetitions", type=int, default=None, help="override K, the SLAM repetitions per case")
    ap.add_argument("--batch-size", type=int, default=None,
                    help="repetitions per job (default: all K of a case and variant in one batched job; 1: none)")
    ap.add_argument("--no-metrics-estimate", action="store_true", help="skip the map-scoring time estimate")
    ap.add_argument("--json", default=None, help="also write the numbers to this JSON file")
    args = ap.parse_args(argv)

    exp = load_experiment(args.experiment)
    if args.runs is not None:
        exp = exp.replace(runs=args.runs)
    if args.repetitions is not None:
        exp = exp.replace(repetitions=args.repetitions)
    load_before = os.getloadavg()
    tmp = None
    if args.out is None:
        tmp = tempfile.TemporaryDirectory(prefix="faultlab-bench-")
        out = Path(tmp.name)
    else:
        out = Path(args.out)

    t0 = time.perf_counter()
    summary = run_experiment(exp, out, jobs=args.jobs, backend=args.backend, force_new=True, progress=True,
                             batch_size=args.batch_size)
    wall = time.perf_counter() - t0
    load_after = os.getloadavg()
    df = load_results(out)
    if summary.n_new != summary.n_jobs:
        print(f"note: {summary.n_skipped} jobs were already in {out}; the wall time covers only the rest")

    busy = float(df.runtime_s.sum())
    by = (df.groupby(["suite", "variant"], sort=False).runtime_s
          .agg(jobs="count", mean="mean", median="median", max="max", total="sum").round(2))
    by_suite = df.groupby("suite", sort=False).runtime_s.agg(jobs="count", mean="mean", total="sum").round(2)
    slowest = df.nlargest(5, "runtime_s")[["run", "suite", "case", "variant", "n_landmarks", "inactivity",
                                           "runtime_s", "status"]]
    pd.set_option("display.width", 160)
    print()
    print(f"faultlab {__version__}, python {platform.python_version()}, {os.cpu_count()} CPUs, "
          f"{args.jobs} workers ({args.backend})")
    print(f"experiment: {args.experiment} (hash {exp.hash[:12]}), runs={exp.runs}, repetitions={exp.repetitions}, "
          f"batch size {args.batch_size or 'all repetitions'}")
    print(f"load average before: {' '.join(f'{x:.2f}' for x in load_before)}, "
          f"after: {' '.join(f'{x:.2f}' for x in load_after)}")
    print(f"{summary}")
    print(f"wall time end to end: {wall:.1f} s for {len(df)} SLAM executions "
          f"({wall / max(len(df), 1):.2f} s per execution)")
    print(f"sum of job runtimes: {busy:.1f} s; worker utilisation {busy / (wall * args.jobs):.0%}")
    if exp.runs == 3 and len(df) in (180, 1800):
        verdict = "met" if wall < TARGET_S else "MISSED"
        print(f"target: {len(df)} executions in < {TARGET_S:.0f} s -> {verdict}")
    scoring = None
    if not args.no_metrics_estimate:
        scoring = metrics_estimate(out, df)
        print(f"map scoring (map_errors), estimated: {scoring:.1f} s of CPU for {len(df)} executions "
              f"({scoring / (wall * args.jobs):.0%} of the workers' time); SLAM: {busy:.1f} s "
              f"({busy / (wall * args.jobs):.0%})")
    print("\nruntime_s per suite and variant:")
    print(by.to_string())
    print("\nruntime_s per suite:")
    print(by_suite.to_string())
    print("\nslowest jobs:")
    print(slowest.to_string(index=False))
    if args.json:
        Path(args.json).write_text(json.dumps({
            "wall_time_s": wall, "n_executions": int(len(df)), "jobs": args.jobs, "backend": args.backend,
            "sum_runtime_s": busy, "counts": dict(summary.counts), "experiment_hash": exp.hash,
            "repetitions": exp.repetitions, "batch_size": args.batch_size, "metrics_estimate_s": scoring,
            "load_before": list(load_before), "load_after": list(load_after),
            "faultlab_version": __version__,
            "by_suite_variant": by.reset_index().to_dict(orient="records"),
        }, indent=1))
    if tmp is not None:
        tmp.cleanup()
    return 0


if __name__ == "__main__":
    sys.exit(main())
