"""The registry of faults: built-ins, third-party plugin discovery and name resolution.

The fault contract (:class:`~faultlab.faults.fault.Fault`) is documented in
:mod:`faultlab.faults.fault`.  Built-in faults live in :mod:`faultlab.faults.builtin` and have plain names.
Third-party faults have ``provider/name`` names and are discovered through the
entry-point group ``faultlab.faults`` (see :func:`load_plugins`).  The variant
name ``"baseline"`` is reserved for the unmodified reference.

Applicability: a fault replaces one unit (:attr:`Fault.step`), so it applies to exactly the SLAMs
whose steps table has a unit of that name (the units shared by FastSLAM 1.0, FastSLAM 2.0 and
EKF-SLAM have the same signatures, see :mod:`faultlab.slam.units`).  :func:`applicable_faults`
splits a list of faults into those that apply to a SLAM and those that do not, with the reason.
"""

from __future__ import annotations

import dataclasses
import difflib
import importlib.metadata
import warnings
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from typing import Any

from faultlab.config import import_object
from faultlab.errors import FaultError, PluginError
from faultlab.faults.builtin import BUILTIN_FAULTS
from faultlab.faults.fault import Fault, step_names
from faultlab.slam.registry import BUILTIN_SLAMS, SlamKind, build_slam, get_slam_kind
from faultlab.vocabulary import BASELINE, UNMODIFIED

__all__ = [
    "ENTRY_POINT_GROUP",
    "PluginFailure",
    "PluginReport",
    "PluginWarning",
    "builtin_faults",
    "all_faults",
    "get_fault",
    "resolve_fault",
    "load_plugins",
    "FaultListing",
    "list_faults",
    "known_steps",
    "slam_units",
    "NotApplicable",
    "FaultNotApplicableWarning",
    "Applicability",
    "not_applicable",
    "fault_applies",
    "applicable_faults",
    "SlamSummary",
    "SlamListing",
    "list_slams",
]

#: Entry-point group a plugin distribution declares its faults in.
ENTRY_POINT_GROUP = "faultlab.faults"


class PluginWarning(UserWarning):
    """Issued when a fault plugin fails to load (the other plugins still load)."""


# --------------------------------------------------------------------------- built-ins

def builtin_faults() -> dict[str, Fault]:
    """The built-in faults by name, in registration order (the paper's three first)."""
    return {f.name: f for f in BUILTIN_FAULTS}


# --------------------------------------------------------------------------- plugins

@dataclass(frozen=True)
class PluginFailure:
    """A plugin (entry point) or one of its faults that could not be loaded.

    Attributes
    ----------
    plugin : str
        Entry-point name.
    source : str
        Entry point and distribution, e.g. ``"entry point broken = broken_mod:FAULTS
        (distribution broken-faults 1.0)"``.
    error : str
        The exception type and text, or what is wrong with the loaded object.
    """

    plugin: str
    source: str
    error: str

    def __str__(self) -> str:
        return f"fault plugin {self.plugin!r} ({self.source}) failed to load: {self.error}"


@dataclass(frozen=True)
class PluginReport:
    """Result of :func:`load_plugins`.

    Attributes
    ----------
    faults : tuple of Fault
        The third-party faults that loaded, sorted by name.
    sources : mapping
        Fault name -> the entry point / distribution it came from.
    errors : tuple of PluginFailure
        One entry per plugin that failed to import, or per rejected fault
        (bad object, invalid name, unknown step, duplicate name).
    """

    faults: tuple[Fault, ...] = ()
    sources: Mapping[str, str] = field(default_factory=dict)
    errors: tuple[PluginFailure, ...] = ()

    @property
    def ok(self) -> bool:
        """True if every plugin loaded without error."""
        return not self.errors

    def by_name(self) -> dict[str, Fault]:
        return {f.name: f for f in self.faults}

    def raise_for_errors(self) -> None:
        """Raise :class:`PluginError` listing every failure, if there is any."""
        if self.errors:
            raise PluginError("; ".join(str(e) for e in self.errors))

    def __str__(self) -> str:
        lines = [f"{len(self.faults)} plugin fault(s) loaded"]
        lines += [f"  {f.name}  ({self.sources.get(f.name, '?')})" for f in self.faults]
        lines += [f"  error: {e}" for e in self.errors]
        return "\n".join(lines)


def _describe(ep: importlib.metadata.EntryPoint) -> str:
    dist = getattr(ep, "dist", None)
    where = f"entry point {ep.name} = {ep.value}"
    if dist is not None:
        try:
            where += f" (distribution {dist.metadata['Name']} {dist.version})"
        except Exception:  # pragma: no cover - malformed metadata still names the entry point
            pass
    return where


