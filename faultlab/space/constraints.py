"""Constraints between equivalence classes: class combinations no test case may have.

Table I's classes can be combined freely: the scenario generator (Sec. VI) produces a test case
for every combination of its classes, so the paper's space has no constraint.  A space with
other classes may need some (e.g. a map too small for the largest step), and combinatorial
suites must then cover only the combinations that can occur.  A space file (or an experiment's
``[space]`` table) lists them as *forbidden combinations*::

    [constraints]
    forbid = [
      { map_size = "small", step_size = "large" },                  # one class per parameter
      { variance = "none", outlier_probability = ["low", "high"] },   # or a list of classes
    ]

An entry forbids every case whose class lies among the listed ones for *every* parameter the
entry names; it must name at least two parameters (a class that no case may have is removed from
the parameter instead).  Every class must still occur in some allowed case.  A malformed entry
raises one :class:`~faultlab.errors.ConfigError` naming the file and the key, e.g.
``x.toml: [constraints].forbid[0].map_size: unknown class 'tiny' (classes: small, medium, large)``.

:class:`ClassStructure` is the index form the suite builders and coverage measures work with:
the number of classes of every parameter and each constraint as (parameter index, forbidden
class indices).  A *partial row* gives a class index per parameter, ``-1`` where unassigned; it is
*allowed* when no constraint has all its parameters assigned to forbidden classes, and
*feasible* when it can be completed to an allowed full row.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from itertools import combinations, product
from typing import Any, Mapping, Sequence

import numpy as np

from faultlab.errors import ConfigError

__all__ = ["Constraint", "ClassStructure", "parse_constraints"]


@dataclass(frozen=True)
class Constraint:
    """One forbidden class combination.

    Attributes
    ----------
    classes : tuple of (str, tuple of str)
        Parameter name -> the class names forbidden together, in the space's parameter order.
    """

    classes: tuple[tuple[str, tuple[str, ...]], ...]

    @property
    def parameters(self) -> tuple[str, ...]:
        return tuple(p for p, _ in self.classes)

    def describe(self) -> str:
        """``map_size=small & step_size=large|medium``."""
        return " & ".join(f"{p}={'|'.join(cs)}" for p, cs in self.classes)

    def to_dict(self) -> dict[str, Any]:
        """The entry of ``[constraints].forbid`` (a class name, or a list of several)."""
        return {p: cs[0] if len(cs) == 1 else list(cs) for p, cs in self.classes}


@dataclass(frozen=True)
class ClassStructure:
    """Class counts and forbidden combinations of a space, as indices (hashable).

    Attributes
    ----------
    sizes : tuple of int
        Number of classes of every parameter, in parameter order.
    forbidden : tuple
        One entry per constraint: a tuple of ``(parameter index, frozenset of class indices)``.
    """

    sizes: tuple[int, ...]
    forbidden: tuple[tuple[tuple[int, frozenset[int]], ...], ...] = ()

    @property
    def n_parameters(self) -> int:
        return len(self.sizes)

    @cached_property
    def constrained(self) -> tuple[int, ...]:
        """Indices of the parameters named by some constraint."""
        return tuple(sorted({p for c in self.forbidden for p, _ in c}))

    @cached_property
    def _by_parameter(self) -> dict[int, tuple[int, ...]]:
        out: dict[int, list[int]] = {}
        for i, c in enumerate(self.forbidden):
            for p, _ in c:
                out.setdefault(p, []).append(i)
        return {p: tuple(v) for p, v in out.items()}

    # -- single rows ---------------------------------------------------------
    def _violates(self, row: Sequence[int], ci: int) -> bool:
        return all(row[p] >= 0 and row[p] in cs for p, cs in self.forbidden[ci])

    def allows(self, row: Sequence[int]) -> bool:
        """True if no constraint is violated by the assigned entries of ``row`` (-1 = unassigned)."""
        return not any(self._violates(row, ci) for ci in range(len(self.forbidden)))

    def feasible(self, row: Sequence[int]) -> bool:
        """True if the partial ``row`` can be completed to an allowed full row."""
        return self.complete(row) is not None

    def complete(self, row: Sequence[int]) -> tuple[int, ...] | None:
        """An allowed full row extending ``row`` (-1 = unassigned), or None if there is none.

        Depth-first search over the unassigned constrained parameters, classes in index order;
        unconstrained unassigned parameters get class 0.
        """
        r = [int(x) for x in row]
        if not self.allows(r):
            return None
        free = [p for p in self.constrained if r[p] < 0]
        if not self._search(r, free, 0):
            return None
        return tuple(x if x >= 0 else 0 for x in r)

    def _search(self, r: list[int], free: list[int], i: int) -> bool:
        if i == len(free):
            return True
        p = free[i]
        for c in range(self.sizes[p]):
            r[p] = c
            if not any(self._violates(r, ci) for ci in self._by_parameter.get(p, ())) \
                    and self._search(r, free, i + 1):
                return True
        r[p] = -1
        return False

    # -- many rows -------------------------------------------------------------
    def allowed_rows(self, rows: np.ndarray) -> np.ndarray:
        """Which full rows violate no constraint.

        Parameters
        ----------
        rows : ndarray, shape (n, n_parameters), int
            Class indices (-1 = outside every class, never forbidden).

        Returns
        -------
        ndarray, shape (n,), bool
        """
        rows = np.asarray(rows, dtype=np.int64).reshape(-1, self.n_parameters)
        ok = np.ones(rows.shape[0], dtype=bool)
        for c in self.forbidden:
            hit = np.ones(rows.shape[0], dtype=bool)
            for p, cs in c:
                hit &= np.isin(rows[:, p], np.fromiter(cs, dtype=np.int64, count=len(cs)))
            ok &= ~hit
        return ok

    def tuples(self, parameters: Sequence[int]) -> np.ndarray:
        """Every feasible combination of classes of ``parameters``, shape (m, len(parameters)).

        Without constraints this is the full product; otherwise the combinations that some
        allowed full row contains (in lexicographic order).
        """
        grid = np.array(list(product(*(range(self.sizes[p]) for p in parameters))), dtype=np.int64)
        grid = grid.reshape(-1, len(parameters))
        if not self.forbidden:
            return grid
        keep = np.ones(grid.shape[0], dtype=bool)
        row = [-1] * self.n_parameters
        for i, combo in enumerate(grid):
            for p, c in zip(parameters, combo):
                row[p] = int(c)
            keep[i] = self.feasible(row)
        return grid[keep]

    def interactions(self, strength: int) -> tuple[tuple[int, ...], ...]:
        """All sets of ``strength`` parameters, in lexicographic order."""
        return tuple(combinations(range(self.n_parameters), strength))

    def to_covertable(self) -> list[dict]:
        """The constraints as covertable conditions over integer factor keys (parameter indices)."""
        return [{"operator": "not", "condition": {"operator": "and", "conditions": [
            {"operator": "in", "left": p, "values": sorted(cs)} for p, cs in c]}} for c in self.forbidden]


# ---------------------------------------------------------------------------
# Parsing
# ---------------------------------------------------------------------------

def parse_constraints(raw: Any, parameters: Sequence, *, source: str) -> tuple[Constraint, ...]:
    """The ``[constraints]`` table of a space file.

    Parameters
    ----------
    raw : any
        The table (``{"forbid": [...]}``).
    parameters : sequence of Parameter
        The space's parameters (after class overrides), in order.
    source : str
        The file, for messages.

    Raises
    ------
    ConfigError
        Not a table, an unknown key, an entry that is not a table, names fewer than two
        parameters, an unknown parameter or class, a repeated class.
    """
    where = f"{source}: [constraints]"
    if not isinstance(raw, Mapping):
        raise ConfigError(f"{where}: expected a table with a 'forbid' list, got {type(raw).__name__}")
    unknown = [k for k in raw if k != "forbid"]
    if unknown:
        raise ConfigError(f"{where}.{unknown[0]}: unknown key (the constraints table has only 'forbid')")
    entries = raw.get("forbid", [])
    if not isinstance(entries, list):
        raise ConfigError(f"{where}.forbid: expected a list of tables such as "
                          f"[{{ map_size = \"small\", step_size = \"large\" }}], got {type(entries).__name__}")
    by_name = {p.name: p for p in parameters}
    order = [p.name for p in parameters]
    out = []
    for i, entry in enumerate(entries):
        w = f"{where}.forbid[{i}]"
        if not isinstance(entry, Mapping):
            raise ConfigError(f"{w}: expected a table parameter = class, got {type(entry).__name__}")
        if len(entry) < 2:
            raise ConfigError(f"{w}: a constraint names at least two parameters (to exclude a class "
                              f"altogether, remove it from the parameter's classes)")
        classes = {}
        for name, spec in entry.items():
            wp = f"{w}.{name}"
            if name not in by_name:
                raise ConfigError(f"{wp}: unknown parameter (known: {', '.join(order)})")
            names = spec if isinstance(spec, list) else [spec]
            if not names or not all(isinstance(n, str) for n in names):
                raise ConfigError(f"{wp}: expected a class name or a list of class names, got {spec!r}")
            if len(set(names)) != len(names):
                raise ConfigError(f"{wp}: a class appears twice")
            known = by_name[name].class_names
            for n in names:
                if n not in known:
                    raise ConfigError(f"{wp}: unknown class {n!r} (classes: {', '.join(known)})")
            classes[name] = tuple(n for n in known if n in names)
        out.append(Constraint(tuple((p, classes[p]) for p in order if p in classes)))
    return tuple(out)


def structure_of(parameters: Sequence, constraints: Sequence[Constraint]) -> ClassStructure:
    """The :class:`ClassStructure` of parameters with constraints (names resolved to indices)."""
    index = {p.name: i for i, p in enumerate(parameters)}
    forbidden = []
    for c in constraints:
        forbidden.append(tuple((index[p], frozenset(parameters[index[p]].class_names.index(n) for n in cs))
                               for p, cs in c.classes))
    return ClassStructure(tuple(p.n_classes for p in parameters), tuple(forbidden))


def check_constraints(parameters: Sequence, constraints: Sequence[Constraint], *, source: str) -> None:
    """Every constraint refers to existing classes and every class occurs in some allowed case.

    Raises
    ------
    ConfigError
        Naming the constraint or the class that no allowed case can have.
    """
    by_name = {p.name: p for p in parameters}
    for i, c in enumerate(constraints):
        for p, cs in c.classes:
            if p not in by_name or any(n not in by_name[p].class_names for n in cs):
                raise ConfigError(f"{source}: [constraints].forbid[{i}] ({c.describe()}) refers to a "
                                  f"parameter or class the space does not have")
    s = structure_of(parameters, constraints)
    for pi, p in enumerate(parameters):
        for ci, name in enumerate(p.class_names):
            row = [-1] * s.n_parameters
            row[pi] = ci
            if not s.feasible(row):
                raise ConfigError(f"{source}: [constraints] forbid every case with {p.name} = {name!r}; "
                                  f"remove the class or relax the constraints")
