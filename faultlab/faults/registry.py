"""Fault records, the registry of built-in faults and third-party plugin discovery.

A :class:`Fault` is a mutation of exactly one replaceable unit (one field of
:class:`faultlab.slam.FastSlamSteps`).  Applying it builds a *new* SLAM
instance whose step table has that one unit replaced; the reference
:data:`faultlab.slam.REFERENCE_STEPS` and any SLAM the fault is applied to are
never modified, and nothing is written to disk.  This replaces the paper's
hand-edited copies of the SLAM code (Sec. VII-A) by named, documented plugins.

Built-in faults live in :mod:`faultlab.faults.builtin` and have plain names.
Third-party faults have ``provider/name`` names and are discovered through the
entry-point group ``faultlab.faults`` (see :func:`load_plugins`).  The variant
name ``"baseline"`` is reserved for the unmodified reference.
"""

from __future__ import annotations

import contextlib
import dataclasses
import difflib
import importlib
import importlib.metadata
import re
import warnings
from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from typing import Any

from faultlab.errors import FaultError, PluginError
from faultlab.vocabulary import BASELINE

__all__ = [
    "ENTRY_POINT_GROUP",
    "Fault",
    "UnitExample",
    "PluginFailure",
    "PluginReport",
    "PluginWarning",
    "builtin_faults",
    "all_faults",
    "get_fault",
    "resolve_fault",
    "resolve_variant",
    "load_plugins",
    "apply_faults",
    "step_names",
    "FaultListing",
    "list_faults",
]

#: Entry-point group a plugin distribution declares its faults in.
ENTRY_POINT_GROUP = "faultlab.faults"


_BUILTIN_NAME = re.compile(r"[a-z][a-z0-9_]*")
_PLUGIN_NAME = re.compile(r"[a-z0-9][a-z0-9_.-]*/[a-z0-9][a-z0-9_.-]*")


class PluginWarning(UserWarning):
    """Issued when a fault plugin fails to load (the other plugins still load)."""


def step_names() -> tuple[str, ...]:
    """Names of the replaceable units of the reference FastSLAM (fields of ``FastSlamSteps``)."""
    from faultlab.slam import FastSlamSteps  # late import: faults builds on slam

    return tuple(f.name for f in dataclasses.fields(FastSlamSteps))


@dataclass(frozen=True, eq=False)
class UnitExample:
    """Inputs on which a fault's unit must behave differently from the original unit.

    A cosmic-ray style smoke test for a mutant: calling the original unit and
    the faulty unit with the same inputs must give different outputs (see
    :func:`faultlab.faults.check.unit_outputs`).

    Parameters
    ----------
    make_args : callable
        ``make_args() -> (args, kwargs)``; called once per unit so that
        each call gets fresh arrays (and, for random units, a fresh
        ``numpy.random.Generator`` with the same seed).
    note : str
        What the example shows, one line.
    """

    make_args: Callable[[], tuple[tuple, dict]]
    note: str = ""