def _faults_of(obj: Any) -> list[Any]:
    """An entry point loads to a Fault or an iterable of Faults."""
    if isinstance(obj, Fault):
        return [obj]
    if isinstance(obj, (str, bytes, Mapping)) or not isinstance(obj, Iterable):
        raise TypeError(f"entry point must load to a Fault or an iterable of Faults, "
                        f"got {type(obj).__name__}")
    return list(obj)


def load_plugins(*, group: str = ENTRY_POINT_GROUP, warn: bool = True) -> PluginReport:
    """Discover third-party faults through the entry-point group ``faultlab.faults``.

    Every entry point is loaded with :mod:`importlib.metadata`; it must resolve
    to a :class:`Fault` or an iterable of Faults.  Plugins are independent: one
    that fails to import (or yields a bad object, an invalid or duplicate name,
    or an unknown step) is recorded in :attr:`PluginReport.errors` with its
    name and error text, a :class:`PluginWarning` is issued, and the other
    plugins still load.  Discovery is repeated on each call (a few ms); nothing
    is cached or registered globally.

    Parameters
    ----------
    group : str
        Entry-point group to scan.
    warn : bool
        Issue a :class:`PluginWarning` per failure.

    Returns
    -------
    PluginReport
    """
    steps = set(known_steps())
    builtins = builtin_faults()
    eps = sorted(importlib.metadata.entry_points(group=group),
                 key=lambda ep: (ep.name, ep.value, _describe(ep)))
    faults: dict[str, Fault] = {}
    sources: dict[str, str] = {}
    errors: list[PluginFailure] = []
    for ep in eps:
        source = _describe(ep)
        try:
            items = _faults_of(ep.load())
        except Exception as exc:  # any import-time error of third-party code
            errors.append(PluginFailure(ep.name, source, f"{type(exc).__name__}: {exc}"))
            continue
        for item in items:
            problem = None
            if not isinstance(item, Fault):
                problem = f"yielded {type(item).__name__} {item!r}, not a Fault"
            elif item.provider is None:
                problem = (f"fault {item.name!r} needs a 'provider/name' name (plain names are reserved "
                           f"for built-ins{', and this one is taken' if item.name in builtins else ''})")
            elif item.step not in steps:
                problem = (f"fault {item.name!r} patches unknown step {item.step!r}; "
                           f"known steps: {', '.join(sorted(steps))}")
            elif item.name in faults:
                problem = (f"duplicate fault name {item.name!r}: defined by {sources[item.name]} "
                           f"and by {source}; the first one is kept")
            if problem:
                errors.append(PluginFailure(ep.name, source, problem))
                continue
            faults[item.name] = item
            sources[item.name] = source
    if warn:
        for failure in errors:
            warnings.warn(str(failure), PluginWarning, stacklevel=2)
    ordered = tuple(faults[k] for k in sorted(faults))
    return PluginReport(faults=ordered, sources={f.name: sources[f.name] for f in ordered},
                        errors=tuple(errors))


# --------------------------------------------------------------------------- look-up

def all_faults(*, plugins: bool = True, warn: bool = True) -> list[Fault]:
    """Every fault: the built-ins in registration order, then plugin faults by name.

    Plugins that fail to load are skipped with a :class:`PluginWarning`
    (call :func:`load_plugins` for the full report).
    """
    faults = list(builtin_faults().values())
    if plugins:
        faults += list(load_plugins(warn=warn).faults)
    return faults


def get_fault(name: str) -> Fault:
    """The registered fault called ``name`` (built-in, or ``provider/name`` from a plugin).

    Raises
    ------
    FaultError
        For ``"baseline"`` (not a fault) and for unknown names; the message
        lists the known names with close matches first.
    """
    if not isinstance(name, str):
        raise FaultError(f"fault name must be a string, got {type(name).__name__}")
    if name in UNMODIFIED:
        raise FaultError(f"{name!r} is the unmodified reference, not a fault")
    builtins = builtin_faults()
    if name in builtins:
        return builtins[name]
    report = load_plugins(warn=False)
    known = {**builtins, **report.by_name()}
    if name in known:
        return known[name]
    close = difflib.get_close_matches(name, list(known), n=3, cutoff=0.6)
    hint = f"; did you mean {' or '.join(repr(c) for c in close)}?" if close else ""
    msg = f"unknown fault {name!r}{hint} Known faults: {', '.join(known)}"
    if "/" in name and report.errors:
        msg += ". Plugins that failed to load: " + "; ".join(str(e) for e in report.errors)
    raise FaultError(msg)


