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

from faultlab.metamorphic.relation import MetamorphicRelation
from faultlab.metamorphic.builtin import BUILTIN_RELATIONS
from faultlab.plugins import PluginCatalogue

__all__ = [
    "RELATION_ENTRY_POINT_GROUP",
    "RelationPluginWarning",
    "load_relation_plugins",
    "all_relations",
    "get_relation",
]

#: Entry-point group of third-party metamorphic relations.
RELATION_ENTRY_POINT_GROUP = "faultlab.metamorphic"


class RelationPluginWarning(UserWarning):
    """Issued when a metamorphic relation plugin fails to load."""


_CATALOGUE = PluginCatalogue(kind="metamorphic relation", group=RELATION_ENTRY_POINT_GROUP,
                             base=MetamorphicRelation, builtins=tuple(BUILTIN_RELATIONS),
                             warning=RelationPluginWarning)

#: ``load_relation_plugins(*, group=None, warn=True)``: discover the third-party metamorphic
#: relations (in entry-point name order); a :class:`~faultlab.plugins.PluginLoad`.
load_relation_plugins = _CATALOGUE.load
#: ``all_relations(*, plugins=True)``: the built-in metamorphic relations, then the plugin ones.
all_relations = _CATALOGUE.all
#: ``get_relation(name)``: the relation called ``name`` (built-in or plugin);
#: :class:`~faultlab.errors.UnknownPluginError` with close names otherwise.
get_relation = _CATALOGUE.get
