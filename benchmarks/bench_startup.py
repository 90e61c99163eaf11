"""A newcomer's first hour: CPU time of ``faultlab --version`` and ``faultlab --help``, and the wall time of
``faultlab run smoke`` (target: <= 0.5 s CPU for the first two, <= 20 s wall for smoke on 2 idle cores).

    python benchmarks/bench_startup.py                 # --version and --help, 5 runs each
    python benchmarks/bench_startup.py --smoke         # and one run smoke into a temporary directory

Each command runs in a child process; its CPU time (user + system) comes from ``resource.getrusage``
of the children, so the interpreter's own start is included, as a user sees it.  Printed with the CPU
model and the load average before and after: timings on a shared machine are noisy.  Not a test.
"""

from __future__ import annotations

import argparse
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def _cpu_model() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown"


def timed(command: list[str]) -> tuple[float, float]:
    """(CPU s, wall s) of one run of ``command`` in a child process."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    start = time.perf_counter()
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    wall = time.perf_counter() - start
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime), wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeat", type=int, default=5)
    parser.add_argument("--smoke", action="store_true", help="also time faultlab run smoke (once)")
    args = parser.parse_args()
    faultlab = [sys.executable, "-m", "faultlab"]
    print(f"CPU: {_cpu_model()}, {os.cpu_count()} cores; load average {os.getloadavg()[0]:.2f} (start)")
    for flag, target in (("--version", 0.5), ("--help", 0.5)):
        runs = [timed([*faultlab, flag]) for _ in range(args.repeat)]
        cpu = sorted(c for c, _ in runs)
        print(f"faultlab {flag}: CPU median {cpu[len(cpu) // 2]:.3f} s (min {cpu[0]:.3f}, max {cpu[-1]:.3f}) "
              f"over {args.repeat} runs; target <= {target} s: {'met' if cpu[len(cpu) // 2] <= target else 'NOT met'}")
    if args.smoke:
        with tempfile.TemporaryDirectory() as tmp:
            cpu, wall = timed([*faultlab, "run", "smoke", "--out", str(Path(tmp) / "smoke"), "--no-progress"])
        print(f"faultlab run smoke: {wall:.1f} s wall, {cpu:.1f} s CPU (workers included); target <= 20 s wall "
              f"on 2 idle cores: {'met' if wall <= 20 else 'NOT met'} (at this load)")
    print(f"load average {os.getloadavg()[0]:.2f} (end)")


if __name__ == "__main__":
    main()
