"""Compiled twins vs the numpy units: FastSLAM 1.0 side by side in one process (not a test).

Run ``python benchmarks/bench_twins.py`` from the repository root (a few minutes; ``--quick``
skips the largest case and the memory measurement).  Prints, with the load average before and
after:

* the fixed-suite case (1000 steps, ~29 observations per step), one execution: CPU and wall time
  of the compiled path (the reference step's kernels), of the twins called unit by unit (the path
  of a filter with a replaced unit) and of the numpy path (``FAULTLAB_JIT=0``), alternated
  ``--rounds`` times (best kept), their ratios and the particle-observation updates per second
  per core;
* the largest Table I case (6000 landmarks, 1000 active + 2000 idle steps), one compiled execution
  (and one numpy execution unless ``--quick``);
* K = 10 batched repetitions of the fixed case, CPU per repetition, against K = 1 compiled;
* the peak memory (max RSS) of a fresh process running the largest case at K = 10 (compiled);
* the cost of the compilation: a fresh process with an empty cache directory (``NUMBA_CACHE_DIR``)
  calling :func:`faultlab.slam.twins.warm_up` (first-call compile time), then a second one with
  the same directory (loading the cache), and the import of numba alone.

Every map of the compiled path is checked bit-identical to the numpy path's.  Targets: >= 4x and
>= 20M updates/s/core on the fixed case, largest case <= 2 s, peak memory <= 1 GiB at K = 10.
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from machine import describe, load  # noqa: E402

from faultlab.faults.check import estimates_identical  # noqa: E402
from faultlab.runner.execution import tune_allocator  # noqa: E402
from faultlab.scenario import generate_scenario  # noqa: E402
from faultlab.slam import FastSlam, FastSlamConfig, run_slam, run_slam_batch, twins  # noqa: E402
from faultlab.space.case import FIXED_VALUES, CaseSpec  # noqa: E402

LARGEST = dict(FIXED_VALUES, map_size=400.0, landmark_density=15.0, field_of_view=2 * math.pi, inactivity=2000)


#: The paths compared on the fixed case: the compiled reference step, the compiled twins called
#: unit by unit (what a filter with a replaced unit runs), and numpy.
PATHS = {"compiled": (True, True), "unit twins": (True, False), "numpy": (False, False)}


def make(jit: bool, whole_step: bool = True) -> FastSlam:
    """A reference FastSLAM on the compiled (``jit``) or the numpy path; ``whole_step=False`` calls
    the twins unit by unit instead of the reference step's kernels."""
    saved = twins.JIT_ENABLED
    twins.JIT_ENABLED = jit
    try:
        slam = FastSlam()
    finally:
        twins.JIT_ENABLED = saved
    if not whole_step:  # every stage calls its units (the twins), not the reference step's kernels
        slam._ref_step = slam._ref_predict = slam._ref_correct = False
    return slam


def timed(jit: bool, sc, seed: int, k: int = 1, whole_step: bool = True):
    """(CPU s per repetition, wall s per repetition, estimates) of one run of ``k`` repetitions."""
    slam = make(jit, whole_step)
    t0, c0 = time.perf_counter(), time.process_time()
    if k == 1:
        ests = [run_slam(slam, sc, rng=np.random.default_rng(seed))]
    else:
        ests = run_slam_batch(slam, sc, rngs=[np.random.default_rng(seed + i) for i in range(k)])
    return (time.process_time() - c0) / k, (time.perf_counter() - t0) / k, ests


def child(code: str, env: dict) -> str:
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                         env=dict(os.environ, PYTHONPATH=os.pathsep.join(sys.path), **env))
    return out.stdout.strip()


def peak_memory(k: int, seed: int) -> float:
    """Peak RSS (GiB) of a fresh process that runs the largest case with ``k`` batched repetitions."""
    code = ("import resource, sys, numpy as np; sys.argv = ['x']; sys.path.insert(0, %r); import bench_twins as b; "
            "b.tune_allocator(); b.twins.warm_up(); sc = b.generate_scenario(b.CaseSpec(b.LARGEST), "
            "rng=np.random.default_rng(%d)); "
            "b.run_slam_batch(b.FastSlam(), sc, rngs=[np.random.default_rng(%d + i) for i in range(%d)]); "
            "print(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)"
            % (str(Path(__file__).resolve().parent), seed, seed, k))
    return int(child(code, {})) / 2 ** 20


