"""MRPT's CRangeBearingKFSLAM2D behind the process protocol (examples/mrpt-kfslam), built once per test session
with CMake.

Import the ``mrpt_kfslam`` fixture into a test module; it skips (with the reason) where CMake, a C++ compiler,
MRPT's development files (Debian: ``libmrpt-slam-dev``) or nlohmann/json (``nlohmann-json3-dev``) are missing.
"""

import shutil
import subprocess
from pathlib import Path

import pytest

SOURCE = Path(__file__).resolve().parents[1] / "examples" / "mrpt-kfslam"



@pytest.fixture(scope="session")
def mrpt_kfslam(tmp_path_factory) -> Path:
    """Path of the compiled front end."""
    cmake = shutil.which("cmake")
    if cmake is None or (shutil.which("c++") or shutil.which("g++")) is None:
        pytest.skip("no cmake or C++ compiler on PATH to build examples/mrpt-kfslam")
    build = tmp_path_factory.mktemp("mrpt-kfslam")
    done = subprocess.run([cmake, "-S", str(SOURCE), "-B", str(build), "-DCMAKE_BUILD_TYPE=Release"],
                          capture_output=True, text=True)
    if done.returncode != 0:
        if "mrpt-slam" in done.stderr or "nlohmann_json" in done.stderr:
            pytest.skip("MRPT or nlohmann/json development files are missing (Debian: apt-get install "
                        "libmrpt-slam-dev nlohmann-json3-dev)")
        pytest.fail(f"cmake could not configure {SOURCE}:\n{done.stderr}")
    done = subprocess.run([cmake, "--build", str(build)], capture_output=True, text=True)
    if done.returncode != 0:
        pytest.fail(f"could not build {SOURCE}:\n{done.stdout[-3000:]}{done.stderr[-3000:]}")
    return build / "mrpt_kfslam"
