"""Mutants of a SLAM's replaceable units: generation from source, and a mutant as a :class:`Fault`.

For every unit of a steps dataclass (:func:`faultlab.mutation.source.unit_sources`) and every
function it is built from (the unit and its private helpers), every operator's mutation points
become :class:`Mutant` records.  The source is parsed with libcst, a concrete syntax tree that
keeps every space, comment and parenthesis: a point's node has an exact line and column, so the
mutated function is the original text with just that node's text replaced, and the diff shows
the one change (an ``ast`` round trip would reformat the whole function).

A mutant is applied *in process*: :func:`mutant_fault` returns a :class:`~faultlab.faults.Fault`
whose replacement recompiles the unit from the mutated source in a copy of the unit's module
namespace (:meth:`faultlab.mutation.source.UnitSource.build`).  The replacement is a
module-level function bound to the steps type, the mutant id and a digest of the mutated source,
so the fault pickles to worker processes, which regenerate the mutant from the unit's source
(and refuse if that source changed since).

Ids are ``<unit>:<operator>:<n>`` for a mutant of the unit's own body and
``<unit>.<helper>:<operator>:<n>`` for a mutant of a helper built into that unit only; ``n``
counts the operator's points in that function from 1, in source order.
"""

from __future__ import annotations

import difflib
import functools
import hashlib
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from functools import cached_property

import libcst as cst
from libcst.metadata import MetadataWrapper, PositionProvider

from faultlab.errors import FaultError
from faultlab.faults.fault import Fault
from faultlab.mutation.operatorbase import MutationOperator, MutationPoint, node_code
from faultlab.mutation.registry import all_operators, get_operator
from faultlab.mutation.source import FunctionSource, UnitSource, unit_source, unit_sources

__all__ = ["Mutant", "MutantSet", "generate_mutants", "function_mutants", "mutant_fault", "build_mutant_unit"]

#: Provider part of the fault names of mutants (``mutant/<unit>.<operator>.<n>``).
FAULT_PROVIDER = "mutant"


@dataclass(frozen=True)
class Mutant:
    """One mutant: one operator applied at one point of one function of one unit.

    Attributes
    ----------
    id : str
        ``<unit>:<operator>:<n>`` (unit body) or ``<unit>.<helper>:<operator>:<n>`` (helper).
    unit : str
        The replaced unit (a field of the steps dataclass).
    function : str
        The mutated function: the unit's function or one of its helpers.
    operator : str
        The operator's name.
    index : int
        ``n``: the point's number among the operator's points in that function (from 1).
    line : int
        Line of the change in the original file.
    path : str
        The file, relative to the directory holding the top-level package.
    first_line : int
        Line of the function's first line in the file.
    description : str
        One line: what changed.
    original_source, mutated_source : str
        The function's source before and after.
    """

    id: str
    unit: str
    function: str
    operator: str
    index: int
    line: int
    path: str
    first_line: int
    description: str
    original_source: str = field(repr=False)
    mutated_source: str = field(repr=False)

    @cached_property
    def diff(self) -> str:
        """Unified diff of the file (``a/<path>``, ``b/<path>``, file line numbers; applies with ``patch -p1``)."""
        lines = difflib.unified_diff(self.original_source.splitlines(keepends=True),
                                     self.mutated_source.splitlines(keepends=True),
                                     fromfile=f"a/{self.path}", tofile=f"b/{self.path}", n=3)
        out = []
        offset = self.first_line - 1
        for line in lines:
            if line.startswith("@@"):
                line = _shift_hunk(line, offset)
            out.append(line if line.endswith("\n") else line + "\n\\ No newline at end of file\n")
        return "".join(out)

    @cached_property
    def change(self) -> str:
        """The first changed line, before and after: ``old  ->  new`` (stripped)."""
        a = self.original_source.splitlines()
        b = self.mutated_source.splitlines()
        matcher = difflib.SequenceMatcher(a=a, b=b, autojunk=False)
        for tag, i1, i2, j1, j2 in matcher.get_opcodes():
            if tag != "equal":
                old = a[i1].strip() if i1 < i2 else ""
                new = b[j1].strip() if j1 < j2 else ""
                return f"{old}  ->  {new}"
        return "(no change)"

    @property
    def digest(self) -> str:
        """First 16 hex digits of the SHA-256 of the mutated function's source."""
        return hashlib.sha256(self.mutated_source.encode()).hexdigest()[:16]

    @property
    def fault_name(self) -> str:
        """The name of this mutant as a fault: ``mutant/<id with ':' as '.'>``, lower case."""
        return f"{FAULT_PROVIDER}/" + self.id.replace(":", ".").replace("/", "-").lower()


def _shift_hunk(header: str, offset: int) -> str:
    """``@@ -a,b +c,d @@`` with ``offset`` added to ``a`` and ``c``."""
    parts = header.split()
    for i in (1, 2):
        sign, rest = parts[i][0], parts[i][1:]
        start, _, count = rest.partition(",")
        parts[i] = f"{sign}{int(start) + offset}" + (f",{count}" if count else "")
    return " ".join(parts) + "\n"