def _import_fault(spec: str) -> Fault:
    obj = import_object(spec, what="fault import path", error=FaultError)
    if not isinstance(obj, Fault):
        raise FaultError(f"fault {spec!r} is a {type(obj).__name__}, not a faultlab.faults.Fault")
    return obj


def resolve_fault(spec: str | Fault) -> Fault:
    """A fault from a name (built-in or ``provider/name``) or a ``module:attr`` import path.

    Import paths let an experiment use a fault defined in a test module or any
    importable module without packaging it as a plugin.  A :class:`Fault`
    instance is returned unchanged.
    """
    if isinstance(spec, Fault):
        return spec
    if isinstance(spec, str) and ":" in spec:
        return _import_fault(spec)
    return get_fault(spec)


# --------------------------------------------------------------------------- listing

@dataclass(frozen=True)
class FaultListing:
    """Every known fault with where it comes from (result of :func:`list_faults`).

    Attributes
    ----------
    faults : tuple of Fault
        Built-ins in registration order, then plugin faults by name.
    sources : mapping
        Fault name -> ``"built-in"`` or the plugin entry point it came from.
    errors : tuple of PluginFailure
        Plugins (or plugin faults) that failed to load.
    """

    faults: tuple[Fault, ...]
    sources: Mapping[str, str]
    errors: tuple[PluginFailure, ...] = ()

    def select(self, specs: Iterable[str]) -> "FaultListing":
        """The listing of the given faults (names or ``module:attr`` paths), in that order."""
        faults = tuple(resolve_fault(s) for s in specs)
        sources = {f.name: self.sources.get(f.name, "import path") for f in faults}
        return FaultListing(faults=faults, sources=sources, errors=self.errors)

    def rows(self) -> list[tuple[str, str, str, str]]:
        """``(name, step, origin, description)`` per fault."""
        return [(f.name, f.step, f.origin, f.description) for f in self.faults]

    def format(self, *, verbose: bool = False) -> str:
        """A plain-text table; ``verbose`` adds each fault's rationale and source."""
        rows = self.rows()
        if not verbose:
            w0 = max(len(r[0]) for r in rows) if rows else 4
            w1 = max(len(r[1]) for r in rows) if rows else 4
            lines = []
            for name, step, origin, description in rows:
                lines.append(f"{name.ljust(w0)}  {step.ljust(w1)}  {description}")
                lines.append(f"{'':{w0}}  {'':{w1}}  origin: {origin}")
        else:
            lines = []
            for f in self.faults:
                lines += [f"{f.name}  (step: {f.step}; {self.sources.get(f.name, '?')})",
                          f"    {f.description}",
                          f"    origin: {f.origin}",
                          f"    {f.rationale}", ""]
        n_plugin = sum(1 for f in self.faults if f.provider is not None)
        lines.append(f"{len(self.faults)} faults ({len(self.faults) - n_plugin} built-in, {n_plugin} from "
                     f"plugins); variant {BASELINE!r} is the unmodified reference")
        lines += [f"error: {e}" for e in self.errors]
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.format()


def list_faults(*, plugins: bool = True) -> FaultListing:
    """All faults with their sources and any plugin load errors (no warnings issued)."""
    builtins = builtin_faults()
    report = load_plugins(warn=False) if plugins else PluginReport()
    sources = {name: "built-in" for name in builtins} | dict(report.sources)
    return FaultListing(faults=(*builtins.values(), *report.faults), sources=sources, errors=report.errors)


# --------------------------------------------------------------------------- applicability

def known_steps() -> tuple[str, ...]:
    """Every unit of every built-in SLAM (the steps a fault may replace), FastSLAM 1.0's first."""
    names = list(step_names())
    for kind in BUILTIN_SLAMS.values():
        names += [u for u in kind.units if u not in names]
    return tuple(names)


def _slam_label(slam: Any) -> str:
    if isinstance(slam, str):
        return slam
    if isinstance(slam, SlamKind):
        return slam.name
    if isinstance(slam, type):
        return slam.__name__
    return str(getattr(slam, "name", type(slam).__name__))


