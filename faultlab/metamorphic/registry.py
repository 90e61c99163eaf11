"""Metamorphic relations by name: the built-ins and third-party plugins.

A distribution adds relations by declaring an entry point in the group ``faultlab.metamorphic``::

    [project.entry-points."faultlab.metamorphic"]
    mylab = "mylab.relations:RELATIONS"

The entry point loads to a :class:`~faultlab.metamorphic.relation.MetamorphicRelation` subclass
(instantiated without arguments) or instance, or an iterable of them.  Names must be lower-case
``snake_case`` and unique.  faultlab declares its own built-ins in this group too; loading them
again from there is recognised and skipped.  A plugin that fails to load is reported (a warning)
and the others still load.
"""

from __future__ import annotations

import difflib
import importlib.metadata
import re
import warnings
from collections.abc import Iterable
from dataclasses import dataclass

from faultlab.errors import ConfigError
from faultlab.metamorphic.builtin import BUILTIN_RELATIONS
from faultlab.metamorphic.relation import MetamorphicRelation

__all__ = [
    "RELATION_ENTRY_POINT_GROUP",
    "RelationPluginWarning",
    "RelationPlugins",
    "load_relation_plugins",
    "all_relations",
    "get_relation",
]

#: Entry-point group of third-party metamorphic relations.
RELATION_ENTRY_POINT_GROUP = "faultlab.metamorphic"

_NAME = re.compile(r"[a-z][a-z0-9_]*")


class RelationPluginWarning(UserWarning):
    """Issued when a metamorphic-relation plugin fails to load."""


@dataclass(frozen=True)
class RelationPlugins:
    """Result of :func:`load_relation_plugins`: the relations that loaded and the failures."""

    relations: tuple[MetamorphicRelation, ...] = ()
    errors: tuple[str, ...] = ()


def _instances(obj) -> list:
    if isinstance(obj, type) and issubclass(obj, MetamorphicRelation):
        return [obj()]
    if isinstance(obj, MetamorphicRelation):
        return [obj]
    if isinstance(obj, (str, bytes)) or not isinstance(obj, Iterable):
        raise TypeError(f"must load to a MetamorphicRelation (class or instance) or an iterable of them, "
                        f"got {type(obj).__name__}")
    return [o() if isinstance(o, type) and issubclass(o, MetamorphicRelation) else o for o in obj]


def _problem(rel, taken: dict[str, str]) -> str | None:
    if not isinstance(rel, MetamorphicRelation):
        return f"yielded {type(rel).__name__} {rel!r}, not a MetamorphicRelation"
    name = getattr(rel, "name", None)
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        return f"relation name {name!r} is not lower-case snake_case"
    description = getattr(rel, "description", None)
    if not isinstance(description, str) or not description.strip() or "\n" in description.strip():
        return f"relation {name!r} needs a one-line description"
    if name in taken:
        return f"duplicate relation name {name!r} (already defined by {taken[name]})"
    return None


def load_relation_plugins(*, group: str = RELATION_ENTRY_POINT_GROUP, warn: bool = True) -> RelationPlugins:
    """Discover third-party relations through the entry-point group (in entry-point name order)."""
    builtin = {type(r) for r in BUILTIN_RELATIONS}
    taken = {r.name: "faultlab (built-in)" for r in BUILTIN_RELATIONS}
    relations: list[MetamorphicRelation] = []
    errors: list[str] = []
    for ep in sorted(importlib.metadata.entry_points(group=group), key=lambda e: (e.name, e.value)):
        source = f"entry point {ep.name} = {ep.value}"
        try:
            items = _instances(ep.load())
        except Exception as exc:  # any import-time error of third-party code
            errors.append(f"metamorphic-relation plugin {ep.name!r} ({source}) failed to load: "
                          f"{type(exc).__name__}: {exc}")
            continue
        for rel in items:
            if type(rel) in builtin:
                continue  # faultlab's own declaration of its built-ins
            problem = _problem(rel, taken)
            if problem:
                errors.append(f"metamorphic-relation plugin {ep.name!r} ({source}): {problem}")
                continue
            taken[rel.name] = source
            relations.append(rel)
    if warn:
        for e in errors:
            warnings.warn(e, RelationPluginWarning, stacklevel=2)
    return RelationPlugins(relations=tuple(relations), errors=tuple(errors))


def all_relations(*, plugins: bool = True) -> list[MetamorphicRelation]:
    """The built-in relations, then the plugin relations."""
    rels = list(BUILTIN_RELATIONS)
    if plugins:
        rels += list(load_relation_plugins().relations)
    return rels


def get_relation(name: str) -> MetamorphicRelation:
    """The relation called ``name`` (built-in or plugin); ConfigError with close names otherwise."""
    for rel in BUILTIN_RELATIONS:
        if rel.name == name:
            return rel
    known = {r.name: r for r in all_relations(plugins=True)}
    if name in known:
        return known[name]
    close = difflib.get_close_matches(str(name), list(known), n=3, cutoff=0.6)
    hint = f"; did you mean {' or '.join(map(repr, close))}?" if close else ""
    raise ConfigError(f"unknown metamorphic relation {name!r}{hint} Known relations: {', '.join(known)}")
