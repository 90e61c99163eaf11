"""Oracles by name: the built-ins and third-party plugins.

A distribution adds oracles by declaring an entry point in the group ``faultlab.oracles``::

    [project.entry-points."faultlab.oracles"]
    mylab = "mylab.oracles:ORACLES"

The entry point loads to an :class:`~faultlab.oracles.oracle.Oracle` subclass (instantiated without
arguments) or instance, or an iterable of them (the rules of :class:`faultlab.plugins.PluginCatalogue`).
"""

from __future__ import annotations

from dataclasses import dataclass

from faultlab.errors import ConfigError
from faultlab.oracles.builtin import BUILTIN_ORACLES
from faultlab.oracles.oracle import Oracle
from faultlab.plugins import ORACLE_ENTRY_POINT_GROUP, PluginCatalogue, PluginLoad

__all__ = ["ORACLE_ENTRY_POINT_GROUP", "OraclePluginWarning", "OraclePlugins", "load_oracle_plugins",
           "all_oracles", "get_oracle"]

class OraclePluginWarning(UserWarning):
    """Issued when an oracle plugin fails to load."""


@dataclass(frozen=True)
class OraclePlugins(PluginLoad):
    """Result of :func:`load_oracle_plugins`."""

    @property
    def oracles(self) -> tuple[Oracle, ...]:
        return self.items


_CATALOGUE = PluginCatalogue(kind="oracle", group=ORACLE_ENTRY_POINT_GROUP, base=Oracle,
                             builtins=tuple(BUILTIN_ORACLES), error=ConfigError, warning=OraclePluginWarning,
                             result=OraclePlugins)

#: ``load_oracle_plugins(*, group=None, warn=True)``: the third-party oracles.
load_oracle_plugins = _CATALOGUE.load
#: ``all_oracles(*, plugins=True)``: the built-in oracles, then the plugin ones.
all_oracles = _CATALOGUE.all
#: ``get_oracle(name)``: the oracle called ``name``; ConfigError with close names otherwise.
get_oracle = _CATALOGUE.get
