"""The registry of faults: the built-ins and the plugin faults by name, and name resolution.

The fault contract (:class:`~faultlab.faults.fault.Fault`) is documented in
:mod:`faultlab.faults.fault`.  Built-in faults live in :mod:`faultlab.faults.builtin` and have plain names.
Sensor and hardware faults (:class:`~faultlab.faults.sensor.SensorFault`, which perturb the input
stream rather than a unit) share the name space: built-ins in :mod:`faultlab.faults.sensorfaults`,
plugins in the entry-point group ``faultlab.sensor_faults``.
Third-party faults have ``provider/name`` names and are discovered through the
entry-point group ``faultlab.faults`` (:mod:`faultlab.faults.discovery`).  The variant
name ``"baseline"`` is reserved for the unmodified reference.  Which faults apply to which SLAM:
:mod:`faultlab.faults.applicability`.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from faultlab.config import import_object
from faultlab.errors import FaultError, UnknownPluginError
from faultlab.faults.builtin import BUILTIN_FAULTS
from faultlab.faults.discovery import load_plugins
from faultlab.faults.fault import Fault
from faultlab.faults.real import fault_categories
from faultlab.faults.sensor import SensorFault, load_sensor_plugins
from faultlab.faults.sensorfaults import BUILTIN_SENSOR_FAULTS
from faultlab.plugins import PluginLoad
from faultlab.vocabulary import BASELINE, UNMODIFIED

__all__ = ["builtin_faults", "builtin_sensor_faults", "all_sensor_faults", "all_faults", "get_fault", "resolve_fault", "FaultListing", "list_faults"]


# --------------------------------------------------------------------------- built-ins

def builtin_faults() -> dict[str, Fault]:
    """The built-in faults by name, in registration order (the paper's three first)."""
    return {f.name: f for f in BUILTIN_FAULTS}


def builtin_sensor_faults() -> dict[str, SensorFault]:
    """The built-in sensor and hardware faults by name, in registration order."""
    return {f.name: f for f in BUILTIN_SENSOR_FAULTS}


def all_sensor_faults(*, plugins: bool = True, warn: bool = True) -> list[SensorFault]:
    """Every sensor fault: the built-ins in registration order, then plugin sensor faults by name."""
    faults = list(BUILTIN_SENSOR_FAULTS)
    if plugins:
        faults += list(load_sensor_plugins(warn=warn).items)
    return faults


# --------------------------------------------------------------------------- look-up

def all_faults(*, plugins: bool = True, warn: bool = True) -> list[Fault]:
    """Every fault: the built-ins in registration order, then plugin faults by name.

    Plugins that fail to load are skipped with a :class:`PluginWarning`
    (call :func:`load_plugins` for the full report).
    """
    faults = list(builtin_faults().values())
    if plugins:
        faults += list(load_plugins(warn=warn).items)
    return faults


def get_fault(name: str) -> Fault | SensorFault:
    """The registered fault called ``name``: a code fault or a sensor fault, built-in or ``provider/name``.

    Raises
    ------
    FaultError
        For ``"baseline"`` (not a fault); for an unknown name its subclass
        :class:`~faultlab.errors.UnknownPluginError`, listing the known names with close matches first.
    """
    if not isinstance(name, str):
        raise FaultError(f"fault name must be a string, got {type(name).__name__}")
    if name in UNMODIFIED:
        raise FaultError(f"{name!r} is the unmodified reference, not a fault")
    builtins = builtin_faults() | builtin_sensor_faults()
    if name in builtins:
        return builtins[name]
    report, sensor = load_plugins(warn=False), load_sensor_plugins(warn=False)
    known = {**builtins, **report.by_name(), **sensor.by_name()}
    if name in known:
        return known[name]
    failures = (*report.errors, *sensor.errors)
    note = (". Plugins that failed to load: " + "; ".join(str(e) for e in failures)) if "/" in name and failures else ""
    raise UnknownPluginError("fault", name, known, note=note)


def _import_fault(spec: str) -> Fault | SensorFault:
    obj = import_object(spec, what="fault import path", error=FaultError)
    if not isinstance(obj, (Fault, SensorFault)):
        raise FaultError(f"fault {spec!r} is a {type(obj).__name__}, not a faultlab.faults.Fault or SensorFault")
    return obj


def resolve_fault(spec: str | Fault | SensorFault) -> Fault | SensorFault:
    """A fault from a name (built-in or ``provider/name``) or a ``module:attr`` import path.

    Import paths let an experiment use a fault defined in a test module or any
    importable module without packaging it as a plugin.  A :class:`Fault`
    instance is returned unchanged.
    """
    if isinstance(spec, (Fault, SensorFault)):
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
    errors : tuple of faultlab.plugins.PluginFailure
        Plugins (or plugin faults) that failed to load.
    sensor_faults : tuple of SensorFault
        The sensor and hardware faults, listed in their own section.
    categories : mapping
        Fault name -> category for the faults that have one (``"real"``: reproduces a bug found in
        public SLAM code, :mod:`faultlab.faults.real`).
    """

    faults: tuple[Fault, ...]
    sources: Mapping[str, str]
    errors: tuple = ()
    sensor_faults: tuple[SensorFault, ...] = ()
    categories: Mapping[str, str] = field(default_factory=dict)

    def select(self, specs: Iterable[str]) -> "FaultListing":
        """The listing of the given faults (names or ``module:attr`` paths), in that order."""
        chosen = tuple(resolve_fault(s) for s in specs)
        sources = {f.name: self.sources.get(f.name, "import path") for f in chosen}
        return FaultListing(faults=tuple(f for f in chosen if isinstance(f, Fault)), sources=sources,
                            errors=self.errors, sensor_faults=tuple(f for f in chosen if isinstance(f, SensorFault)),
                            categories=self.categories)

    def in_category(self, category: str) -> "FaultListing":
        """The listing of the faults of one category (no sensor faults: none has a category)."""
        return FaultListing(faults=tuple(f for f in self.faults if self.categories.get(f.name) == category),
                            sources=self.sources, errors=self.errors, categories=self.categories)

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
                category = f" (category: {self.categories[name]})" if name in self.categories else ""
                lines.append(f"{name.ljust(w0)}  {step.ljust(w1)}  {description}")
                lines.append(f"{'':{w0}}  {'':{w1}}  origin: {origin}{category}")
        else:
            lines = []
            for f in self.faults:
                category = f"; category: {self.categories[f.name]}" if f.name in self.categories else ""
                lines += [f"{f.name}  (step: {f.step}; {self.sources.get(f.name, '?')}{category})",
                          f"    {f.description}",
                          f"    origin: {f.origin}",
                          f"    {f.rationale}", ""]
        n_plugin = sum(1 for f in self.faults if f.provider is not None)
        lines.append(f"{len(self.faults)} faults ({len(self.faults) - n_plugin} built-in, {n_plugin} from "
                     f"plugins); variant {BASELINE!r} is the unmodified reference")
        if self.sensor_faults:
            lines += ["", "Sensor and hardware faults (perturb what every SLAM is fed; ground truth untouched):"]
            w0 = max(len(f.name) for f in self.sensor_faults)
            for f in self.sensor_faults:
                lines.append(f"{f.name.ljust(w0)}  {f.step}: {f.description}")
                lines.append(f"{'':{w0}}  parameters: {f.parameter_text() or '-'}; origin: {f.origin}")
                if verbose:
                    lines.append(f"{'':{w0}}  {f.rationale} ({self.sources.get(f.name, '?')})")
            lines.append(f"{len(self.sensor_faults)} sensor and hardware faults")
        lines += [f"error: {e}" for e in self.errors]
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.format()


def list_faults(*, plugins: bool = True) -> FaultListing:
    """All faults with their sources and any plugin load errors (no warnings issued)."""
    builtins = builtin_faults()
    report = load_plugins(warn=False) if plugins else PluginLoad()
    sensor = load_sensor_plugins(warn=False) if plugins else None
    sources = ({name: "built-in" for name in builtins} | {f.name: "built-in" for f in BUILTIN_SENSOR_FAULTS}
               | dict(report.sources) | (dict(sensor.sources) if sensor else {}))
    errors = (*report.errors, *(sensor.errors if sensor else ()))
    return FaultListing(faults=(*builtins.values(), *report.items), sources=sources, errors=errors,
                        sensor_faults=(*BUILTIN_SENSOR_FAULTS, *(sensor.items if sensor else ())),
                        categories=fault_categories())
