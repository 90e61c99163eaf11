"""Throwaway installed distributions for the plugin tests: real ``*.dist-info`` entry-point metadata.

The ``site`` fixture (``tests/conftest.py``) gives the directory to write them into.
"""

import textwrap
from pathlib import Path


def make_distribution(site: Path, dist: str, group: str, entry_points: dict[str, str], modules: dict[str, str],
                      *, version: str = "1.0") -> None:
    """Write a minimal installed distribution (``*.dist-info``) declaring ``entry_points`` in ``group``,
    plus its modules (name -> source), into ``site``."""
    info = site / f"{dist.replace('-', '_')}-{version}.dist-info"
    info.mkdir(parents=True)
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: {version}\n")
    lines = [f"[{group}]"] + [f"{k} = {v}" for k, v in entry_points.items()]
    (info / "entry_points.txt").write_text("\n".join(lines) + "\n")
    for mod, source in modules.items():
        (site / f"{mod}.py").write_text(textwrap.dedent(source))
