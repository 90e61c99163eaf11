"""Mutation operators by name: the built-ins and third-party plugins.

A distribution adds operators by declaring an entry point in the group
``faultlab.mutation_operators``::

    [project.entry-points."faultlab.mutation_operators"]
    mylab = "mylab.operators:OPERATORS"

The entry point loads to a :class:`~faultlab.mutation.operatorbase.MutationOperator` subclass or
instance, or an iterable of them.  Operator names must be lower-case ``snake_case`` and unique
(they appear in mutant ids).  faultlab declares its own built-ins in this group too; loading them
again from there is recognised and skipped.  A plugin that fails to load is reported (a warning)
and the others still load.
"""

from __future__ import annotations

from faultlab.mutation.operatorbase import MutationOperator
from faultlab.mutation.operators import BUILTIN_OPERATORS
from faultlab.plugins import PluginCatalogue

__all__ = [
    "OPERATOR_ENTRY_POINT_GROUP",
    "OperatorPluginWarning",
    "load_operator_plugins",
    "all_operators",
    "get_operator",
]

#: Entry-point group of third-party mutation operators.
OPERATOR_ENTRY_POINT_GROUP = "faultlab.mutation_operators"


class OperatorPluginWarning(UserWarning):
    """Issued when a mutation operator plugin fails to load."""


_CATALOGUE = PluginCatalogue(kind="mutation operator", group=OPERATOR_ENTRY_POINT_GROUP, base=MutationOperator,
                             builtins=tuple(BUILTIN_OPERATORS), warning=OperatorPluginWarning)

#: ``load_operator_plugins(*, group=None, warn=True)``: discover the third-party mutation operators
#: (in entry-point name order); a :class:`~faultlab.plugins.PluginLoad`.
load_operator_plugins = _CATALOGUE.load
#: ``all_operators(*, plugins=True)``: the built-in mutation operators, then the plugin ones.
all_operators = _CATALOGUE.all
#: ``get_operator(name)``: the operator called ``name`` (built-in or plugin);
#: :class:`~faultlab.errors.UnknownPluginError` with close names otherwise.
get_operator = _CATALOGUE.get
