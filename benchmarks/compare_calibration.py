"""How often ``faultlab compare`` is right: a stochastic SLAM against itself and against a planted degradation.

    python benchmarks/compare_calibration.py [RUNS [K [self]]]   # a Markdown table, with the CPU model and load

Each seeded run draws its own pairwise suite over the small space (``tests/oracles/small_space.toml``,
20 cases of 60 active steps) and records FastSLAM 1.0 with 20 particles (``tests/campaigns/compare_slams.py``)
as the baseline, K repetitions per case (default 8, compare's default).  Two candidates run with repetition seeds independent of the
baseline's: the same SLAM (the verdict should be "no regression" and "equivalent within the default delta")
and the same SLAM behind a wrapper whose range sensor reads 3 % long (a planted degradation; the verdict
should be "regression").  The planted effect's size is estimated from every case of every run together.
Not a test (``tests/campaigns/test_compare_calibration.py`` is the slow test that can fail).
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy.stats import binomtest

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "benchmarks")]

from machine import describe  # noqa: E402

from faultlab.analysis.compare import DEFAULT_DELTA, compare_records  # noqa: E402
from faultlab.campaigns.compare import RecordSpec, candidate_spec, record  # noqa: E402
from faultlab.config import read_toml  # noqa: E402
from faultlab.inference.equivalence import percent  # noqa: E402

SLAMS = ROOT / "tests" / "campaigns"
SPACE = read_toml(ROOT / "tests" / "oracles" / "small_space.toml", what="space")[0]


def one_run(seed: int, work: Path, k: int, candidates: tuple[str, ...]):
    base = RecordSpec(slam="compare_slams:fastslam20", suite="pairwise", n_steps=60, seed=seed, repetitions=k,
                      paths=(str(SLAMS),), space=SPACE)
    b = record(base, work / f"b{seed}")
    out = {}
    for name, slam, offset in (("self", "compare_slams:fastslam20", 100_000),
                               ("degraded", "compare_slams:miscalibrated", 200_000),
                               ("slightly", "compare_slams:slightly_miscalibrated", 300_000)):
        if name not in candidates:
            continue
        spec = candidate_spec(base, slam=slam, rep_seed=seed + offset)
        c = record(spec, work / f"{name}{seed}")
        out[name] = compare_records(base.to_dict(), b, spec.to_dict(), c, delta=DEFAULT_DELTA)
    return out


def main() -> None:
    runs = int(sys.argv[1]) if len(sys.argv) > 1 else 100
    k = int(sys.argv[2]) if len(sys.argv) > 2 else 8
    candidates = tuple(sys.argv[3:]) or ("self", "degraded")
    print(f"Machine: {describe()}; K = {k}")
    t0 = time.perf_counter()
    results = []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(1, runs + 1):
            results.append(one_run(seed, Path(tmp), k, candidates))
    seconds = time.perf_counter() - t0
    have = set(candidates)

    def ci(k):
        c = binomtest(k, runs).proportion_ci(method="exact")
        return f"[{100 * c.low:.1f} %, {100 * c.high:.1f} %]"

    print(f"\n| candidate | runs | K | verdict wanted | runs with it | rate (95 % Clopper-Pearson) |")
    print("|---|---:|---:|---|---:|---|")
    if "self" in have:
        self_ok = sum((not r["self"].regression) and r["self"].equivalent for r in results)
        self_reg = sum(r["self"].regression for r in results)
        print(f"| the same SLAM, independent seeds | {runs} | {k} | no regression and equivalent within ±"
              f"{100 * DEFAULT_DELTA:g} % | {self_ok} | {100 * self_ok / runs:.1f} % {ci(self_ok)} |")
        print(f"| the same SLAM, independent seeds | {runs} | {k} | regression (a false alarm) | {self_reg} | "
              f"{100 * self_reg / runs:.1f} % {ci(self_reg)} |")
    for name, what in (("degraded", "range sensor 3 % long"), ("slightly", "range sensor 2 % long")):
        if name not in have:
            continue
        power = sum(r[name].regression for r in results)
        effects = np.concatenate([[np.log(c.candidate_mm / c.baseline_mm) for c in r[name].cases] for r in results])
        se = effects.std(ddof=1) / np.sqrt(effects.size)
        print(f"| {what} | {runs} | {k} | regression (power) | {power} | {100 * power / runs:.1f} % {ci(power)} |")
        print(f"\n{what}: mean log error ratio over {effects.size} cases {effects.mean():.4f} "
              f"(a {percent(effects.mean()):+.1f} % change; 95 % t interval {percent(effects.mean() - 1.96 * se):+.1f} "
              f"% to {percent(effects.mean() + 1.96 * se):+.1f} %).\n")
    print(f"Cost: {seconds:.0f} s for {runs} runs ({seconds / runs:.1f} s per run of three records of 20 cases).")


if __name__ == "__main__":
    main()