@dataclass(frozen=True, eq=False)
class MutantSet:
    """The mutants of a steps table.

    Attributes
    ----------
    steps_type : type
        The steps dataclass (e.g. ``FastSlamSteps``).
    mutants : tuple of Mutant
        In unit order, then function, operator and point order.
    sources : dict
        Unit name -> :class:`UnitSource` (the source the mutants were made from).
    skipped : dict
        Unit name -> why it has no mutants (no Python source).
    """

    steps_type: type
    mutants: tuple[Mutant, ...]
    sources: dict[str, UnitSource]
    skipped: dict[str, str] = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.mutants)

    def __iter__(self):
        return iter(self.mutants)

    @cached_property
    def by_id(self) -> dict[str, Mutant]:
        return {m.id: m for m in self.mutants}

    def get(self, mutant_id: str) -> Mutant:
        """The mutant with id (or fault name) ``mutant_id``; FaultError naming close ids otherwise."""
        if mutant_id in self.by_id:
            return self.by_id[mutant_id]
        for m in self.mutants:
            if m.fault_name == mutant_id:
                return m
        close = difflib.get_close_matches(mutant_id, list(self.by_id), n=3, cutoff=0.6)
        hint = f"; did you mean {' or '.join(map(repr, close))}?" if close else ""
        raise FaultError(f"unknown mutant {mutant_id!r}{hint} ({len(self.mutants)} mutants of "
                         f"{self.steps_type.__name__}; list them with `faultlab mutate list --all`)")

    def fault(self, mutant_id: str) -> Fault:
        """The mutant as a :class:`Fault` (see :func:`mutant_fault`)."""
        return mutant_fault(self.get(mutant_id), self.steps_type)


def _line_offsets(source: str) -> list[int]:
    offsets = [0]
    for line in source.splitlines(keepends=True):
        offsets.append(offsets[-1] + len(line))
    return offsets


@functools.lru_cache(maxsize=64)
def _parsed(source: str):
    """(tree, node positions, line offsets) of a function's source; shared helpers are parsed once."""
    tree = cst.parse_module(source)
    positions = MetadataWrapper(tree, unsafe_skip_copy=True).resolve(PositionProvider)
    return tree, positions, _line_offsets(source)


def _splice_text(point: MutationPoint) -> str | None:
    """Text of the replacement for splicing over the node's position, or None (use the tree)."""
    node, new = point.node, point.replacement
    if isinstance(node, cst.BaseExpression) and isinstance(new, cst.BaseExpression):
        k = len(node.lpar)
        if k:  # the node's own parentheses stay in the text; the replacement carries them
            if len(new.lpar) < k:
                return None
            new = new.with_changes(lpar=new.lpar[k:], rpar=new.rpar[:len(new.rpar) - k])
    elif isinstance(node, cst.BaseSmallStatement) and isinstance(new, cst.BaseSmallStatement):
        new = new.with_changes(semicolon=cst.MaybeSentinel.DEFAULT)
    else:
        return None
    text = node_code(new)
    return None if "\n" in text else text


def _first_changed_line(a: str, b: str) -> int:
    for i, (x, y) in enumerate(zip(a.splitlines(), b.splitlines())):
        if x != y:
            return i + 1
    return min(len(a.splitlines()), len(b.splitlines())) + 1


def function_mutants(unit: str, function: FunctionSource, operators: Sequence[MutationOperator], *,
                     is_unit: bool) -> list[Mutant]:
    """Every mutant of one function (the unit's own, or a helper built into ``unit``)."""
    source = function.source
    tree, positions, offsets = _parsed(source)
    prefix = unit if is_unit else f"{unit}.{function.name}"
    mutants = []
    for op in operators:
        fast = type(op).apply is MutationOperator.apply
        for n, point in enumerate(op.points(tree), 1):
            text = _splice_text(point) if fast and point.node in positions else None
            if text is not None:
                where = positions[point.node]
                start = offsets[where.start.line - 1] + where.start.column
                end = offsets[where.end.line - 1] + where.end.column
                mutated = source[:start] + text + source[end:]
                line = where.start.line
            else:
                mutated = op.apply(tree, point).code
                line = _first_changed_line(source, mutated)
            mutants.append(Mutant(
                id=f"{prefix}:{op.name}:{n}", unit=unit, function=function.name, operator=op.name, index=n,
                line=function.first_line + line - 1, path=function.display_path, first_line=function.first_line,
                description=f"{op.name}: {point.description}", original_source=source, mutated_source=mutated))
    return mutants


