"""faultlab: coverage-driven testing of SLAM algorithms with injected faults.

Reproduces and extends Tasche & Herber, "A Coverage-Driven Systematic Test
Approach for Simultaneous Localization and Mapping".
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("faultlab")
except PackageNotFoundError:  # running from a source tree without install
    __version__ = "0.0.0+unknown"

from faultlab.errors import (  # noqa: E402
    ConfigError,
    FaultError,
    FaultlabError,
    PluginError,
    ResultsError,
    ScenarioError,
    SlamInputError,
    SlamOutputError,
)

__all__ = [
    "__version__",
    "FaultlabError",
    "ConfigError",
    "ScenarioError",
    "SlamInputError",
    "SlamOutputError",
    "FaultError",
    "PluginError",
    "ResultsError",
]
