"""Speed of the vectorised reference FastSLAM 1.0 (a benchmark, not a test).

Run ``python benchmarks/bench_fastslam.py`` from the repository root.  Prints
one table row per run: wall time, steps/s and particle-observation updates/s
(N particles x observations processed, per second), for

* the fixed-suite case (``FIXED_VALUES``, 1000 steps);
* the largest Table I case (20 m side, 15 landmarks/m^2, FoV 2 pi, 1000 active
  steps + 2000 inactivity steps) with the reference (low-variance resampling
  when N_eff < N / 1.5) and with a resample-every-step variant (multinomial
  resampling at every update, empty ones included: ``resample`` replaced);
* the per-particle loop oracle of ``tests/slam/oracle.py`` on the first steps
  of the fixed case (it is far too slow for the full trace), compared with the
  vectorised filter on the same truncated trace; the full-trace oracle time is
  extrapolated linearly and marked as such.

Targets: fixed case < 1 s; largest case < 15 s with either
resampler; vectorised >= 100x faster than the per-particle loop.
The compiled kernels are loaded (:func:`faultlab.slam.twins.warm_up`) and every
row's case run once before it is timed, so no row includes a first call; rates
are per CPU second (``time.process_time``, the best of ``--repeat`` runs).  The
CPU model and the load average are printed with the table.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))  # for tests.slam.oracle
sys.path.insert(0, str(Path(__file__).resolve().parent))

from machine import describe  # noqa: E402

from faultlab.scenario import generate_scenario  # noqa: E402
from faultlab.slam import REFERENCE_STEPS, FastSlam, FastSlamConfig, run_slam, twins  # noqa: E402
from faultlab.space.case import FIXED_VALUES, CaseSpec  # noqa: E402
from tests.slam.oracle import OracleFastSlam, run_oracle  # noqa: E402

LARGEST = dict(FIXED_VALUES, map_size=400.0, landmark_density=15.0, field_of_view=2 * math.pi, inactivity=2000)


def multinomial_every_step(w, n_eff, empty, rng, config):
    """Resample-every-step variant: multinomial draw at every update, no N_eff test."""
    return np.minimum(np.searchsorted(np.cumsum(w), rng.random(w.size)), w.size - 1)


def truncated(scenario, n_steps):
    """The first ``n_steps`` steps of ``scenario``."""
    m = int(scenario.obs_offsets[n_steps])
    return dataclasses.replace(
        scenario, true_poses=scenario.true_poses[: n_steps + 1], controls=scenario.controls[:n_steps],
        obs_offsets=scenario.obs_offsets[: n_steps + 1], obs_range=scenario.obs_range[:m],
        obs_bearing=scenario.obs_bearing[:m], obs_ids=scenario.obs_ids[:m])


def time_run(make, scenario, *, seed, repeat):
    """Best (wall, cpu) seconds of ``repeat`` runs of ``run_slam``, after one untimed run."""
    run_slam(make(), scenario, rng=np.random.default_rng(seed))
    best = (math.inf, math.inf)
    for _ in range(repeat):
        slam = make()
        t0, c0 = time.perf_counter(), time.process_time()
        run_slam(slam, scenario, rng=np.random.default_rng(seed))
        best = min(best, (time.perf_counter() - t0, time.process_time() - c0), key=lambda wc: wc[1])
    return best


def time_oracle(scenario, *, seed, particles):
    oracle = OracleFastSlam(particles=particles)
    t0, c0 = time.perf_counter(), time.process_time()
    run_oracle(oracle, scenario, rng=np.random.default_rng(seed))
    return time.perf_counter() - t0, time.process_time() - c0


def row(name, seconds, scenario, particles, note=""):
    wall, cpu = seconds
    steps = scenario.n_steps
    updates = particles * int(scenario.obs_offsets[-1])
    return (name, steps, int(scenario.obs_offsets[-1]), wall, cpu, steps / cpu, updates / cpu, note)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1, help="scenario and SLAM seed")
    ap.add_argument("--repeat", type=int, default=3, help="best of this many runs per vectorised row")
    ap.add_argument("--oracle-steps", type=int, default=20, help="steps of the fixed case run by the oracle")
    args = ap.parse_args(argv)
    n = FastSlamConfig().particles
    twins.warm_up()
    fixed = generate_scenario(CaseSpec(FIXED_VALUES), rng=np.random.default_rng(args.seed))
    largest = generate_scenario(CaseSpec(LARGEST), rng=np.random.default_rng(args.seed))
    every = dataclasses.replace(REFERENCE_STEPS, resample=multinomial_every_step)
    rows = []
    t_fixed = time_run(FastSlam, fixed, seed=args.seed, repeat=args.repeat)
    rows.append(row("fixed case, reference", t_fixed, fixed, n))
    t_big = time_run(FastSlam, largest, seed=args.seed, repeat=args.repeat)
    rows.append(row("largest case, reference", t_big, largest, n))
    t_big_every = time_run(lambda: FastSlam(steps=every), largest, seed=args.seed, repeat=args.repeat)
    rows.append(row("largest case, resample every step", t_big_every, largest, n))
    short = truncated(fixed, args.oracle_steps)
    t_short = time_run(FastSlam, short, seed=args.seed, repeat=max(3, args.repeat))
    rows.append(row(f"fixed case, first {short.n_steps} steps, reference", t_short, short, n))
    t_oracle = time_oracle(short, seed=args.seed, particles=n)
    rows.append(row(f"fixed case, first {short.n_steps} steps, per-particle oracle", t_oracle, short, n))
    scale = fixed.n_steps / short.n_steps
    t_oracle_full = (t_oracle[0] * scale, t_oracle[1] * scale)
    rows.append(row("fixed case, per-particle oracle (extrapolated)", t_oracle_full, fixed, n,
                    f"= {t_oracle[0]:.2f} s x {fixed.n_steps}/{short.n_steps}"))

    print(f"FastSLAM 1.0 benchmark: N = {n} particles, seed {args.seed}; {describe()}")
    print("(updates = particle-observation pairs processed; wall and CPU time of run_slam, input "
          "validation included; rates per CPU second)")
    head = ("run", "steps", "obs", "wall s", "cpu s", "steps/cpu s", "updates/cpu s", "")
    print(f"{head[0]:<52} {head[1]:>6} {head[2]:>7} {head[3]:>8} {head[4]:>8} {head[5]:>11} {head[6]:>13}")
    for name, steps, obs, wall, cpu, sps, ups, note in rows:
        print(f"{name:<52} {steps:>6} {obs:>7} {wall:>8.3f} {cpu:>8.3f} {sps:>11.0f} {ups:>13.3g}  {note}")
    print(f"load average after: {describe().rsplit('load average ', 1)[1]}")
    ratio = t_oracle[0] / t_short[0]
    print(f"speed-up over the per-particle loop (same {short.n_steps} steps, wall): {ratio:.0f}x; "
          f"extrapolated full oracle vs full vectorised run: {t_oracle_full[0] / t_fixed[0]:.0f}x")
    checks = [("fixed case < 1 s", t_fixed[0] < 1.0), ("largest case < 15 s (reference)", t_big[0] < 15.0),
              ("largest case < 15 s (resample every step)", t_big_every[0] < 15.0),
              (">= 100x faster than the per-particle loop", ratio >= 100.0)]
    for what, ok in checks:
        print(f"  {'met    ' if ok else 'MISSED '} {what}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
