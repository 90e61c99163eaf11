"""The built-in SLAMs as ``faultlab slams`` lists them: units, applicable built-in faults, availability.

The SLAMs themselves are registered in :mod:`faultlab.slam.registry`; this listing adds what the
fault layer knows about each (how many built-in faults replace one of its units).
"""

from __future__ import annotations

import importlib.metadata
from dataclasses import dataclass

from faultlab.faults.applicability import applicable_faults
from faultlab.faults.registry import builtin_faults
from faultlab.slam.registry import BUILTIN_SLAMS

__all__ = ["SlamSummary", "SlamListing", "list_slams"]


@dataclass(frozen=True)
class SlamSummary:
    """One built-in SLAM as :func:`list_slams` describes it.

    Attributes
    ----------
    name, description : str
    n_units : int
        Replaceable units (0: no fault applies).
    n_faults : int
        Built-in faults that apply to it.
    requires : str or None
        Optional dependency (and faultlab extra) it needs.
    available : bool
        False if that dependency is not installed.
    version : str or None
        The installed version of that dependency.
    """

    name: str
    description: str
    n_units: int
    n_faults: int
    requires: str | None
    available: bool
    version: str | None = None


@dataclass(frozen=True)
class SlamListing:
    """Result of :func:`list_slams`: every built-in SLAM and the built-in fault count."""

    slams: tuple[SlamSummary, ...]
    n_builtin_faults: int

    def format(self) -> str:
        """A plain-text table, then how to select a SLAM and any missing optional dependency."""
        header = ("name", "units", "faults", "installed", "description")
        rows = [(s.name, str(s.n_units), f"{s.n_faults}/{self.n_builtin_faults}",
                 "yes" if s.available else "no", s.description) for s in self.slams]
        widths = [max(len(r[i]) for r in [header, *rows]) for i in range(4)]
        lines = ["  ".join([c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(r[:4], widths))]
                           + [r[4]]) for r in [header, *rows]]
        lines.append("units: replaceable units (steps table); faults: built-in faults that replace one of them "
                     "(python -m faultlab faults --slam NAME)")
        for s in self.slams:
            if s.requires is not None:
                state = f"installed ({s.version})" if s.available else (f"not installed: pip install 'faultlab[{s.requires}]' "
                                                          f"to use SLAM {s.name!r}")
                lines.append(f"{s.requires}: {state}")
        lines.append("select one in an experiment file with [slam] name = \"NAME\"")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.format()


def list_slams() -> SlamListing:
    """The built-in SLAMs with their unit counts, applicable built-in faults and availability."""
    faults = list(builtin_faults().values())
    rows = []
    for kind in BUILTIN_SLAMS.values():
        fit = applicable_faults(kind, faults)
        version = None
        if kind.requires is not None and kind.available:
            try:
                version = importlib.metadata.version(kind.requires)
            except importlib.metadata.PackageNotFoundError:  # importable, but not an installed distribution
                version = "unknown version"
        rows.append(SlamSummary(name=kind.name, description=kind.description, n_units=len(kind.units),
                                n_faults=len(fit.applicable), requires=kind.requires, available=kind.available,
                                version=version))
    return SlamListing(slams=tuple(rows), n_builtin_faults=len(faults))
