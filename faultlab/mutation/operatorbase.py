"""The mutation-operator contract and the tree helpers the built-in operators share.

A mutation operator knows one kind of small syntactic change (``+`` -> ``-``, ``np.sin`` ->
``np.cos``, ...).  Given the concrete syntax tree (libcst) of one function it yields
:class:`MutationPoint` records, each naming a node of that tree and the node that replaces it;
:meth:`MutationOperator.apply` turns a point into the mutated tree.  Operators see only source
text: they cannot know types or shapes, so a change that cannot run (a shape mismatch, an
unbound name) is left for the pre-campaign screening to classify as *stillborn*.

Every operator carries :class:`OperatorExample` pairs (a function before, every function the
operator makes of it, in order); one generic test runs them for all operators, built-in or
plugin.  Third-party operators are discovered through the entry-point group
``faultlab.mutation_operators`` (:mod:`faultlab.mutation.registry`).

Only the executable body of a function is mutated: decorators, parameters (with their
defaults) and annotations are skipped by :class:`NodeOperator`.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import ClassVar

import libcst as cst

__all__ = [
    "MutationPoint",
    "OperatorExample",
    "MutationOperator",
    "NodeOperator",
    "node_code",
    "module_function",
    "parenthesize",
    "precedence",
    "fits",
    "fix_operands",
    "method_name",
    "int_value",
    "int_node",
    "walk",
    "NUMPY_NAMES",
    "MATH_NAMES",
]

#: Names under which numpy is conventionally imported (operators recognise ``np.sin`` etc.).
NUMPY_NAMES: frozenset[str] = frozenset({"np", "numpy"})
#: Names of the standard-library math module.
MATH_NAMES: frozenset[str] = frozenset({"math"})

_EMPTY = cst.Module(body=[])


def node_code(node: cst.CSTNode) -> str:
    """Source text of one node (no indentation context; used for single-line nodes)."""
    return _EMPTY.code_for_node(node)


@dataclass(frozen=True, eq=False)
class MutationPoint:
    """One possible mutation: replace ``node`` (a node of the tree given to the operator) by ``replacement``.

    Attributes
    ----------
    node : libcst.CSTNode
        The node that changes, by identity (a node of the tree passed to
        :meth:`MutationOperator.points`).
    replacement : libcst.CSTNode
        What replaces it.
    description : str
        One line, e.g. ``"`+` -> `-`"``.
    """

    node: cst.CSTNode
    replacement: cst.CSTNode
    description: str


@dataclass(frozen=True)
class OperatorExample:
    """A function before and every function the operator makes of it, in the order of the points.

    Attributes
    ----------
    before : str
        Source of one function.
    after : tuple of str
        The mutated sources, one per mutation point, in the order :meth:`MutationOperator.points`
        yields them.  Empty if the operator must leave ``before`` alone.
    """

    before: str
    after: tuple[str, ...]


class MutationOperator(ABC):
    """A kind of small syntactic change, applied one occurrence at a time.

    Subclasses set :attr:`name` (lower-case snake_case, unique among all operators: it is part
    of mutant ids), :attr:`description` (one line) and :attr:`examples`, and implement
    :meth:`points`.  :meth:`apply` replaces the point's node by its replacement; override
    it only for changes that are not a node replacement.
    """

    #: Stable name used in mutant ids (``<unit>:<operator>:<n>``) and on the command line.
    name: ClassVar[str]
    #: One line: what the operator changes.
    description: ClassVar[str]
    #: Examples run by the generic operator test.
    examples: ClassVar[tuple[OperatorExample, ...]] = ()

    @abstractmethod
    def points(self, tree: cst.Module) -> Iterator[MutationPoint]:
        """Every mutation point of ``tree`` (a module holding one function), in source order."""

    def apply(self, tree: cst.Module, point: MutationPoint) -> cst.Module:
        """``tree`` with ``point.node`` replaced by ``point.replacement`` (``tree`` is unchanged)."""
        return tree.deep_replace(point.node, point.replacement)

    def mutate_source(self, source: str) -> list[str]:
        """Every mutated source of the function ``source`` (one per point, in order)."""
        tree = cst.parse_module(source)
        return [self.apply(tree, p).code for p in self.points(tree)]

    def __repr__(self) -> str:
        return f"<mutation operator {self.name}>"


# --------------------------------------------------------------------------- precedence

# Python's operator precedence, low to high (Language Reference 6.17); atoms are highest.
_BINARY = {
    cst.BitOr: 6, cst.BitXor: 7, cst.BitAnd: 8, cst.LeftShift: 9, cst.RightShift: 9,
    cst.Add: 10, cst.Subtract: 10,
    cst.Multiply: 11, cst.Divide: 11, cst.FloorDivide: 11, cst.Modulo: 11, cst.MatrixMultiply: 11,
    cst.Power: 13,
}
_ATOM = 16
_PRIMARY = 15
_UNARY = 12


def precedence(node: cst.CSTNode) -> int:
    """Binding strength of an expression as written (parenthesised expressions are atoms)."""
    if getattr(node, "lpar", None):
        return _ATOM
    if isinstance(node, cst.BinaryOperation):
        return _BINARY[type(node.operator)]
    if isinstance(node, cst.UnaryOperation):
        return 4 if isinstance(node.operator, cst.Not) else _UNARY
    if isinstance(node, cst.BooleanOperation):
        return 3 if isinstance(node.operator, cst.And) else 2
    if isinstance(node, cst.Comparison):
        return 5
    if isinstance(node, cst.IfExp):
        return 1
    if isinstance(node, (cst.Lambda, cst.NamedExpr)):
        return 0
    if isinstance(node, (cst.Call, cst.Subscript, cst.Attribute)):
        return _PRIMARY
    if isinstance(node, cst.Await):
        return 14
    if isinstance(node, cst.Tuple):  # an unparenthesised tuple binds loosest of all
        return 0
    return _ATOM


def _operand_needs(parent: cst.CSTNode, node: cst.CSTNode) -> int:
    """The least precedence an expression needs to stand where ``node`` stands in ``parent``."""
    if isinstance(parent, cst.BinaryOperation):
        p = _BINARY[type(parent.operator)]
        right = parent.right is node
        if isinstance(parent.operator, cst.Power):  # right-associative; -x allowed on the right
            return _UNARY if right else p + 1
        return p + 1 if right else p
    if isinstance(parent, cst.BooleanOperation):
        p = 3 if isinstance(parent.operator, cst.And) else 2
        return p + 1 if parent.right is node else p
    if isinstance(parent, cst.UnaryOperation):
        return 5 if isinstance(parent.operator, cst.Not) else _UNARY
    if isinstance(parent, cst.Comparison) or isinstance(parent, cst.ComparisonTarget):
        return 6
    if isinstance(parent, cst.Attribute) and parent.value is node:
        return _PRIMARY
    if isinstance(parent, cst.Subscript) and parent.value is node:
        return _PRIMARY
    if isinstance(parent, cst.Call) and parent.func is node:
        return _PRIMARY
    if isinstance(parent, cst.Await):
        return _PRIMARY
    if isinstance(parent, (cst.Element, cst.StarredElement, cst.Index)):
        return 1
    return 0


def parenthesize(node: cst.BaseExpression) -> cst.BaseExpression:
    """``node`` in parentheses, unless it already is or is an atom or primary."""
    if precedence(node) >= _PRIMARY:
        return node
    return node.with_changes(lpar=[cst.LeftParen()], rpar=[cst.RightParen()])


def fits(node: cst.BaseExpression, parent: cst.CSTNode | None, original: cst.CSTNode) -> cst.BaseExpression:
    """``node`` ready to stand where ``original`` stands in ``parent``.

    Keeps the parentheses ``original`` was written with and adds a pair where the new expression
    binds more loosely than its place requires (``c * (a + b)`` rather than ``c * a + b``).
    """
    lpar = getattr(original, "lpar", None)
    if lpar:
        if getattr(node, "lpar", None):
            return node
        return node.with_changes(lpar=lpar, rpar=original.rpar)
    if parent is not None and precedence(node) < _operand_needs(parent, original):
        return node.with_changes(lpar=[cst.LeftParen()], rpar=[cst.RightParen()])
    return node


def fix_operands(node: cst.BinaryOperation | cst.BooleanOperation) -> cst.BaseExpression:
    """Parenthesise operands of a binary node whose operator changed, so it parses back the same."""
    left, right = node.left, node.right
    if precedence(left) < _operand_needs(node, left):
        left = left.with_changes(lpar=[cst.LeftParen()], rpar=[cst.RightParen()])
    if precedence(right) < _operand_needs(node, right):
        right = right.with_changes(lpar=[cst.LeftParen()], rpar=[cst.RightParen()])
    return node.with_changes(left=left, right=right)


# --------------------------------------------------------------------------- name helpers

def module_function(node: cst.CSTNode, modules: frozenset[str] = NUMPY_NAMES) -> str | None:
    """``"sin"`` for ``np.sin`` (an attribute of one of ``modules``), else None."""
    if (isinstance(node, cst.Attribute) and isinstance(node.value, cst.Name)
            and node.value.value in modules and not node.value.lpar):
        return node.attr.value
    return None


def method_name(node: cst.CSTNode) -> str | None:
    """``"sum"`` for a method call ``x.sum(...)`` on anything but a module name, else None."""
    if isinstance(node, cst.Call) and isinstance(node.func, cst.Attribute):
        value = node.func.value
        if isinstance(value, cst.Name) and value.value in NUMPY_NAMES | MATH_NAMES:
            return None
        return node.func.attr.value
    return None


def int_value(node: cst.CSTNode) -> int | None:
    """The value of an integer literal, ``-`` literals included; None for anything else."""
    if isinstance(node, cst.Integer):
        return int(node.value, 0)
    if (isinstance(node, cst.UnaryOperation) and isinstance(node.operator, cst.Minus)
            and isinstance(node.expression, cst.Integer) and not node.expression.lpar):
        return -int(node.expression.value, 0)
    return None


def int_node(value: int) -> cst.BaseExpression:
    """An integer literal (a unary minus for negative values)."""
    if value < 0:
        return cst.UnaryOperation(operator=cst.Minus(), expression=cst.Integer(str(-value)))
    return cst.Integer(str(value))


# --------------------------------------------------------------------------- traversal

_SKIPPED = (cst.Annotation, cst.Parameters, cst.Decorator)


class _Walker(cst.CSTVisitor):
    """Pre-order walk that records every node with its parent, skipping annotations and signatures."""

    def __init__(self) -> None:
        self.stack: list[cst.CSTNode] = []
        self.nodes: list[tuple[cst.CSTNode, cst.CSTNode | None]] = []

    def on_visit(self, node: cst.CSTNode) -> bool:
        if isinstance(node, _SKIPPED):
            self.stack.append(node)
            return False
        self.nodes.append((node, self.stack[-1] if self.stack else None))
        self.stack.append(node)
        return True

    def on_leave(self, original_node: cst.CSTNode) -> None:
        self.stack.pop()


_WALKS: dict[int, tuple[cst.CSTNode, list]] = {}
_WALKS_KEPT = 64


def walk(tree: cst.CSTNode) -> list[tuple[cst.CSTNode, cst.CSTNode | None]]:
    """``(node, parent)`` for every node of ``tree`` in source order, function signatures skipped.

    The walk of the last few trees is remembered (every operator walks the same tree; a libcst
    traversal costs milliseconds).  Trees are immutable, so a remembered walk stays valid.
    """
    hit = _WALKS.get(id(tree))
    if hit is not None and hit[0] is tree:
        return hit[1]
    walker = _Walker()
    tree.visit(walker)
    if len(_WALKS) >= _WALKS_KEPT:
        _WALKS.pop(next(iter(_WALKS)))
    _WALKS[id(tree)] = (tree, walker.nodes)
    return walker.nodes


class NodeOperator(MutationOperator):
    """An operator that looks at one node at a time (with its parent).

    Subclasses implement :meth:`mutations`, yielding ``(replacement, description)`` for a node;
    the base class walks the function body in source order and keeps the parentheses the
    replacement needs in its place.
    """

    @abstractmethod
    def mutations(self, node: cst.CSTNode, parent: cst.CSTNode | None) -> Iterable[tuple[cst.CSTNode, str]]:
        """Replacements of ``node`` (an empty iterable for nodes the operator ignores)."""

    def points(self, tree: cst.Module) -> Iterator[MutationPoint]:
        for node, parent in walk(tree):
            for replacement, description in self.mutations(node, parent):
                if isinstance(replacement, cst.BaseExpression) and isinstance(node, cst.BaseExpression):
                    replacement = fits(replacement, parent, node)
                yield MutationPoint(node, replacement, description)
