"""Named plugins discovered through an entry-point group: one catalogue for every kind.

Mutation operators (``faultlab.mutation_operators``) and metamorphic relations
(``faultlab.metamorphic``) are plugins of the same shape: a class whose instances have a
lower-case ``snake_case`` ``name`` and a one-line ``description``, built-ins shipped with faultlab
and third-party ones declared by an installed distribution::

    [project.entry-points."faultlab.metamorphic"]
    mylab = "mylab.relations:RELATIONS"

An entry point loads to a subclass (instantiated without arguments), an instance, or an iterable
of them.  faultlab declares its own built-ins in the group too; loading them again from there is
recognised and skipped.  A plugin that fails to load is reported (a warning) and the others still
load; names must be unique.

Faults (``faultlab.faults``) load through the same loop, with their own rules: a fault is a
record with provenance rather than a class, its name is ``provider/name`` and it must replace a
known unit (:class:`faultlab.faults.discovery.FaultCatalogue` overrides the hooks :meth:`~PluginCatalogue.instances`,
:meth:`~PluginCatalogue.is_builtin`, :meth:`~PluginCatalogue.problem`, :meth:`~PluginCatalogue.failure`
and :meth:`~PluginCatalogue.collect`).
"""

from __future__ import annotations

import importlib.metadata
import re
import warnings
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field

from faultlab.errors import PluginError, UnknownPluginError

__all__ = ["PluginFailure", "PluginLoad", "PluginCatalogue"]

_NAME = re.compile(r"[a-z][a-z0-9_]*")


@dataclass(frozen=True)
class PluginFailure:
    """A plugin (entry point) that failed to load, or one of its items that was refused.

    Attributes
    ----------
    plugin : str
        Entry-point name.
    source : str
        The entry point (and, for faults, the distribution), e.g. ``"entry point broken = broken_mod:FAULTS"``.
    error : str
        The exception type and text, or what is wrong with the loaded item.
    kind : str
        The kind of plugin, hyphenated (``"fault"``, ``"sensor-fault"``, ``"mutation-operator"``, ...).
    loading : bool
        The entry point failed to load (True) or loaded an item that was refused (False).
    """

    plugin: str
    source: str
    error: str
    kind: str = "fault"
    loading: bool = True

    def __str__(self) -> str:
        if self.loading:
            return f"{self.kind} plugin {self.plugin!r} ({self.source}) failed to load: {self.error}"
        return f"{self.kind} plugin {self.plugin!r} ({self.source}): {self.error}"


@dataclass(frozen=True)
class PluginLoad:
    """What :meth:`PluginCatalogue.load` found, for every kind of plugin: the plugins that loaded, where
    each came from, and the failures.

    Attributes
    ----------
    items : tuple
        The plugins that loaded, in the catalogue's order.
    sources : mapping
        Plugin name -> the entry point (and distribution) it came from.
    errors : tuple of PluginFailure
        One per plugin that failed to load or item that was refused.
    """

    items: tuple = ()
    sources: Mapping[str, str] = field(default_factory=dict)
    errors: tuple[PluginFailure, ...] = ()

    @property
    def ok(self) -> bool:
        """True if every plugin loaded without error."""
        return not self.errors

    def by_name(self) -> dict:
        """Plugin name -> plugin."""
        return {item.name: item for item in self.items}

    def raise_for_errors(self) -> None:
        """Raise :class:`~faultlab.errors.PluginError` listing every failure, if there is any."""
        if self.errors:
            raise PluginError("; ".join(str(e) for e in self.errors))

    def __str__(self) -> str:
        lines = [f"{len(self.items)} plugin(s) loaded"]
        lines += [f"  {item.name}  ({self.sources.get(item.name, '?')})" for item in self.items]
        lines += [f"  error: {e}" for e in self.errors]
        return "\n".join(lines)


