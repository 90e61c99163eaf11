"""faultlab: coverage-driven testing of SLAM algorithms with injected faults.

Reproduces and extends Tasche & Herber, "A Coverage-Driven Systematic Test
Approach for Simultaneous Localization and Mapping".
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("faultlab")
except PackageNotFoundError:  # running from a source tree without install
    __version__ = "0.0.0+unknown"

from faultlab import errors  # noqa: E402
from faultlab.errors import *  # noqa: E402, F403 -- the exception hierarchy is part of the top-level API

__all__ = ["__version__", *errors.__all__]
