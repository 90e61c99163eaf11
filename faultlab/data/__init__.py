"""Files shipped inside the faultlab package: experiments and the paper's own data.

The package carries the one canonical copy of

* the shipped experiment files (``experiments/<name>.toml``): ``paper`` (the paper's
  protocol, Sec. VII), ``paper-k10`` (the same with K = 10 repetitions, the statistical
  detection rule and the A/A replica), ``smoke`` (a campaign of seconds), ``slams`` (the
  cross-SLAM protocol at reduced scale, run once per SLAM by ``faultlab slams run``),
  ``space_table1`` (Table I written out in the parameter-space override format), ``mutation``
  (the mutation study) and ``study`` (the test-design strategies study, ``faultlab study``);
* the paper's replication data (``paper/``): the raw RMS errors behind Table II
  (``paper_table2_rms.csv``) and its printed "Detected Faults" percentages
  (``paper_table2_reported.csv``).

They are read with :mod:`importlib.resources`, so they are found wherever faultlab is
installed (a wheel, an editable install, a source tree on ``PYTHONPATH``), whatever the
working directory.  In the source repository the top-level ``experiments/*.toml`` and
``paper_repro/*.csv`` are symbolic links to these files, so the paths printed in the
README keep working there.

Every command that takes an experiment or a parameter-space file accepts a shipped name
(``paper``) as well as a path (``experiments/paper.toml``, ``my/campaign.toml``):
:func:`resolve_experiment` decides which one is meant.

>>> from faultlab.data import experiment_names, resolve_experiment
>>> experiment_names()
('mutation', 'paper-k10', 'paper', 'slams', 'smoke', 'space_table1', 'study')
>>> resolve_experiment("paper").name
'paper.toml'

This module belongs to the computation layer: it imports only the standard library and
:mod:`faultlab.errors`.
"""

from __future__ import annotations

import atexit
import contextlib
from importlib import resources
from pathlib import Path, PurePosixPath

from faultlab.errors import ConfigError

__all__ = [
    "EXPERIMENTS_DIR",
    "PAPER_DIR",
    "PAPER_RAW",
    "PAPER_REPORTED",
    "REPOSITORY_DIRS",
    "experiment_names",
    "experiment_file",
    "resolve_experiment",
    "paper_file",
    "paper_files",
    "shipped_file",
]

#: Folder of the shipped experiment files inside the package.
EXPERIMENTS_DIR = "experiments"
#: Folder of the paper's replication data inside the package.
PAPER_DIR = "paper"
#: File name of the paper's raw RMS data behind Table II (``suite, variant, run, case, rms_mm``).
PAPER_RAW = "paper_table2_rms.csv"
#: File name of Table II's printed percentages (``suite, variant, detected_pct``).
PAPER_REPORTED = "paper_table2_reported.csv"
#: Top-level folder of the source repository -> package folder holding the same files.
REPOSITORY_DIRS: dict[str, str] = {"experiments": EXPERIMENTS_DIR, "paper_repro": PAPER_DIR}

_SUFFIX = {EXPERIMENTS_DIR: ".toml", PAPER_DIR: ".csv"}
_materialised: dict[str, Path] = {}
_extracted = contextlib.ExitStack()
atexit.register(_extracted.close)


def _path(folder: str, name: str) -> Path:
    """A file system path of the shipped ``folder/name``.

    For a package on the file system (wheel or source tree) this is the file itself; for
    one imported from a zip archive the file is extracted once to a temporary file that
    lives until the interpreter exits.
    """
    key = f"{folder}/{name}"
    if key not in _materialised:
        ref = resources.files(__name__).joinpath(folder, name)
        _materialised[key] = _extracted.enter_context(resources.as_file(ref))
    return _materialised[key]


def _names(folder: str) -> tuple[str, ...]:
    suffix = _SUFFIX[folder]
    return tuple(sorted(e.name for e in resources.files(__name__).joinpath(folder).iterdir()
                        if e.is_file() and e.name.endswith(suffix)))


