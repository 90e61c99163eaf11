"""Mutation operators by name: the built-ins and third-party plugins.

A distribution adds operators by declaring an entry point in the group
``faultlab.mutation_operators``::

    [project.entry-points."faultlab.mutation_operators"]
    mylab = "mylab.operators:OPERATORS"

The entry point loads to a :class:`~faultlab.mutation.operator.MutationOperator` subclass or
instance, or an iterable of them.  Operator names must be lower-case ``snake_case`` and unique
(they appear in mutant ids).  faultlab declares its own built-ins in this group too; loading them
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

from faultlab.errors import FaultError
from faultlab.mutation.operator import MutationOperator
from faultlab.mutation.operators import BUILTIN_OPERATORS

__all__ = [
    "OPERATOR_ENTRY_POINT_GROUP",
    "OperatorPluginWarning",
    "OperatorPlugins",
    "load_operator_plugins",
    "all_operators",
    "get_operator",
]

#: Entry-point group of third-party mutation operators.
OPERATOR_ENTRY_POINT_GROUP = "faultlab.mutation_operators"

_NAME = re.compile(r"[a-z][a-z0-9_]*")


class OperatorPluginWarning(UserWarning):
    """Issued when a mutation-operator plugin fails to load."""


@dataclass(frozen=True)
class OperatorPlugins:
    """Result of :func:`load_operator_plugins`: the operators that loaded and the failures."""

    operators: tuple[MutationOperator, ...] = ()
    errors: tuple[str, ...] = ()


def _instances(obj) -> list:
    if isinstance(obj, type) and issubclass(obj, MutationOperator):
        return [obj()]
    if isinstance(obj, MutationOperator):
        return [obj]
    if isinstance(obj, (str, bytes)) or not isinstance(obj, Iterable):
        raise TypeError(f"must load to a MutationOperator (class or instance) or an iterable of them, "
                        f"got {type(obj).__name__}")
    return [o() if isinstance(o, type) and issubclass(o, MutationOperator) else o for o in obj]


def _problem(op, taken: dict[str, str]) -> str | None:
    if not isinstance(op, MutationOperator):
        return f"yielded {type(op).__name__} {op!r}, not a MutationOperator"
    name = getattr(op, "name", None)
    if not isinstance(name, str) or not _NAME.fullmatch(name):
        return f"operator name {name!r} is not lower-case snake_case"
    description = getattr(op, "description", None)
    if not isinstance(description, str) or not description.strip() or "\n" in description.strip():
        return f"operator {name!r} needs a one-line description"
    if name in taken:
        return f"duplicate operator name {name!r} (already defined by {taken[name]})"
    return None


def load_operator_plugins(*, group: str = OPERATOR_ENTRY_POINT_GROUP, warn: bool = True) -> OperatorPlugins:
    """Discover third-party mutation operators through the entry-point group (in entry-point name order)."""
    builtin = {type(op) for op in BUILTIN_OPERATORS}
    taken = {op.name: "faultlab (built-in)" for op in BUILTIN_OPERATORS}
    operators: list[MutationOperator] = []
    errors: list[str] = []
    for ep in sorted(importlib.metadata.entry_points(group=group), key=lambda e: (e.name, e.value)):
        source = f"entry point {ep.name} = {ep.value}"
        try:
            items = _instances(ep.load())
        except Exception as exc:  # any import-time error of third-party code
            errors.append(f"mutation-operator plugin {ep.name!r} ({source}) failed to load: "
                          f"{type(exc).__name__}: {exc}")
            continue
        for op in items:
            if type(op) in builtin:
                continue  # faultlab's own declaration of its built-ins
            problem = _problem(op, taken)
            if problem:
                errors.append(f"mutation-operator plugin {ep.name!r} ({source}): {problem}")
                continue
            taken[op.name] = source
            operators.append(op)
    if warn:
        for e in errors:
            warnings.warn(e, OperatorPluginWarning, stacklevel=2)
    return OperatorPlugins(operators=tuple(operators), errors=tuple(errors))


def all_operators(*, plugins: bool = True) -> list[MutationOperator]:
    """The built-in operators, then the plugin operators."""
    ops = list(BUILTIN_OPERATORS)
    if plugins:
        ops += list(load_operator_plugins().operators)
    return ops


def get_operator(name: str) -> MutationOperator:
    """The operator called ``name`` (built-in or plugin); FaultError with close names otherwise."""
    for op in BUILTIN_OPERATORS:
        if op.name == name:
            return op
    known = {op.name: op for op in all_operators(plugins=True)}
    if name in known:
        return known[name]
    close = difflib.get_close_matches(str(name), list(known), n=3, cutoff=0.6)
    hint = f"; did you mean {' or '.join(map(repr, close))}?" if close else ""
    raise FaultError(f"unknown mutation operator {name!r}{hint} Known operators: {', '.join(known)}")
