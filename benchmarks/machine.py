"""The machine a benchmark ran on: CPU model, cores and load average, printed with every figure."""

from __future__ import annotations

import os
import platform


def cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo``, else :func:`platform.processor`)."""
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as fh:
            for line in fh:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or "unknown CPU"


def load() -> str:
    """The 1-, 5- and 15-minute load averages."""
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def describe() -> str:
    """One line: CPU model, logical CPUs and the load average now."""
    return f"{cpu_model()}, {os.cpu_count()} logical CPUs, load average {load()}"