def experiment_names() -> tuple[str, ...]:
    """Names of the shipped experiment files, sorted (``paper``, ``smoke``, ``space_table1``).

    Returns
    -------
    tuple of str
        File names without ``.toml``; each is accepted wherever an experiment or
        parameter-space file is.
    """
    return tuple(n.removesuffix(".toml") for n in _names(EXPERIMENTS_DIR))


def experiment_file(name: str, *, what: str = "experiment") -> Path:
    """Path of the shipped experiment file ``name`` (e.g. ``"paper"`` -> ``.../paper.toml``).

    Parameters
    ----------
    name : str
        A name from :func:`experiment_names` (``.toml`` may be appended).
    what : str
        What the file is, for the error message.

    Raises
    ------
    ConfigError
        ``name`` is not shipped; the message lists the shipped names.
    """
    stem = name.removesuffix(".toml")
    names = experiment_names()
    if stem not in names:
        raise ConfigError(f"unknown {what} {name!r}: not a file, and not one of the shipped "
                          f"experiments ({', '.join(names)})")
    return _path(EXPERIMENTS_DIR, f"{stem}.toml")


def shipped_file(path: str | Path) -> Path | None:
    """The packaged copy of a repository path such as ``experiments/paper.toml``, if there is one.

    The source repository keeps ``experiments/*.toml`` and ``paper_repro/*.csv`` as links
    to the package's files; this maps such a relative path (as written in the README) to
    the packaged file, so the documented paths work from any directory and in an install
    without the repository.

    Returns
    -------
    Path or None
        None when ``path`` is absolute, not of the form ``<folder>/<file>`` with a
        folder of :data:`REPOSITORY_DIRS`, or names no shipped file.
    """
    p = PurePosixPath(Path(path).as_posix())
    if p.is_absolute() or len(p.parts) != 2 or p.parts[0] not in REPOSITORY_DIRS:
        return None
    folder = REPOSITORY_DIRS[p.parts[0]]
    return _path(folder, p.name) if p.name in _names(folder) else None


def resolve_experiment(arg: str | Path, *, what: str = "experiment file") -> Path:
    """The file meant by an experiment argument: a path, or the name of a shipped experiment.

    Resolution order:

    1. ``arg`` is an existing file (relative to the working directory): that file;
    2. ``arg`` is a shipped name (:func:`experiment_names`, e.g. ``"paper"``): the packaged file;
    3. ``arg`` is a repository path of a shipped file (``experiments/paper.toml``, see
       :func:`shipped_file`): the packaged file.

    Parameters
    ----------
    arg : str or Path
        What the user wrote.
    what : str
        What the file is, for the error message (``"experiment file"``,
        ``"parameter-space file"``).

    Returns
    -------
    Path

    Raises
    ------
    ConfigError
        Nothing matches: for a bare name (no folder, no suffix) ``"unknown <what> 'x': ..."``,
        for a path ``"<path>: <what> cannot be read (no such file) ..."``; both list the
        shipped names.
    """
    p = Path(arg)
    if p.is_file():
        return p
    names = experiment_names()
    if str(arg) in names:
        return experiment_file(str(arg))
    packaged = shipped_file(p)
    if packaged is not None:
        return packaged
    if len(p.parts) == 1 and not p.suffix:
        raise ConfigError(f"unknown {what} {str(arg)!r}: not a file, and not one of the shipped "
                          f"experiments ({', '.join(names)})")
    raise ConfigError(f"{p}: {what} cannot be read (no such file; the shipped experiments "
                      f"are named {', '.join(names)})")


def paper_file(name: str) -> Path:
    """Path of one file of the paper's replication data (:data:`PAPER_RAW` or :data:`PAPER_REPORTED`).

    Raises
    ------
    ConfigError
        ``name`` is not a shipped data file (the message lists them).
    """
    names = _names(PAPER_DIR)
    if name not in names:
        raise ConfigError(f"unknown paper data file {name!r}; shipped: {', '.join(names)}")
    return _path(PAPER_DIR, name)


def paper_files() -> dict[str, Path]:
    """The paper's replication data: ``{"raw": <rms CSV>, "reported": <printed percentages CSV>}``."""
    return {"raw": paper_file(PAPER_RAW), "reported": paper_file(PAPER_REPORTED)}
