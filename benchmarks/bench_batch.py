"""Batched repetitions of the reference FastSLAM 1.0: K repetitions in one filter vs one at a time.

Run ``python benchmarks/bench_batch.py`` from the repository root (about 5 minutes; ``--quick``
skips the largest case).  For three cases -- the fixed-suite case (1000 steps, ~29 observations
per step), a small map (16 m^2, 1 landmark/m^2, ~5 observations per step) and the largest Table I
case (6000 landmarks, 1000 active + 2000 idle steps, ~180 observations per active step) -- it
times, side by side and alternating, one single-filter run (K = 1, ``run_slam``) and one batch of
K repetitions (``run_slam_batch``, default K = 10), and prints per repetition: CPU time,
particle-observation updates per second per core (N x observations / CPU time) and the speed-up
of the batch.  Then, in a fresh process, the peak memory (``resource.getrusage`` max RSS) of the
largest case at K repetitions.  The load average is printed before and after; the figures are
CPU times of this process, the best of ``--rounds`` alternations.  Like the campaign's workers, the
benchmark first tunes glibc's allocator (:func:`faultlab.runner.execution.tune_allocator`;
``--no-tune`` measures with the default thresholds).

Targets: K = 10 per-repetition speed-up >= 3x on the fixed case; peak memory of the largest case
at K = 10 <= 4 GiB.  Not a test: nothing is asserted.
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from faultlab.runner.execution import tune_allocator  # noqa: E402
from faultlab.scenario import generate_scenario  # noqa: E402
from faultlab.slam import FastSlam, FastSlamConfig, run_slam, run_slam_batch  # noqa: E402
from faultlab.space.case import FIXED_VALUES, CaseSpec  # noqa: E402

LARGEST = dict(FIXED_VALUES, map_size=400.0, landmark_density=15.0, field_of_view=2 * math.pi, inactivity=2000)
SMALL = dict(FIXED_VALUES, map_size=16.0, landmark_density=1.0)
CASES = {"fixed": FIXED_VALUES, "small map": SMALL, "largest": LARGEST}
SPEEDUP_TARGET = 3.0
MEMORY_TARGET_GIB = 4.0


def scenario(name: str, seed: int):
    return generate_scenario(CaseSpec(CASES[name]), rng=np.random.default_rng(seed))


def cpu_per_rep(sc, k: int, seed: int) -> tuple[float, float]:
    """(CPU s, wall s) per repetition of one run of ``k`` repetitions (k = 1: a single filter)."""
    t0, c0 = time.perf_counter(), time.process_time()
    if k == 1:
        run_slam(FastSlam(), sc, rng=np.random.default_rng(seed))
    else:
        run_slam_batch(FastSlam(), sc, rngs=[np.random.default_rng(seed + i) for i in range(k)])
    return (time.process_time() - c0) / k, (time.perf_counter() - t0) / k


def peak_memory(k: int, seed: int, tune: bool) -> float:
    """Peak RSS (GiB) of a fresh process that runs the largest case with ``k`` batched repetitions."""
    code = ("import resource, sys; sys.argv = ['x']; import numpy as np; "
            "sys.path.insert(0, %r); import bench_batch as b; b.tune_allocator() if %r else None; "
            "sc = b.scenario('largest', %d); "
            "base = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss; "
            "b.run_slam_batch(b.FastSlam(), sc, rngs=[np.random.default_rng(%d + i) for i in range(%d)]); "
            "print(base, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)"
            % (str(Path(__file__).resolve().parent), tune, seed, seed, k))
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path)))
    base_kib, peak_kib = map(int, out.stdout.split())
    return peak_kib / 2 ** 20, base_kib / 2 ** 20


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--k", type=int, default=10, help="repetitions per batch (default 10)")
    ap.add_argument("--rounds", type=int, default=2, help="alternations of K = 1 and K; the best is kept")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--quick", action="store_true", help="skip the largest case and the memory measurement")
    ap.add_argument("--no-tune", action="store_true", help="keep glibc's default allocator thresholds")
    args = ap.parse_args(argv)
    tuned = False if args.no_tune else tune_allocator()
    n = FastSlamConfig().particles
    names = ["fixed", "small map"] + ([] if args.quick else ["largest"])
    print(f"batched FastSLAM benchmark: N = {n}, K = {args.k}, {os.cpu_count()} CPUs, allocator "
          f"{'tuned' if tuned else 'default'}, load average before: {load()}")
    rows = []
    for name in names:
        sc = scenario(name, args.seed)
        pairs = n * int(sc.obs_offsets[-1])
        best = {1: (math.inf, math.inf), args.k: (math.inf, math.inf)}
        for _ in range(args.rounds):
            for k in (1, args.k):
                best[k] = min(best[k], cpu_per_rep(sc, k, args.seed))
        rows.append((name, sc, pairs, best))
    head = ("case", "steps", "obs/step", "K", "cpu s/rep", "wall s/rep", "updates/s/core", "speed-up")
    print(f"{head[0]:<10} {head[1]:>6} {head[2]:>8} {head[3]:>3} {head[4]:>10} {head[5]:>10} {head[6]:>15} {head[7]:>9}")
    for name, sc, pairs, best in rows:
        obs = sc.obs_offsets[-1] / sc.n_steps
        for k, (cpu, wall) in best.items():
            speedup = best[1][0] / cpu
            print(f"{name:<10} {sc.n_steps:>6} {obs:>8.1f} {k:>3} {cpu:>10.3f} {wall:>10.3f} {pairs / cpu:>15.3g} "
                  f"{speedup:>8.2f}x")
    fixed = next(best for name, _, _, best in rows if name == "fixed")
    ratio = fixed[1][0] / fixed[args.k][0]
    print(f"\nper-repetition speed-up, fixed case, K = {args.k} over K = 1 (CPU): {ratio:.2f}x "
          f"({'met' if ratio >= SPEEDUP_TARGET else 'MISSED'}: target >= {SPEEDUP_TARGET:g}x)")
    if not args.quick:
        peak, base = peak_memory(args.k, args.seed, tuned)
        print(f"peak memory, largest case, K = {args.k}: {peak:.2f} GiB max RSS (process after generating "
              f"the case: {base:.2f} GiB) ({'met' if peak <= MEMORY_TARGET_GIB else 'MISSED'}: target <= "
              f"{MEMORY_TARGET_GIB:g} GiB)")
    print(f"load average after: {load()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