def generate_mutants(steps, *, operators: Iterable[MutationOperator | str] | None = None,
                     units: Iterable[str] | None = None, helpers: bool = True,
                     plugins: bool = True) -> MutantSet:
    """Every mutant of the units of a steps table.

    Parameters
    ----------
    steps : dataclass instance or class
        A frozen steps dataclass, e.g. :data:`faultlab.slam.REFERENCE_STEPS`.
    operators : iterable of MutationOperator or str, optional
        Operators (or their names); default: the built-ins and, with ``plugins``, plugin operators.
    units : iterable of str, optional
        Only these units (default: all).
    helpers : bool
        Also mutate each unit's private helpers (built into that unit only).
    plugins : bool
        Include operators from the ``faultlab.mutation_operators`` entry points.

    Returns
    -------
    MutantSet
    """
    ops = all_operators(plugins=plugins) if operators is None else [
        get_operator(o) if isinstance(o, str) else o for o in operators]
    sources, skipped = unit_sources(steps, helpers=helpers)
    steps_type = steps if isinstance(steps, type) else type(steps)
    if units is not None:
        wanted = list(units)
        known = set(sources) | set(skipped)
        unknown = [u for u in wanted if u not in known]
        if unknown:
            raise FaultError(f"unknown unit(s) {', '.join(map(repr, unknown))}; {steps_type.__name__} has: "
                             f"{', '.join(known)}")
        sources = {u: s for u, s in sources.items() if u in wanted}
        skipped = {u: s for u, s in skipped.items() if u in wanted}
    mutants: list[Mutant] = []
    for unit, src in sources.items():
        for i, function in enumerate(src.functions):
            mutants += function_mutants(unit, function, ops, is_unit=i == 0)
    return MutantSet(steps_type=steps_type, mutants=tuple(mutants), sources=sources, skipped=skipped)


# --------------------------------------------------------------------------- a mutant as a fault

def _parse_id(mutant_id: str) -> tuple[str, str | None, str, int]:
    try:
        where, operator, n = mutant_id.rsplit(":", 2)
        index = int(n)
    except ValueError:
        raise FaultError(f"malformed mutant id {mutant_id!r}: expected <unit>[.<helper>]:<operator>:<n>") from None
    unit, _, helper = where.partition(".")
    return unit, helper or None, operator, index


@functools.lru_cache(maxsize=256)
def _operator_mutants(unit: str, function: FunctionSource, operator: str, is_unit: bool) -> tuple[Mutant, ...]:
    return tuple(function_mutants(unit, function, [get_operator(operator)], is_unit=is_unit))


@functools.lru_cache(maxsize=512)
def _rebuild(steps_type: type, mutant_id: str, digest: str, original: Callable) -> tuple[Mutant, UnitSource]:
    unit, helper, operator, index = _parse_id(mutant_id)
    source = unit_source(unit, original, steps_type)
    function = source.function(helper or source.function_name)
    candidates = _operator_mutants(unit, function, operator, helper is None)
    if not 1 <= index <= len(candidates):
        raise FaultError(f"mutant {mutant_id!r} does not exist in the current source of {function.display_path} "
                         f"({len(candidates)} {operator} points in {function.name}); was the file changed?")
    mutant = candidates[index - 1]
    if mutant.digest != digest:
        raise FaultError(f"mutant {mutant_id!r} differs from the one generated earlier (source digest "
                         f"{mutant.digest} != {digest}); {function.display_path} changed since")
    return mutant, source


@functools.lru_cache(maxsize=256)
def build_mutant_unit(steps_type: type, mutant_id: str, digest: str, original: Callable) -> Callable:
    """The unit of mutant ``mutant_id`` compiled from source (the replacement of :func:`mutant_fault`).

    Compiled once per process and reused: a campaign applies the mutant to a fresh SLAM for every
    batch of its jobs.  The unit holds no state of its own (it runs in a copy of its module's
    namespace, like the original unit, which every SLAM shares too), so reusing it changes no result.

    Parameters
    ----------
    steps_type : type
        The steps dataclass the mutant belongs to.
    mutant_id : str
    digest : str
        :attr:`Mutant.digest` of the mutant as generated; the rebuilt mutant must match it.
    original : callable
        The unit being replaced (``Fault.patch`` passes it); its source is mutated.
    """
    mutant, source = _rebuild(steps_type, mutant_id, digest, original)
    return source.build({mutant.function: mutant.mutated_source}, filename=f"<mutant {mutant.id} of {mutant.path}>")


def mutant_fault(mutant: Mutant, steps_type: type) -> Fault:
    """The mutant as a :class:`~faultlab.faults.Fault` replacing unit :attr:`Mutant.unit` (picklable)."""
    rationale = (f"Automatically generated mutant {mutant.id}: the mutation operator {mutant.operator!r} applied "
                 f"once to {mutant.function}() at {mutant.path}:{mutant.line}: {mutant.change}. "
                 f"It replaces only unit {mutant.unit!r}.")
    return Fault(
        name=mutant.fault_name,
        step=mutant.unit,
        description=mutant.description,
        rationale=rationale,
        origin=f"faultlab mutation operator {mutant.operator!r} at {mutant.path}:{mutant.line}",
        replacement=functools.partial(build_mutant_unit, steps_type, mutant.id, mutant.digest),
    )
