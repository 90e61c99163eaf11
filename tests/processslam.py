"""The example C SLAM of ``examples/process-slam``, compiled once per test session with the system compiler.

Import the ``example_slam`` fixture into a test module; it skips (with the reason) where no C
compiler exists.
"""

import shutil
import subprocess
from pathlib import Path

import pytest

SOURCE = Path(__file__).resolve().parents[1] / "examples" / "process-slam" / "example_slam.c"


def c_compiler() -> str | None:
    """The system C compiler (``cc``, else ``gcc``), or None."""
    return shutil.which("cc") or shutil.which("gcc")


@pytest.fixture(scope="session")
def example_slam(tmp_path_factory) -> Path:
    """Path of the compiled example SLAM."""
    cc = c_compiler()
    if cc is None:
        pytest.skip("no C compiler (cc or gcc) on PATH to build examples/process-slam/example_slam.c")
    out = tmp_path_factory.mktemp("example-slam") / "example_slam"
    done = subprocess.run([cc, "-O2", "-std=c99", "-Wall", "-o", str(out), str(SOURCE), "-lm"],
                          capture_output=True, text=True)
    if done.returncode != 0:
        pytest.fail(f"{cc} could not build {SOURCE.name}:\n{done.stderr}")
    return out