@dataclass(frozen=True)
class Fault:
    """A mutation-style fault that replaces one unit of the reference FastSLAM.

    Parameters
    ----------
    name : str
        Stable name used in experiment files and results tables: lower-case
        ``snake_case`` for built-ins, ``provider/name`` for third-party faults.
        ``"baseline"`` is reserved.
    step : str
        The :class:`~faultlab.slam.FastSlamSteps` field (unit) the fault replaces.
    description : str
        One line: what is wrong.
    rationale : str
        One paragraph: why this is a realistic mistake and how it shows.
    origin : str
        Where the failure mode comes from, e.g. ``"paper Sec. VII-A"``,
        ``"public bug report: ..."``, ``"textbook pitfall: ..."``.
    replacement : callable
        ``replacement(original_unit) -> new_unit``.  It receives the unit it
        replaces (so a fault can wrap the original) and must return a callable
        with the same signature.  Use a module-level function (not a lambda) so
        that the fault can be pickled to worker processes.
    examples : tuple of UnitExample
        Optional unit-level inputs on which the new unit differs from the
        original (not compared, not hashed).
    """

    name: str
    step: str
    description: str
    rationale: str
    origin: str
    replacement: Callable[[Callable], Callable]
    examples: tuple[UnitExample, ...] = field(default=(), compare=False, repr=False)

    def __post_init__(self) -> None:
        name = self.name
        if not isinstance(name, str) or not name:
            raise FaultError(f"fault name must be a non-empty string, got {name!r}")
        if name == BASELINE:
            raise FaultError(f"fault name {BASELINE!r} is reserved for the unmodified reference")
        if not (_BUILTIN_NAME.fullmatch(name) or _PLUGIN_NAME.fullmatch(name)):
            raise FaultError(
                f"fault name {name!r} is invalid: use lower-case snake_case for built-ins or "
                f"'provider/name' for third-party faults (letters, digits, '_', '.', '-')")
        if not isinstance(self.step, str) or not self.step.isidentifier():
            raise FaultError(f"fault {name!r}: step must be the name of a FastSlamSteps field, "
                             f"got {self.step!r}")
        for attr in ("description", "rationale", "origin"):
            value = getattr(self, attr)
            if not isinstance(value, str) or not value.strip():
                raise FaultError(f"fault {name!r}: {attr} must be a non-empty string")
        if "\n" in self.description.strip():
            raise FaultError(f"fault {name!r}: description must be one line")
        if not callable(self.replacement):
            raise FaultError(f"fault {name!r}: replacement must be callable (original_unit) -> new_unit, "
                             f"got {type(self.replacement).__name__}")
        examples = tuple(self.examples)
        if not all(isinstance(e, UnitExample) for e in examples):
            raise FaultError(f"fault {name!r}: examples must be UnitExample instances")
        object.__setattr__(self, "examples", examples)

    @property
    def provider(self) -> str | None:
        """The ``provider`` part of a third-party name; None for built-ins."""
        return self.name.split("/", 1)[0] if "/" in self.name else None

    def patch(self, steps):
        """Return a copy of ``steps`` with unit :attr:`step` replaced.

        Parameters
        ----------
        steps : FastSlamSteps
            Any frozen dataclass of units (normally ``slam.steps``); not modified.

        Raises
        ------
        FaultError
            If :attr:`step` is not a field of ``steps`` or the replacement
            factory fails or returns something that is not callable.
        """
        if not dataclasses.is_dataclass(steps) or isinstance(steps, type):
            raise FaultError(f"fault {self.name!r}: can only patch a steps dataclass (FastSlamSteps), "
                             f"got {type(steps).__name__}")
        names = [f.name for f in dataclasses.fields(steps)]
        if self.step not in names:
            raise FaultError(f"fault {self.name!r} patches unknown step {self.step!r}; "
                             f"{type(steps).__name__} has: {', '.join(names)}")
        original = getattr(steps, self.step)
        try:
            unit = self.replacement(original)
        except Exception as exc:
            raise FaultError(f"fault {self.name!r}: building the replacement for step {self.step!r} "
                             f"failed: {type(exc).__name__}: {exc}") from exc
        if not callable(unit):
            raise FaultError(f"fault {self.name!r}: replacement for step {self.step!r} returned "
                             f"{type(unit).__name__}, not a callable unit")
        return dataclasses.replace(steps, **{self.step: unit})

    def apply(self, slam):
        """Return a new SLAM instance with this fault injected; ``slam`` is unchanged.

        Parameters
        ----------
        slam : FastSlam
            Any SLAM with a ``steps`` table and ``with_steps(steps)``.
        """
        if not (hasattr(slam, "steps") and callable(getattr(slam, "with_steps", None))):
            raise FaultError(f"fault {self.name!r} can only be applied to a SLAM with replaceable steps "
                             f"(FastSlam); {type(slam).__name__} has no steps/with_steps")
        return slam.with_steps(self.patch(slam.steps))

    @contextlib.contextmanager
    def applied(self, slam) -> Iterator[Any]:
        """Context-manager form of :meth:`apply`: ``with fault.applied(slam) as faulty: ...``.

        Yields a new instance; nothing global is modified, so there is nothing
        to undo on exit (``slam`` itself stays the reference).
        """
        yield self.apply(slam)

    def summary(self) -> str:
        """``name  step  origin  description`` on one line."""
        return f"{self.name}  [{self.step}]  {self.origin}: {self.description}"


def apply_faults(slam, faults: Iterable[Fault]):
    """Apply several faults in order (a higher-order mutant); returns a new instance."""
    for fault in faults:
        slam = fault.apply(slam)
    return slam


# --------------------------------------------------------------------------- built-ins

def builtin_faults() -> dict[str, Fault]:
    """The built-in faults by name, in registration order (the paper's three first)."""
    from faultlab.faults.builtin import BUILTIN_FAULTS  # late: builtin imports this module

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
    known_steps = set(step_names())
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
            elif item.step not in known_steps:
                problem = (f"fault {item.name!r} patches unknown step {item.step!r}; "
                           f"known steps: {', '.join(sorted(known_steps))}")
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
    if name == BASELINE:
        raise FaultError(f"{BASELINE!r} is the unmodified reference, not a fault")
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
    module_name, _, attr = spec.partition(":")
    if not module_name or not attr:
        raise FaultError(f"fault import path {spec!r} must look like 'package.module:attribute'")
    try:
        obj: Any = importlib.import_module(module_name)
    except Exception as exc:
        raise FaultError(f"fault {spec!r}: cannot import module {module_name!r}: "
                         f"{type(exc).__name__}: {exc}") from exc
    for part in attr.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            raise FaultError(f"fault {spec!r}: module {module_name!r} has no attribute {attr!r}") from None
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


def resolve_variant(spec: str | Fault) -> Fault | None:
    """Like :func:`resolve_fault`, but ``"baseline"`` resolves to None (no fault)."""
    if spec == BASELINE:
        return None
    return resolve_fault(spec)


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
