"""Speed of the SLAMs under test side by side: FastSLAM 1.0, FastSLAM 2.0 and EKF-SLAM (not a test).

With ``--unknown`` the unknown-data-association FastSLAMs run too (ids hidden, every particle
associates by maximum likelihood; their map error is the EMD, in the RMS column marked ``*``);
their cost grows with the landmarks near the particle, so use ``--steps`` and ``--particles`` to
keep the run short.

Run ``python benchmarks/bench_suts.py`` from the repository root.  In one process it runs the
three SLAMs on

* the fixed-suite case (``FIXED_VALUES``: 8 m map side, 5 landmarks/m^2 = 320 landmarks,
  1000 steps, ~29 observations per step);
* a small map (the fixed case with a 4 m side: 80 landmarks, 1000 steps);

in round-robin order (so a change in machine load hits all three alike), ``--repeat`` times, and
prints per SLAM and case the best and median wall time, CPU time, observations processed per second,
filter updates per second (particle-observation pairs for the particle filters, observations for
EKF-SLAM), the Kabsch-aligned map RMS and the wall-time and CPU-time ratios to FastSLAM 1.0 (on a
busy machine the CPU ratio is the steadier one).  The machine's load average is printed before and
after, and the BLAS thread setting (EKF-SLAM limits BLAS to one thread during its updates itself).
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import time

import numpy as np
from threadpoolctl import threadpool_info

from faultlab.metrics import map_errors
from faultlab.scenario import generate_scenario
from faultlab.slam import EkfSlam, FastSlam, FastSlam2, FastSlamConfig, run_slam
from faultlab.slam.association import FastSlam2Unknown, FastSlamUnknown
from faultlab.space import FIXED_VALUES, CaseSpec

CASES = {
    "fixed case (320 landmarks)": FIXED_VALUES,
    "small map (80 landmarks)": dict(FIXED_VALUES, map_size=16.0),
}


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1, help="scenario and SLAM seed")
    ap.add_argument("--repeat", type=int, default=3, help="round-robin repetitions per case")
    ap.add_argument("--particles", type=int, default=FastSlamConfig().particles)
    ap.add_argument("--steps", type=int, default=None, help="active steps per case (default: the generator's)")
    ap.add_argument("--unknown", action="store_true", help="also the unknown-association FastSLAMs")
    args = ap.parse_args(argv)
    cfg = FastSlamConfig(particles=args.particles)
    suts = {"FastSLAM 1.0": lambda: FastSlam(cfg), "FastSLAM 2.0": lambda: FastSlam2(cfg), "EKF-SLAM": EkfSlam}
    if args.unknown:
        ucfg = FastSlamConfig(particles=args.particles, association="unknown")
        suts.update({"FS1.0 unknown": lambda: FastSlamUnknown(ucfg), "FS2.0 unknown": lambda: FastSlam2Unknown(ucfg)})
    blas = ", ".join(f"{i['internal_api']} {i['num_threads']} threads" for i in threadpool_info()
                     if i["user_api"] == "blas")
    print(f"SLAMs under test side by side: N = {cfg.particles} particles, seed {args.seed}, best of "
          f"{args.repeat} round-robin runs, {os.cpu_count()} CPUs, BLAS: {blas}")
    print(f"load average before: {load()}")
    head = f"{'case':<28} {'SLAM':<13} {'best s':>7} {'median s':>8} {'cpu s':>7} {'obs/s':>8} " \
           f"{'updates/s':>10} {'RMS mm':>7} {'x FS1':>6} {'cpu x FS1':>9}"  # updates: particle-observation pairs
    rows = []
    for case_name, values in CASES.items():
        kw = {} if args.steps is None else {"n_steps": args.steps}
        sc = generate_scenario(CaseSpec(values), rng=np.random.default_rng(args.seed), **kw)
        n_obs = int(sc.obs_offsets[-1])
        times = {name: [] for name in suts}
        cpu = {name: math.inf for name in suts}
        rms = {}
        for _ in range(args.repeat):
            for name, make in suts.items():
                slam = make()
                t0, c0 = time.perf_counter(), time.process_time()
                est = run_slam(slam, sc, rng=np.random.default_rng(args.seed))
                times[name].append(time.perf_counter() - t0)
                cpu[name] = min(cpu[name], time.process_time() - c0)
                if getattr(slam, "association", "known") == "unknown":
                    rms[name] = map_errors(sc, est, association="unknown").emd_mm
                else:
                    rms[name] = map_errors(sc, est, metrics=("rms",)).rms_mm
        base, cpu_base = min(times["FastSLAM 1.0"]), cpu["FastSLAM 1.0"]
        for name in suts:
            best = min(times[name])
            per_obs = 1 if name == "EKF-SLAM" else cfg.particles
            rows.append(f"{case_name:<28} {name:<13} {best:>7.3f} {statistics.median(times[name]):>8.3f} "
                        f"{cpu[name]:>7.3f} {n_obs / best:>8.3g} {per_obs * n_obs / best:>10.3g} "
                        f"{rms[name]:>7.1f}{'*' if 'unknown' in name else ' '}{best / base:>6.2f} "
                        f"{cpu[name] / cpu_base:>9.2f}")
        rows.append(f"{'':<28} ({sc.n_steps} steps, {n_obs} observations, "
                    f"{len(sc.landmark_ids)} landmarks)")
    print(head)
    for r in rows:
        print(r)
    print(f"load average after: {load()}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
