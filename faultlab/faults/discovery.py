"""Discovery of third-party faults through the entry-point group ``faultlab.faults``.

A plugin distribution declares its faults in the group::

    [project.entry-points."faultlab.faults"]
    mylab = "mylab.faults:FAULTS"

An entry point loads to a :class:`~faultlab.faults.fault.Fault` or an iterable of Faults, each named
``provider/name`` (plain names are reserved for the built-ins) and replacing a unit some built-in SLAM
has (:func:`~faultlab.faults.fault.known_steps`).  Loading runs the same loop as every other kind
of plugin (:class:`faultlab.plugins.PluginCatalogue`), with the rules of faults
(:class:`FaultCatalogue`).
"""

from __future__ import annotations

import importlib.metadata
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

from faultlab.faults.builtin import BUILTIN_FAULTS
from faultlab.faults.fault import Fault, known_steps
from faultlab.plugins import PluginCatalogue, PluginFailure, PluginLoad

__all__ = ["ENTRY_POINT_GROUP", "PluginWarning", "PluginFailure", "FaultCatalogue", "load_plugins"]

#: Entry-point group a plugin distribution declares its faults in.
ENTRY_POINT_GROUP = "faultlab.faults"


class PluginWarning(UserWarning):
    """Issued when a fault plugin fails to load (the other plugins still load)."""


@dataclass(frozen=True)
class FaultCatalogue(PluginCatalogue):
    """The fault plugins: :class:`~faultlab.plugins.PluginCatalogue` with the rules of faults.

    An entry point loads to a Fault or an iterable of Faults (a mapping is refused); a plugin
    fault needs a ``provider/name`` name, a known step and a name no other plugin took.  Failures
    are :class:`~faultlab.plugins.PluginFailure` records naming the distribution; :meth:`load` returns a
    :class:`~faultlab.plugins.PluginLoad` with the faults sorted by name.
    """

    def describe(self, ep: importlib.metadata.EntryPoint) -> str:
        dist = getattr(ep, "dist", None)
        where = f"entry point {ep.name} = {ep.value}"
        if dist is not None:
            try:
                where += f" (distribution {dist.metadata['Name']} {dist.version})"
            except Exception:  # pragma: no cover - malformed metadata still names the entry point
                pass
        return where

    def instances(self, obj: Any) -> list[Any]:
        if isinstance(obj, Fault):
            return [obj]
        if isinstance(obj, (str, bytes, Mapping)) or not isinstance(obj, Iterable):
            raise TypeError(f"entry point must load to a Fault or an iterable of Faults, "
                            f"got {type(obj).__name__}")
        return list(obj)

    def is_builtin(self, item: Any) -> bool:
        return False  # faultlab does not declare its faults in the group: a plain name is an error

    def problem(self, item: Any, taken: dict[str, str], source: str) -> str | None:
        builtins = {f.name for f in self.builtins}
        if not isinstance(item, Fault):
            return f"yielded {type(item).__name__} {item!r}, not a Fault"
        if item.provider is None:
            return (f"fault {item.name!r} needs a 'provider/name' name (plain names are reserved "
                    f"for built-ins{', and this one is taken' if item.name in builtins else ''})")
        steps = known_steps()
        if item.step not in steps:
            return (f"fault {item.name!r} patches unknown step {item.step!r}; "
                    f"known steps: {', '.join(sorted(steps))}")
        if item.name in taken:
            return (f"duplicate fault name {item.name!r}: defined by {taken[item.name]} "
                    f"and by {source}; the first one is kept")
        return None

    def failure(self, plugin: str, source: str, error: str, *, loading: bool) -> PluginFailure:
        return PluginFailure(plugin, source, error)

    def collect(self, items: list, sources: dict[str, str], errors: list) -> PluginLoad:
        ordered = tuple(sorted(items, key=lambda f: f.name))
        return PluginLoad(items=ordered, sources={f.name: sources[f.name] for f in ordered}, errors=tuple(errors))


_CATALOGUE = FaultCatalogue(kind="fault", group=ENTRY_POINT_GROUP, base=Fault, builtins=tuple(BUILTIN_FAULTS),
                            warning=PluginWarning)


def load_plugins(*, group: str = ENTRY_POINT_GROUP, warn: bool = True) -> PluginLoad:
    """Discover third-party faults through the entry-point group ``faultlab.faults``.

    Every entry point is loaded with :mod:`importlib.metadata`; it must resolve
    to a :class:`Fault` or an iterable of Faults.  Plugins are independent: one
    that fails to import (or yields a bad object, an invalid or duplicate name,
    or an unknown step) is recorded in :attr:`PluginLoad.errors <faultlab.plugins.PluginLoad.errors>` with its
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
    PluginLoad
        The faults sorted by name, their sources, the failures.
    """
    return _CATALOGUE.load(group=group, warn=warn)