def slam_units(slam: Any) -> tuple[str, ...]:
    """The replaceable units of a SLAM, in algorithm order; () for a SLAM without units.

    Parameters
    ----------
    slam : str, SlamKind, type or SlamAdapter
        A built-in SLAM's name (``"ekf"``), an import path ``"package.module:factory"`` (the
        factory is called without options to find out), a :class:`~faultlab.slam.registry.SlamKind`,
        a steps dataclass type, or a SLAM instance (its units are the fields of ``slam.steps`` if it
        has ``steps`` and ``with_steps``, the fault contract of :mod:`faultlab.faults.fault`).

    Raises
    ------
    ConfigError
        An unknown SLAM name.
    """
    if isinstance(slam, SlamKind):
        return slam.units
    if isinstance(slam, str):
        kind = get_slam_kind(slam, where="slam")
        if kind is not None:
            return kind.units
        slam = build_slam(slam, {})
    if isinstance(slam, type):
        return step_names(slam)
    steps = getattr(slam, "steps", None)
    if (steps is None or isinstance(steps, type) or not dataclasses.is_dataclass(steps)
            or not callable(getattr(slam, "with_steps", None))):
        return ()
    return step_names(type(steps))


class FaultNotApplicableWarning(UserWarning):
    """Issued when a campaign skips a variant whose fault replaces a unit its SLAM does not have."""


@dataclass(frozen=True)
class NotApplicable:
    """A fault that does not apply to a SLAM, and why: the SLAM has no unit of that name.

    Attributes
    ----------
    fault : str
        The fault's name.
    step : str
        The unit it replaces.
    slam : str
        The SLAM (its name or import path).
    n_units : int
        How many replaceable units the SLAM has (0: none at all, e.g. dead reckoning).
    """

    fault: str
    step: str
    slam: str
    n_units: int

    def __str__(self) -> str:
        if self.n_units == 0:
            return (f"fault {self.fault!r} replaces unit {self.step!r}, but SLAM {self.slam!r} has no "
                    f"replaceable units")
        return (f"fault {self.fault!r} replaces unit {self.step!r}, which SLAM {self.slam!r} does not have "
                f"(it has {self.n_units} other units)")


def not_applicable(fault: Fault, slam: Any, *, units: tuple[str, ...] | None = None) -> NotApplicable | None:
    """Why ``fault`` does not apply to ``slam`` (see :func:`slam_units`), or None if it applies.

    ``units`` (the SLAM's units, if already known) saves looking them up again.
    """
    units = slam_units(slam) if units is None else tuple(units)
    if fault.step in units:
        return None
    return NotApplicable(fault=fault.name, step=fault.step, slam=_slam_label(slam), n_units=len(units))


def fault_applies(fault: Fault, slam: Any) -> bool:
    """True if ``slam`` has the unit ``fault`` replaces (see :func:`slam_units` for ``slam``)."""
    return not_applicable(fault, slam) is None


@dataclass(frozen=True)
class Applicability:
    """Result of :func:`applicable_faults`: which faults apply to one SLAM.

    Attributes
    ----------
    slam : str
    units : tuple of str
        The SLAM's replaceable units.
    applicable : tuple of Fault
        In the order given.
    not_applicable : tuple of NotApplicable
        In the order given.
    """

    slam: str
    units: tuple[str, ...]
    applicable: tuple[Fault, ...]
    not_applicable: tuple[NotApplicable, ...]

    def summary(self) -> str:
        """One line: how many faults do not apply and why (empty if all apply)."""
        skipped = self.not_applicable
        if not skipped:
            return ""
        total = len(self.applicable) + len(skipped)
        if not self.units:
            return (f"{len(skipped)} of {total} faults do not apply to {self.slam!r}: it has no replaceable "
                    f"units")
        by_step: dict[str, list[str]] = {}
        for item in skipped:
            by_step.setdefault(item.step, []).append(item.fault)
        parts = "; ".join(f"{step} ({', '.join(names)})" for step, names in by_step.items())
        return (f"{len(skipped)} of {total} faults do not apply to {self.slam!r}: they replace units it does "
                f"not have: {parts}")


def applicable_faults(slam: Any, faults: Iterable[Fault] | None = None) -> Applicability:
    """Split ``faults`` (default: every fault, plugins included) by whether they apply to ``slam``.

    Parameters
    ----------
    slam : str, SlamKind, type or SlamAdapter
        See :func:`slam_units`.
    faults : iterable of Fault, optional
    """
    units = slam_units(slam)
    faults = all_faults(warn=False) if faults is None else list(faults)
    label = _slam_label(slam)
    yes: list[Fault] = []
    no: list[NotApplicable] = []
    for fault in faults:
        reason = not_applicable(fault, label if isinstance(slam, str) else slam, units=units)
        if reason is None:
            yes.append(fault)
        else:
            no.append(reason)
    return Applicability(slam=label, units=units, applicable=tuple(yes), not_applicable=tuple(no))


# --------------------------------------------------------------------------- the SLAMs

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
