"""Exception hierarchy of faultlab.

Every error faultlab raises on purpose derives from :class:`FaultlabError`, so a
caller can catch one class.  Messages name *what* is wrong and *where* (file,
key, step, landmark id) in one sentence.
"""

from __future__ import annotations

import difflib
from collections.abc import Iterable

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
    "UnknownPluginError",
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


class UnknownPluginError(ConfigError, FaultError):
    """A name no built-in or installed plugin of its kind has: a SLAM, a suite strategy, a fault, a sensor
    fault, a mutation operator, a metamorphic relation or an oracle.

    One type for every kind of :class:`faultlab.plugins.PluginCatalogue`; a :class:`ConfigError` (a
    setting names it) and a :class:`FaultError` (a fault or mutant names it), so either catches it.
    The command line prints it as one line and exits with 2.

    Parameters
    ----------
    kind : str
        What was looked up (``"SLAM"``, ``"suite strategy"``, ``"mutation operator"``, ...).
    name : str
        The unknown name.
    known : iterable of str
        Every known name of the kind, in the catalogue's order; the closest are suggested first.
    where : str, optional
        The setting that named it (``"exp.toml: slam.name"``), prefixed to the message.
    note : str
        Appended to the message (e.g. the plugins of the kind that failed to load).
    """

    def __init__(self, kind: str, name: object, known: Iterable[str], where: str | None = None, note: str = ""):
        self.kind, self.name, self.known, self.where, self.note = kind, name, tuple(known), where, note
        close = difflib.get_close_matches(str(name), list(self.known), n=3, cutoff=0.6)
        last = kind.split()[-1]
        plural = last[:-1] + "ies" if last.endswith("y") else last + "s"
        message = (f"unknown {kind} {name!r}" + (f"; did you mean {' or '.join(map(repr, close))}?" if close else ".")
                   + f" Known {plural}: {', '.join(self.known) or 'none'}{note}")
        super().__init__(f"{where}: {message}" if where else message)

    def __reduce__(self):  # rebuilt from its fields (a worker process raises it to the parent)
        return type(self), (self.kind, self.name, self.known, self.where, self.note)


class ResultsError(FaultlabError):
    """A results store is missing, corrupt, or belongs to another experiment."""
