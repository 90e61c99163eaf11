"""Wall time of the scenario generator on the largest Table I case (target: < 5 s).

    python benchmarks/bench_generator.py [--repeat 3]

The case: 20 m side (400 m^2), 15 landmarks/m^2 (6000 landmarks), FoV 2 pi (every landmark in range
is visible), smallest step (25 cm, most observations per landmark), 1000 active steps + 2000 idle
steps, 90 % symmetry, all noise at the top of Table I.  Also times a whole systematic suite.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

from faultlab.scenario import generate_scenario
from faultlab.space import FIXED_VALUES, CaseSpec, build_suite, table1_space


def largest_case() -> CaseSpec:
    return CaseSpec(dict(FIXED_VALUES, map_size=400.0, landmark_density=15.0, field_of_view=2 * math.pi,
                         step_size=25.0, inactivity=2000, symmetry=90.0, outlier_probability=15.0,
                         variance_distance=100.0, variance_angle=0.2, bias_distance=25.0, bias_angle=0.05,
                         rotation_error=2 * math.pi, directionality="loop"))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    case = largest_case()
    times = []
    for seed in range(args.repeat):
        t0 = time.perf_counter()
        sc = generate_scenario(case, rng=np.random.default_rng(seed))
        times.append(time.perf_counter() - t0)
    print(f"largest Table I case: {sc.landmarks.shape[0]} landmarks, {sc.n_steps} steps, "
          f"{sc.obs_range.size} observations")
    print(f"  wall time per case: best {min(times):.3f} s, worst {max(times):.3f} s "
          f"(limit 5 s) over {args.repeat} runs")
    t0 = time.perf_counter()
    cases = build_suite("systematic", table1_space(), rng=np.random.default_rng(0))
    for i, c in enumerate(cases):
        generate_scenario(c, rng=np.random.default_rng(i))
    print(f"systematic suite (5 cases, 1000 steps): {time.perf_counter() - t0:.3f} s")


if __name__ == "__main__":
    main()
