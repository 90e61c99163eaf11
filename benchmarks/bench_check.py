"""Cost of ``faultlab check``: SLAM executions per case (the K runs, the metamorphic follow-ups, dead
reckoning, the reference) and, per failure, the executions and seconds shrinking takes.

    python benchmarks/bench_check.py            # prints a Markdown table, with the CPU model and load

Cases of the pairwise suite over a small space (``tests/oracles/small_space.toml``, 200 active steps);
the planted bugs are the test suite's black-box SLAMs (``tests/oracles/blackbox.py``).  Not a test.
"""

from __future__ import annotations

import functools
import os
import platform
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from faultlab.campaigns.checkshrink import reduce_failure  # noqa: E402
from faultlab.campaigns.checkspec import CheckSpec, judge_scenario  # noqa: E402
from faultlab.config import read_toml  # noqa: E402
from faultlab.scenario.suite import draw_suite, generate_case  # noqa: E402
from faultlab.space.parameters import space_from_mapping  # noqa: E402


def _cpu() -> str:
    for line in Path("/proc/cpuinfo").read_text().splitlines():
        if line.startswith("model name"):
            return line.split(":", 1)[1].strip()
    return platform.processor()


def main() -> None:
    space = space_from_mapping(read_toml(ROOT / "tests/oracles/small_space.toml", what="space")[0], source="small")
    cases = draw_suite("pairwise", space, root_seed=1)[:3]
    scenarios = [(f"pairwise-1-{c.case:03d}", generate_case(c, n_steps=200)) for c in cases]
    print(f"CPU {_cpu()}; load before {os.getloadavg()[0]:.1f}")
    print("\n| SLAM under test | kind | executions per case | seconds per case |\n|---|---|---:|---:|")
    for label, spec in [("ekf", CheckSpec(slam="ekf")),
                        ("fastslam (30 particles), K = 8", CheckSpec(slam="fastslam", slam_options={"particles": 30}))]:
        t, n, kind = time.perf_counter(), 0, ""
        for case_id, s in scenarios:
            j = judge_scenario(spec, case_id, s)
            n += j.executions
            kind = "deterministic" if j.deterministic else "stochastic"
        print(f"| {label} | {kind} | {n / len(scenarios):.1f} | {(time.perf_counter() - t) / len(scenarios):.1f} |")
    print("\n| planted bug | oracle | original -> minimal (steps, landmarks) | reduction tests | executions | seconds |"
          "\n|---|---|---|---:|---:|---:|")
    import tempfile
    for bug, oracle in [("ekf_wrap", "metamorphic"), ("ekf_jacobian", "differential"), ("ekf_symmetry", "execution"),
                        ("mapper_off_by_one", "metamorphic")]:
        spec = CheckSpec(slam=f"tests.oracles.blackbox:{bug}", oracles=(oracle,), paths=(str(ROOT),))
        case_id, s = scenarios[0]
        j = judge_scenario(spec, case_id, s)
        t = time.perf_counter()
        with tempfile.TemporaryDirectory() as out:
            import faultlab.oracles.oracle as oracle_module
            count = [0]
            real = oracle_module.execute

            def counted(*a, **k):
                count[0] += 1
                return real(*a, **k)
            oracle_module.execute = counted
            try:
                red = reduce_failure(spec, case_id, s, j, Path(out))[oracle]
            finally:
                oracle_module.execute = real
        o, m = red["original"], red["minimal"]
        print(f"| {bug} | {oracle} | {o['steps']}, {o['landmarks']} -> {m['steps']}, {m['landmarks']} | {red['tests']} "
              f"| {count[0]} | {time.perf_counter() - t:.1f} |")
    print(f"\nload after {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