def compile_costs() -> tuple[float, float, float]:
    """(first-call compile s with an empty cache, warm-up s with the cache filled, numba import s)."""
    warm = "from faultlab.slam import twins; print(twins.warm_up())"
    imp = "import time; t = time.perf_counter(); import numba; print(time.perf_counter() - t)"
    with tempfile.TemporaryDirectory() as cache:
        env = {"NUMBA_CACHE_DIR": cache}
        first = float(child(warm, env))
        again = float(child(warm, env))
    return first, again, float(child(imp, {}))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3, help="alternations of compiled and numpy; best kept")
    ap.add_argument("--k", type=int, default=10, help="repetitions of the batched run (default 10)")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--quick", action="store_true", help="skip the numpy largest case and the memory measurement")
    ap.add_argument("--skip-compile", action="store_true",
                    help="skip the compile-time measurement (two fresh processes compiling every kernel)")
    args = ap.parse_args(argv)
    tune_allocator()
    n = FastSlamConfig().particles
    print(f"compiled twins vs numpy units: N = {n}; {describe()}")
    if not args.skip_compile:
        first, again, imp = compile_costs()
        print(f"compilation: first call with an empty cache {first:.2f} s, with the cache filled {again:.3f} s "
              f"(import of numba alone {imp:.2f} s)")
    twins.warm_up()
    fixed = generate_scenario(CaseSpec(FIXED_VALUES), rng=np.random.default_rng(args.seed))
    pairs = n * int(fixed.obs_offsets[-1])
    best = {name: (math.inf, math.inf) for name in PATHS}
    maps = {}
    for name, (jit, whole) in PATHS.items():  # untimed: each path's first calls
        timed(jit, fixed, args.seed, whole_step=whole)
    for _ in range(args.rounds):
        for name, (jit, whole) in PATHS.items():
            cpu, wall, ests = timed(jit, fixed, args.seed, whole_step=whole)
            best[name] = min(best[name], (cpu, wall))
            maps[name] = ests[0]
    same = all(estimates_identical(maps[name], maps["numpy"]) for name in PATHS)
    print(f"\nfixed case ({fixed.n_steps} steps, {pairs / n / fixed.n_steps:.1f} obs/step), one execution, best of "
          f"{args.rounds}; maps bit-identical: {same}")
    print(f"{'path':<12} {'cpu s':>8} {'wall s':>8} {'updates/s/core':>15} {'numpy / path':>13}")
    for name in PATHS:
        cpu, wall = best[name]
        print(f"{name:<12} {cpu:>8.3f} {wall:>8.3f} {pairs / cpu:>15.3g} {best['numpy'][0] / cpu:>12.2f}x")
    ratio = best["numpy"][0] / best["compiled"][0]
    print(f"speed-up (CPU): {ratio:.2f}x  (target >= 4x: {'met' if ratio >= 4 else 'MISSED'}; "
          f">= 20M updates/s/core: {'met' if pairs / best['compiled'][0] >= 2e7 else 'MISSED'})")

    batch = min(timed(True, fixed, args.seed, args.k)[:2] for _ in range(max(1, args.rounds - 1)))
    print(f"\nK = {args.k} batched, fixed case, compiled: {batch[0]:.3f} CPU s per repetition "
          f"({pairs / batch[0]:.3g} updates/s/core); K = 1 compiled / K = {args.k} per repetition: "
          f"{best['compiled'][0] / batch[0]:.2f}x")

    big = generate_scenario(CaseSpec(LARGEST), rng=np.random.default_rng(args.seed))
    big_pairs = n * int(big.obs_offsets[-1])
    cpu, wall, ests = timed(True, big, args.seed)
    print(f"\nlargest case ({big.n_steps} steps, {big.obs_offsets[-1]} observations), compiled: {cpu:.2f} CPU s, "
          f"{wall:.2f} wall s, {big_pairs / cpu:.3g} updates/s/core (target <= 2 s, CPU: {'met' if cpu <= 2 else 'MISSED'})")
    if not args.quick:
        cpu_n, wall_n, ests_n = timed(False, big, args.seed)
        print(f"largest case, numpy: {cpu_n:.2f} CPU s, {wall_n:.2f} wall s; speed-up (CPU) {cpu_n / cpu:.2f}x; "
              f"maps bit-identical: {estimates_identical(ests[0], ests_n[0])}")
        peak = peak_memory(args.k, args.seed)
        print(f"peak memory, largest case, K = {args.k}, compiled: {peak:.2f} GiB max RSS "
              f"(target <= 1 GiB: {'met' if peak <= 1 else 'MISSED'})")
    print(f"\nload average after: {load()}; this process's max RSS "
          f"{resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 2 ** 20:.2f} GiB")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
