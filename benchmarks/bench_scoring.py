"""Cost of scoring a SLAM execution (``map_errors``: Kabsch RMS + earth mover's distance), old vs new.

    python benchmarks/bench_scoring.py                  # Table I map-size x density corners
    python benchmarks/bench_scoring.py --json out.json
    python benchmarks/bench_scoring.py --sizes 400 --skip-old   # the largest maps, current scoring only

For each Table I corner (map size 4 / 16 / 100 / 400 m^2 x landmark density 1 / 9 / 15 lm/m^2,
the other parameters at the fixed-suite values with a 2 pi field of view so that most landmarks
get mapped) one case is generated and the reference FastSLAM run once on it.  Its final map is
scored twice:

* **old**: the dense route every EMD took before (``transport._dense``: POT's network simplex on
  the full cost matrix) plus the Kabsch fit;
* **new**: :func:`faultlab.metrics.map_errors` as it is now (assignment for equal counts,
  certified sparse arc generation for large unequal ones);
* **rms only**: ``map_errors(..., metrics=("rms",))``, what a job of an experiment with
  ``metrics = ["rms"]`` computes (the Kabsch fit and counts; its RMS is checked bit-identical to
  the one computed with both metrics).

A second row per corner scores the same map with every tenth landmark dropped, so that the counts
differ and the unequal-count routes of the new code are timed too.  Printed: landmarks of the
truth / estimate, the execution's CPU time, the old and new scoring CPU time, each as a share of
(execution + scoring), and the relative difference of the EMD values (must be <= 1e-9).  The load
average is printed before and after: timings on a shared machine are noisy.  Not a test.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import numpy as np

from faultlab.metrics import map_errors
from faultlab.metrics.alignment import kabsch_rms
from faultlab.metrics.transport import _dense
from faultlab.scenario import generate_scenario
from faultlab.slam import Estimate, FastSlam, run_slam
from faultlab.space.case import FIXED_VALUES, CaseSpec

SIZES = (4.0, 16.0, 100.0, 400.0)
DENSITIES = (1.0, 9.0, 15.0)


def old_score(scenario, estimate) -> float:
    """The previous scoring: Kabsch fit, then the dense EMD of the aligned estimate, mm."""
    err = kabsch_rms(scenario.landmark_ids, scenario.landmarks, estimate.landmark_ids, estimate.landmarks)
    return _dense(np.asarray(scenario.landmarks, float), err.apply(estimate.landmarks)) * 1000.0


def cpu(fn, *args):
    t0 = time.process_time()
    value = fn(*args)
    return value, time.process_time() - t0


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--max-landmarks", type=int, default=7000, help="skip corners with more landmarks")
    ap.add_argument("--sizes", type=float, nargs="+", default=SIZES, metavar="M2", help="map sizes to run")
    ap.add_argument("--skip-old", action="store_true", help="do not time the old dense route (slow on large maps)")
    ap.add_argument("--json", help="also write the rows here")
    args = ap.parse_args(argv)
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}, {os.cpu_count()} CPUs")
    _dense(np.zeros((2, 2)), np.ones((3, 2)))  # import POT outside the timings
    rows = []
    for size in args.sizes:
        for density in DENSITIES:
            if size * density > args.max_landmarks:
                continue
            values = dict(FIXED_VALUES, map_size=size, landmark_density=density, field_of_view=2 * np.pi)
            sc = generate_scenario(CaseSpec(values), rng=np.random.default_rng(args.seed))
            est, t_exec = cpu(lambda: run_slam(FastSlam(), sc, rng=np.random.default_rng(args.seed)))
            keep = np.arange(len(est.landmark_ids)) % 10 != 9  # every tenth mapped landmark dropped
            part = Estimate(landmark_ids=np.asarray(est.landmark_ids)[keep],
                            landmarks=np.asarray(est.landmarks, float)[keep], pose=est.pose)
            for label, e in (("SLAM map", est), ("90 % of it", part)):
                old, t_old = (float("nan"), float("nan")) if args.skip_old else cpu(old_score, sc, e)
                both, t_new = cpu(lambda: map_errors(sc, e))
                new = both.emd_mm
                only, t_rms = cpu(lambda: map_errors(sc, e, metrics=("rms",)))
                if only.rms_mm != both.rms_mm:
                    raise AssertionError(f"rms only {only.rms_mm!r} != rms with both {both.rms_mm!r}")
                rel = abs(new - old) / abs(old) if old else abs(new - old)
                rows.append(dict(map_size=size, density=density, map=label, n_truth=len(sc.landmark_ids),
                                 n_est=len(e.landmark_ids), exec_s=t_exec, old_s=t_old, new_s=t_new,
                                 rms_s=t_rms, old_share=t_old / (t_exec + t_old), new_share=t_new / (t_exec + t_new),
                                 rms_share=t_rms / (t_exec + t_rms), rel_diff=rel))
                r = rows[-1]
                print(f"{size:>5.0f} m2 {density:>4.0f}/m2 {label:<10} truth {r['n_truth']:>5} est {r['n_est']:>5}  "
                      f"exec {t_exec:7.2f} s  old {t_old:7.3f} s ({100 * r['old_share']:5.1f} %)  "
                      f"new {t_new:7.3f} s ({100 * r['new_share']:5.1f} %)  "
                      f"rms only {t_rms:6.3f} s ({100 * r['rms_share']:5.2f} %)  rel diff {rel:.1e}", flush=True)
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print("(CPU seconds; share = scoring / (execution + scoring); '90 % of it' rows score the SLAM's map "
          "without every tenth landmark, against the same execution time)")
    worst = max(r["new_share"] for r in rows)
    diffs = [r["rel_diff"] for r in rows if not np.isnan(r["rel_diff"])]
    print(f"largest new share: {100 * worst:.1f} %; largest rms-only share: "
          f"{100 * max(r['rms_share'] for r in rows):.2f} %; largest relative EMD difference: "
          f"{f'{max(diffs):.1e}' if diffs else 'not measured (--skip-old)'}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
