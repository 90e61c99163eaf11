"""Oracles by name: the built-ins and third-party plugins.

A distribution adds oracles by declaring an entry point in the group ``faultlab.oracles``::

    [project.entry-points."faultlab.oracles"]
    mylab = "mylab.oracles:ORACLES"

The entry point loads to an :class:`~faultlab.oracles.oracle.Oracle` subclass (instantiated without
arguments) or instance, or an iterable of them (the rules of :class:`faultlab.plugins.PluginCatalogue`).
"""

from __future__ import annotations

from faultlab.oracles.builtin import BUILTIN_ORACLES
from faultlab.oracles.oracle import Oracle
from faultlab.plugins import PluginCatalogue

__all__ = ["ORACLE_ENTRY_POINT_GROUP", "OraclePluginWarning", "load_oracle_plugins",
           "all_oracles", "get_oracle"]

#: Entry-point group of third-party oracles.
ORACLE_ENTRY_POINT_GROUP = "faultlab.oracles"


class OraclePluginWarning(UserWarning):
    """Issued when an oracle plugin fails to load."""


_CATALOGUE = PluginCatalogue(kind="oracle", group=ORACLE_ENTRY_POINT_GROUP, base=Oracle,
                             builtins=tuple(BUILTIN_ORACLES), warning=OraclePluginWarning)

#: ``load_oracle_plugins(*, group=None, warn=True)``: the third-party oracles.
load_oracle_plugins = _CATALOGUE.load
#: ``all_oracles(*, plugins=True)``: the built-in oracles, then the plugin ones.
all_oracles = _CATALOGUE.all
#: ``get_oracle(name)``: the oracle called ``name``; :class:`~faultlab.errors.UnknownPluginError` otherwise.
get_oracle = _CATALOGUE.get