@dataclass(frozen=True)
class PluginCatalogue:
    """The built-in and third-party plugins of one kind.

    Attributes
    ----------
    kind : str
        What a plugin is, for messages (``"mutation operator"``).
    group : str
        The entry-point group.
    base : type
        The class every plugin instance must be an instance of.
    builtins : sequence
        The built-in instances, in order.
    warning : warning class
        Issued by :meth:`load` for each plugin that fails.
    """

    kind: str
    group: str
    base: type
    builtins: Sequence
    warning: type[Warning]

    def describe(self, ep: importlib.metadata.EntryPoint) -> str:
        """Where a plugin comes from, for messages: ``"entry point NAME = VALUE"``."""
        return f"entry point {ep.name} = {ep.value}"

    def instances(self, obj) -> list:
        """The plugin instances an entry point loaded to (TypeError if it is none of the accepted shapes)."""
        base = self.base
        if isinstance(obj, type) and issubclass(obj, base):
            return [obj()]
        if isinstance(obj, base):
            return [obj]
        if isinstance(obj, (str, bytes)) or not isinstance(obj, Iterable):
            raise TypeError(f"must load to a {base.__name__} (class or instance) or an iterable of them, "
                            f"got {type(obj).__name__}")
        return [o() if isinstance(o, type) and issubclass(o, base) else o for o in obj]

    def is_builtin(self, item) -> bool:
        """True for faultlab's own declaration of a built-in (skipped, not a duplicate)."""
        return type(item) in {type(b) for b in self.builtins}

    def problem(self, item, taken: dict[str, str], source: str) -> str | None:
        """What is wrong with a loaded item (None if nothing); ``taken``: name -> where it was defined."""
        if not isinstance(item, self.base):
            return f"yielded {type(item).__name__} {item!r}, not a {self.base.__name__}"
        name = getattr(item, "name", None)
        if not isinstance(name, str) or not _NAME.fullmatch(name):
            return f"{self.kind.split()[-1]} name {name!r} is not lower-case snake_case"
        description = getattr(item, "description", None)
        if not isinstance(description, str) or not description.strip() or "\n" in description.strip():
            return f"{self.kind.split()[-1]} {name!r} needs a one-line description"
        if name in taken:
            return f"duplicate {self.kind.split()[-1]} name {name!r} (already defined by {taken[name]})"
        return None

    def failure(self, plugin: str, source: str, error: str, *, loading: bool) -> PluginFailure:
        """The record of one failure: a plugin that did not load (``loading``) or an item it rejected."""
        return PluginFailure(plugin, source, error, kind=self.kind.replace(" ", "-"), loading=loading)

    def collect(self, items: list, sources: dict[str, str], errors: list) -> PluginLoad:
        """What :meth:`load` returns, from the items in load order, their sources and the failures."""
        return PluginLoad(items=tuple(items), sources=sources, errors=tuple(errors))

    def load(self, *, group: str | None = None, warn: bool = True) -> PluginLoad:
        """Discover the third-party plugins (in entry-point name order).

        Parameters
        ----------
        group : str, optional
            Entry-point group to read instead of :attr:`group`.
        warn : bool
            Issue :attr:`warning` for each plugin that fails (the failures are returned either way).

        Returns
        -------
        PluginLoad
            What :meth:`collect` makes of the result.
        """
        taken = {b.name: "faultlab (built-in)" for b in self.builtins}
        items: list = []
        errors: list = []
        eps = importlib.metadata.entry_points(group=group or self.group)
        for ep in sorted(eps, key=lambda e: (e.name, e.value, self.describe(e))):
            source = self.describe(ep)
            try:
                loaded = self.instances(ep.load())
            except Exception as exc:  # any import-time error of third-party code
                errors.append(self.failure(ep.name, source, f"{type(exc).__name__}: {exc}", loading=True))
                continue
            for item in loaded:
                if self.is_builtin(item):
                    continue  # faultlab's own declaration of its built-ins
                problem = self.problem(item, taken, source)
                if problem:
                    errors.append(self.failure(ep.name, source, problem, loading=False))
                    continue
                taken[item.name] = source
                items.append(item)
        if warn:
            for e in errors:
                warnings.warn(str(e), self.warning, stacklevel=2)
        return self.collect(items, {item.name: taken[item.name] for item in items}, errors)

    def all(self, *, plugins: bool = True) -> list:
        """The built-ins, then the plugins."""
        return list(self.builtins) + (list(self.load().items) if plugins else [])

    def get(self, name: str):
        """The plugin called ``name`` (built-in or third-party); :class:`~faultlab.errors.UnknownPluginError`
        naming the kind, the name and the known names (closest first) otherwise."""
        for item in self.builtins:
            if item.name == name:
                return item
        known = {item.name: item for item in self.all(plugins=True)}
        if name in known:
            return known[name]
        raise UnknownPluginError(self.kind, name, known)
