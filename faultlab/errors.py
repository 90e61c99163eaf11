"""Exception hierarchy of faultlab.

Every error faultlab raises on purpose derives from :class:`FaultlabError`, so a
caller can catch one class.  Messages name *what* is wrong and *where* (file,
key, step, landmark id) in one sentence.
"""

from __future__ import annotations

__all__ = [
    "FaultlabError",
    "ConfigError",
    "ScenarioError",
    "NoGroundTruthError",
    "InvalidCaseError",
    "SlamInputError",
    "SlamOutputError",
    "SlamProcessError",
    "FaultError",
    "PluginError",
    "ResultsError",
]


class FaultlabError(Exception):
    """Root of every error raised by faultlab."""


class ConfigError(FaultlabError, ValueError):
    """A parameter-space or experiment file (or dict) is malformed.

    Raised before any work starts; the message names the file and the key.
    """


class ScenarioError(FaultlabError, ValueError):
    """A test case cannot be generated, saved or loaded."""


class NoGroundTruthError(ScenarioError):
    """A metric or oracle that needs the ground truth was asked about a scenario without one (a real data set)."""


class InvalidCaseError(ScenarioError):
    """A saved test case whose files are intact (checksums match) but whose content is not a valid case."""


class SlamInputError(FaultlabError, ValueError):
    """Input a SLAM cannot accept: wrong shape, NaN, negative range, ..."""


class SlamOutputError(FaultlabError, ValueError):
    """A SLAM returned an estimate that is malformed or not finite."""


class SlamProcessError(SlamOutputError):
    """A SLAM run as a child process broke its protocol, timed out or died.

    Attributes
    ----------
    rule : str or None
        The protocol rule it broke (:data:`faultlab.slam.process.RULES`), if one.
    detail : str
        What happened, without the program's name, status and stderr.
    """

    def __init__(self, message: str, *, rule: str | None = None, detail: str | None = None):
        super().__init__(message)
        self.rule = rule
        self.detail = message if detail is None else detail


class FaultError(FaultlabError, LookupError):
    """Unknown fault name, or a fault that cannot be applied."""


class PluginError(FaultlabError):
    """A third-party fault plugin failed to load (its name and error are in the message)."""


class ResultsError(FaultlabError):
    """A results store is missing, corrupt, or belongs to another experiment."""
