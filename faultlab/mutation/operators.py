"""The built-in mutation operators: classic ones and numpy-aware ones for numerical SLAM code.

Classic operators (arithmetic, comparison, boolean, constants, statement deletion) follow the
mutation-testing literature; the numpy-aware ones encode mistakes that are specific to array
code and that tools written for general Python do not know: a missing transpose, the wrong
axis or index, ``@`` confused with ``*``, ``arctan2`` arguments swapped, ``sin`` for ``cos``,
``sum`` for ``mean``, a forgotten ``exp``/``log``/``sqrt``, an in-place ufunc call (``out=``)
deleted.  Each operator's docstring lists exactly what it changes; its :attr:`examples` show
it on a small function.
"""

from __future__ import annotations

from collections.abc import Iterable

import libcst as cst

from faultlab.mutation.operatorbase import (
    MATH_NAMES,
    NUMPY_NAMES,
    MutationOperator,
    NodeOperator,
    OperatorExample,
    fix_operands,
    int_node,
    int_value,
    method_name,
    module_function,
    node_code,
    parenthesize,
)

__all__ = [
    "ArithmeticOperator",
    "ComparisonOperator",
    "BooleanOperator",
    "ConstantOperator",
    "OffByOneOperator",
    "MatmulOperator",
    "TransposeOperator",
    "AxisOperator",
    "IndexOperator",
    "SliceOperator",
    "Arctan2Operator",
    "TrigOperator",
    "SumMeanOperator",
    "StdVarOperator",
    "FunctionRemovalOperator",
    "UnaryMinusOperator",
    "StatementDeletionOperator",
    "ZeroReturnOperator",
    "ExtremumOperator",
    "RoundingOperator",
    "BUILTIN_OPERATORS",
]

Mutations = Iterable[tuple[cst.CSTNode, str]]


def _token(op: cst.CSTNode) -> str:
    """The operator token of a libcst operator class instance, e.g. ``"+="``."""
    return node_code(type(op)()).strip()


def _same_spacing(new_cls: type, op: cst.CSTNode) -> cst.CSTNode:
    """An instance of operator ``new_cls`` with the whitespace of ``op``."""
    return new_cls(whitespace_before=op.whitespace_before, whitespace_after=op.whitespace_after)


def _swap_operator(node: cst.CSTNode, new_cls: type) -> tuple[cst.CSTNode, str]:
    """``node`` with its ``operator`` replaced by a ``new_cls`` (same spacing), and the description."""
    return (node.with_changes(operator=_same_spacing(new_cls, node.operator)),
            f"`{_token(node.operator)}` -> `{_token(new_cls())}`")


def _rename(node: cst.Attribute, attr: str) -> cst.Attribute:
    return node.with_changes(attr=node.attr.with_changes(value=attr))


def _np(attr: str) -> cst.Attribute:
    return cst.Attribute(value=cst.Name("np"), attr=cst.Name(attr))


def _is_number(node: cst.CSTNode) -> bool:
    """A numeric literal, possibly with a unary minus."""
    if isinstance(node, (cst.Integer, cst.Float, cst.Imaginary)):
        return True
    return (isinstance(node, cst.UnaryOperation) and isinstance(node.operator, (cst.Minus, cst.Plus))
            and isinstance(node.expression, (cst.Integer, cst.Float, cst.Imaginary)))


def _with_element(node: cst.Tuple, i: int, value: cst.BaseExpression) -> cst.Tuple:
    """``node`` with the value of element ``i`` replaced."""
    elements = list(node.elements)
    elements[i] = elements[i].with_changes(value=value)
    return node.with_changes(elements=elements)


def _positional(call: cst.Call) -> list[cst.Arg]:
    return [a for a in call.args if a.keyword is None and not a.star]


def _sole_argument(call: cst.Call) -> cst.BaseExpression | None:
    """The argument of ``call`` if it has exactly one and that is positional (removing the call leaves it)."""
    args = _positional(call)
    return args[0].value if len(args) == 1 and len(call.args) == 1 else None


def _keywords(call: cst.Call) -> list[str]:
    return [a.keyword.value for a in call.args if a.keyword is not None]


def _called_attribute(node: cst.CSTNode, parent: cst.CSTNode | None, names: dict[str, str], *,
                      methods: bool = True) -> str | None:
    """The new name for ``np.<f>`` / ``math.<f>`` or (with ``methods``) a method ``x.<f>(...)`` in ``names``,
    else None."""
    if not isinstance(node, cst.Attribute) or node.attr.value not in names:
        return None
    if module_function(node, NUMPY_NAMES | MATH_NAMES) is not None:
        return names[node.attr.value]
    if methods and isinstance(parent, cst.Call) and parent.func is node:  # a method call on an array
        return names[node.attr.value]
    return None


def _swap_names(pairs: Iterable[tuple[str, str]]) -> dict[str, str]:
    table = {}
    for a, b in pairs:
        table[a], table[b] = b, a
    return table


# --------------------------------------------------------------------------- classic operators

class ArithmeticOperator(NodeOperator):
    """Arithmetic operator replacement.

    ``+`` -> ``-``, ``*``; ``-`` -> ``+``; ``*`` -> ``/``, ``+``; ``/`` -> ``*``, ``//``;
    ``**`` -> ``*``; ``//`` -> ``/``; the augmented forms ``+=`` <-> ``-=``, ``*=`` <-> ``/=``,
    ``**=`` -> ``*=``, ``//=`` -> ``/=``; and numpy's ufuncs ``np.add`` <-> ``np.subtract``,
    ``np.multiply`` <-> ``np.divide`` (also where the ufunc is only referenced, e.g. ``mul =
    np.multiply``).  Parentheses are added where the new operator binds differently.
    """

    name = "arithmetic"
    description = "replace + - * / ** // (plain, augmented, or numpy ufunc) by a confusable operator"
    _BINARY = {
        cst.Add: (cst.Subtract, cst.Multiply),
        cst.Subtract: (cst.Add,),
        cst.Multiply: (cst.Divide, cst.Add),
        cst.Divide: (cst.Multiply, cst.FloorDivide),
        cst.Power: (cst.Multiply,),
        cst.FloorDivide: (cst.Divide,),
    }
    _AUGMENTED = {
        cst.AddAssign: (cst.SubtractAssign,),
        cst.SubtractAssign: (cst.AddAssign,),
        cst.MultiplyAssign: (cst.DivideAssign,),
        cst.DivideAssign: (cst.MultiplyAssign,),
        cst.PowerAssign: (cst.MultiplyAssign,),
        cst.FloorDivideAssign: (cst.DivideAssign,),
    }
    _UFUNCS = {"add": ("subtract",), "subtract": ("add",), "multiply": ("divide",),
               "divide": ("multiply",), "true_divide": ("multiply",)}
    examples = (
        OperatorExample("def f(a, b):\n    return a + b * 2\n",
                        ("def f(a, b):\n    return a - b * 2\n",
                         "def f(a, b):\n    return a * (b * 2)\n",
                         "def f(a, b):\n    return a + b / 2\n",
                         "def f(a, b):\n    return a + (b + 2)\n")),
        OperatorExample("def f(a, b):\n    a -= b ** 2\n    return a // b\n",
                        ("def f(a, b):\n    a += b ** 2\n    return a // b\n",
                         "def f(a, b):\n    a -= b * 2\n    return a // b\n",
                         "def f(a, b):\n    a -= b ** 2\n    return a / b\n")),
        OperatorExample("def f(a, b, out):\n    mul = np.multiply\n    np.add(a, mul(a, b), out=out)\n",
                        ("def f(a, b, out):\n    mul = np.divide\n    np.add(a, mul(a, b), out=out)\n",
                         "def f(a, b, out):\n    mul = np.multiply\n    np.subtract(a, mul(a, b), out=out)\n")),
        OperatorExample("def f(x: int = 1 + 2) -> int:\n    return x\n", ()),
    )

    def mutations(self, node, parent) -> Mutations:
        if isinstance(node, cst.BinaryOperation) and type(node.operator) in self._BINARY:
            for new in self._BINARY[type(node.operator)]:
                changed, description = _swap_operator(node, new)
                yield fix_operands(changed), description
        elif isinstance(node, cst.AugAssign) and type(node.operator) in self._AUGMENTED:
            for new in self._AUGMENTED[type(node.operator)]:
                yield _swap_operator(node, new)
        else:
            f = module_function(node)
            for new in self._UFUNCS.get(f, ()):
                yield _rename(node, new), f"`np.{f}` -> `np.{new}`"


class ComparisonOperator(NodeOperator):
    """Relational operator replacement: each comparison by its boundary shift and its negation.

    ``<`` -> ``<=``, ``>=``; ``<=`` -> ``<``, ``>``; ``>`` -> ``>=``, ``<=``; ``>=`` -> ``>``,
    ``<``; ``==`` <-> ``!=``; ``is`` <-> ``is not``; ``in`` <-> ``not in``.  One mutant per
    comparison of a chain.
    """

    name = "comparison"
    description = "replace < <= > >= == != (is, in) by the boundary-shifted or negated comparison"
    _TABLE = {
        cst.LessThan: (cst.LessThanEqual, cst.GreaterThanEqual),
        cst.LessThanEqual: (cst.LessThan, cst.GreaterThan),
        cst.GreaterThan: (cst.GreaterThanEqual, cst.LessThanEqual),
        cst.GreaterThanEqual: (cst.GreaterThan, cst.LessThan),
        cst.Equal: (cst.NotEqual,),
        cst.NotEqual: (cst.Equal,),
        cst.Is: (cst.IsNot,),
        cst.IsNot: (cst.Is,),
        cst.In: (cst.NotIn,),
        cst.NotIn: (cst.In,),
    }
    examples = (
        OperatorExample("def f(a, b):\n    return a < b\n",
                        ("def f(a, b):\n    return a <= b\n", "def f(a, b):\n    return a >= b\n")),
        OperatorExample("def f(a, b):\n    if a is not None and a != b:\n        return 1\n",
                        ("def f(a, b):\n    if a is None and a != b:\n        return 1\n",
                         "def f(a, b):\n    if a is not None and a == b:\n        return 1\n")),
    )

    def mutations(self, node, parent) -> Mutations:
        if not isinstance(node, cst.Comparison):
            return
        for i, target in enumerate(node.comparisons):
            op = target.operator
            for new in self._TABLE.get(type(op), ()):
                targets = list(node.comparisons)
                targets[i], description = _swap_operator(target, new)
                yield node.with_changes(comparisons=targets), description


class BooleanOperator(NodeOperator):
    """Boolean operator replacement, with numpy's element-wise forms.

    ``and`` <-> ``or``; ``not x`` -> ``x``; ``~x`` -> ``x`` (numpy's logical not); ``&`` <-> ``|``
    (numpy's logical and/or); ``np.logical_and`` <-> ``np.logical_or``; ``np.logical_not(x)`` ->
    ``x``; ``True`` <-> ``False``.
    """

    name = "boolean"
    description = "swap and/or (also & | and np.logical_*), remove not/~, flip True/False"
    examples = (
        OperatorExample("def f(a, b):\n    return a and not b\n",
                        ("def f(a, b):\n    return a or not b\n", "def f(a, b):\n    return a and b\n")),
        OperatorExample("def f(m, n):\n    return ~m & n | np.logical_not(m)\n",
                        ("def f(m, n):\n    return ~m & n & np.logical_not(m)\n",
                         "def f(m, n):\n    return ~m | n | np.logical_not(m)\n",
                         "def f(m, n):\n    return m & n | np.logical_not(m)\n",
                         "def f(m, n):\n    return ~m & n | m\n")),
        OperatorExample("def f(a):\n    return np.asarray(a, copy=False)\n",
                        ("def f(a):\n    return np.asarray(a, copy=True)\n",)),
    )

    def mutations(self, node, parent) -> Mutations:
        if isinstance(node, cst.BooleanOperation):
            changed, description = _swap_operator(node, cst.Or if isinstance(node.operator, cst.And) else cst.And)
            yield fix_operands(changed), description
        elif isinstance(node, cst.BinaryOperation) and isinstance(node.operator, (cst.BitAnd, cst.BitOr)):
            changed, description = _swap_operator(
                node, cst.BitOr if isinstance(node.operator, cst.BitAnd) else cst.BitAnd)
            yield fix_operands(changed), description
        elif isinstance(node, cst.UnaryOperation) and isinstance(node.operator, (cst.Not, cst.BitInvert)):
            yield node.expression, f"`{_token(node.operator)}` removed"
        elif isinstance(node, cst.Call) and module_function(node.func) == "logical_not":
            only = _sole_argument(node)
            if only is not None:
                yield only, "`np.logical_not` removed"
        elif module_function(node) in ("logical_and", "logical_or"):
            new = "logical_or" if node.attr.value == "logical_and" else "logical_and"
            yield _rename(node, new), f"`np.{node.attr.value}` -> `np.{new}`"
        elif isinstance(node, cst.Name) and node.value in ("True", "False"):
            new = "False" if node.value == "True" else "True"
            yield node.with_changes(value=new), f"`{node.value}` -> `{new}`"


class ConstantOperator(NodeOperator):
    """Floating-point constants scaled: ``c`` -> ``2 c``, ``c / 2``, ``-c``, ``0.0``.

    A literal with a unary minus counts as one constant (``-0.5`` -> ``-1.0``, ``-0.25``,
    ``0.5``, ``0.0``); replacements equal to the original value are skipped.  Integers are left
    to :class:`OffByOneOperator`.
    """

    name = "constant"
    description = "scale a float constant by 2 or 0.5, flip its sign, or replace it by 0"
    examples = (
        OperatorExample("def f(x):\n    return 0.5 * x ** 2\n",
                        ("def f(x):\n    return 1.0 * x ** 2\n", "def f(x):\n    return 0.25 * x ** 2\n",
                         "def f(x):\n    return -0.5 * x ** 2\n", "def f(x):\n    return 0.0 * x ** 2\n")),
        OperatorExample("def f(x):\n    return x ** -2.0 + 0.0\n",
                        ("def f(x):\n    return x ** -4.0 + 0.0\n", "def f(x):\n    return x ** -1.0 + 0.0\n",
                         "def f(x):\n    return x ** 2.0 + 0.0\n", "def f(x):\n    return x ** 0.0 + 0.0\n")),
    )

    def mutations(self, node, parent) -> Mutations:
        value = _float_value(node)
        if value is None:
            return
        if isinstance(node, cst.Float) and isinstance(parent, cst.UnaryOperation):
            return  # handled as the signed literal
        seen = {value}
        for label, new in (("x2", 2.0 * value), ("x0.5", 0.5 * value), ("sign", -value), ("zero", 0.0)):
            if new in seen:
                continue
            seen.add(new)
            yield _float_node(new), f"`{node_code(node)}` -> `{_float_text(new)}` ({label})"


def _float_value(node: cst.CSTNode) -> float | None:
    if isinstance(node, cst.Float):
        return float(node.value)
    if (isinstance(node, cst.UnaryOperation) and isinstance(node.operator, cst.Minus)
            and isinstance(node.expression, cst.Float) and not node.expression.lpar):
        return -float(node.expression.value)
    return None


def _float_text(value: float) -> str:
    return repr(float(value))


def _float_node(value: float) -> cst.BaseExpression:
    if value < 0 or (value == 0 and str(value).startswith("-")):
        return cst.UnaryOperation(operator=cst.Minus(), expression=cst.Float(_float_text(-value)))
    return cst.Float(_float_text(value))


def _is_index_position(node: cst.CSTNode, parent: cst.CSTNode | None) -> bool:
    """An integer that is a subscript index, a slice bound or an ``axis=`` value (own operators)."""
    if isinstance(parent, (cst.Index, cst.Slice)):
        return True
    return isinstance(parent, cst.Arg) and parent.keyword is not None and parent.keyword.value == "axis"


class OffByOneOperator(NodeOperator):
    """Integer constants off by one: ``n`` -> ``n + 1``, ``n - 1`` (as literals).

    Subscript indices, slice bounds and ``axis=`` values are left to :class:`IndexOperator`,
    :class:`SliceOperator` and :class:`AxisOperator`.
    """

    name = "off_by_one"
    description = "change an integer constant by +1 or -1 (not indices, slice bounds or axes)"
    examples = (
        OperatorExample("def f(x, n):\n    return x[n - 1] * 2\n",
                        ("def f(x, n):\n    return x[n - 2] * 2\n", "def f(x, n):\n    return x[n - 0] * 2\n",
                         "def f(x, n):\n    return x[n - 1] * 3\n", "def f(x, n):\n    return x[n - 1] * 1\n")),
        OperatorExample("def f(x):\n    return np.sum(x[0], axis=-1) + -1\n",
                        ("def f(x):\n    return np.sum(x[0], axis=-1) + 0\n",
                         "def f(x):\n    return np.sum(x[0], axis=-1) + -2\n")),
    )

    def mutations(self, node, parent) -> Mutations:
        value = int_value(node)
        if value is None or _is_index_position(node, parent):
            return
        if isinstance(node, cst.Integer) and isinstance(parent, cst.UnaryOperation):
            return  # handled as the signed literal
        for new in (value + 1, value - 1):
            yield int_node(new), f"`{node_code(node)}` -> `{new}`"


# --------------------------------------------------------------------------- numpy-aware operators

class MatmulOperator(NodeOperator):
    """Matrix product confused with the element-wise product.

    ``@`` <-> ``*`` (``*`` only between two non-literal operands), ``@=`` <-> ``*=``, and
    ``np.dot`` / ``np.matmul`` -> ``np.multiply``.
    """

    name = "matmul"
    description = "swap @ and * (matrix vs element-wise product); np.dot/np.matmul -> np.multiply"
    examples = (
        OperatorExample("def f(A, B):\n    return A @ B * 2.0\n",
                        ("def f(A, B):\n    return A * B * 2.0\n",)),
        OperatorExample("def f(A, B):\n    return np.dot(A, B) + A * B\n",
                        ("def f(A, B):\n    return np.multiply(A, B) + A * B\n",
                         "def f(A, B):\n    return np.dot(A, B) + A @ B\n")),
    )

    def mutations(self, node, parent) -> Mutations:
        if isinstance(node, cst.BinaryOperation):
            if isinstance(node.operator, cst.MatrixMultiply):
                yield _swap_operator(node, cst.Multiply)
            elif (isinstance(node.operator, cst.Multiply)
                  and not _is_number(node.left) and not _is_number(node.right)):
                yield _swap_operator(node, cst.MatrixMultiply)
        elif isinstance(node, cst.AugAssign):
            if isinstance(node.operator, cst.MatrixMultiplyAssign):
                yield _swap_operator(node, cst.MultiplyAssign)
            elif isinstance(node.operator, cst.MultiplyAssign) and not _is_number(node.value):
                yield _swap_operator(node, cst.MatrixMultiplyAssign)
        elif module_function(node) in ("dot", "matmul"):
            yield _rename(node, "multiply"), f"`np.{node.attr.value}` -> `np.multiply`"


class TransposeOperator(NodeOperator):
    """A transpose forgotten: ``x.T`` -> ``x``; ``x.transpose(...)``, ``x.swapaxes(...)`` -> ``x``;
    ``np.transpose(x, ...)``, ``np.swapaxes(x, ...)``, ``np.moveaxis(x, ...)`` -> ``x``."""

    name = "transpose"
    description = "remove a transpose (.T, transpose, swapaxes, moveaxis)"
    _FUNCS = ("transpose", "swapaxes", "moveaxis")
    examples = (
        OperatorExample("def f(A, B):\n    return A.T @ np.swapaxes(B, -1, -2)\n",
                        ("def f(A, B):\n    return A @ np.swapaxes(B, -1, -2)\n",
                         "def f(A, B):\n    return A.T @ B\n")),
        OperatorExample("def f(buf):\n    return buf.transpose(2, 1, 0)[..., 0]\n",
                        ("def f(buf):\n    return buf[..., 0]\n",)),
    )

    def mutations(self, node, parent) -> Mutations:
        if (isinstance(node, cst.Attribute) and node.attr.value == "T"
                and not (isinstance(parent, cst.Call) and parent.func is node)):
            yield node.value, "`.T` removed"
        elif isinstance(node, cst.Call):
            f = module_function(node.func)
            if f in self._FUNCS:
                args = _positional(node)
                if args:
                    yield args[0].value, f"`np.{f}(...)` removed"
            elif method_name(node) in self._FUNCS:
                yield node.func.value, f"`.{node.func.attr.value}(...)` removed"


class AxisOperator(NodeOperator):
    """The wrong axis: an ``axis=`` integer literal replaced by the others of 0, 1, -1."""

    name = "axis"
    description = "change axis=0/1/-1 to another of 0, 1, -1"
    examples = (
        OperatorExample("def f(x):\n    return x.sum(axis=1)\n",
                        ("def f(x):\n    return x.sum(axis=0)\n", "def f(x):\n    return x.sum(axis=-1)\n")),
        OperatorExample("def f(x):\n    return np.take(x, [0], axis=-1)\n",
                        ("def f(x):\n    return np.take(x, [0], axis=0)\n",
                         "def f(x):\n    return np.take(x, [0], axis=1)\n")),
    )

    def mutations(self, node, parent) -> Mutations:
        if not (isinstance(parent, cst.Arg) and parent.value is node and parent.keyword is not None
                and parent.keyword.value == "axis"):
            return
        value = int_value(node)
        if value is None:
            return
        for new in (0, 1, -1):
            if new != value:
                yield int_node(new), f"`axis={value}` -> `axis={new}`"


class IndexOperator(NodeOperator):
    """The wrong index: integer subscripts ``0`` <-> ``1``, ``-1`` (and ``i`` -> ``i - 1`` for ``i >= 2``),
    and two adjacent integer indices swapped (``H[..., 0, 1]`` -> ``H[..., 1, 0]``)."""

    name = "index"
    description = "change an integer subscript (0 <-> 1, -1) or swap two integer subscripts"
    examples = (
        OperatorExample("def f(x):\n    return x[:, 2]\n",
                        ("def f(x):\n    return x[:, 0]\n", "def f(x):\n    return x[:, 1]\n",
                         "def f(x):\n    return x[:, -1]\n")),
        OperatorExample("def f(S):\n    return S[..., 0, 1]\n",
                        ("def f(S):\n    return S[..., 1, 0]\n",
                         "def f(S):\n    return S[..., 1, 1]\n", "def f(S):\n    return S[..., -1, 1]\n",
                         "def f(S):\n    return S[..., 0, 0]\n", "def f(S):\n    return S[..., 0, -1]\n")),
    )

    def mutations(self, node, parent) -> Mutations:
        if isinstance(node, cst.Subscript):
            ints = [i for i, el in enumerate(node.slice)
                    if isinstance(el.slice, cst.Index) and int_value(el.slice.value) is not None]
            for a, b in zip(ints, ints[1:]):
                va, vb = int_value(node.slice[a].slice.value), int_value(node.slice[b].slice.value)
                if va == vb:
                    continue
                elements = list(node.slice)
                elements[a] = elements[a].with_changes(slice=elements[a].slice.with_changes(value=int_node(vb)))
                elements[b] = elements[b].with_changes(slice=elements[b].slice.with_changes(value=int_node(va)))
                yield node.with_changes(slice=elements), f"indices `{va}, {vb}` swapped"
        elif isinstance(parent, cst.Index) and parent.value is node:
            value = int_value(node)
            if value is None:
                return
            candidates = [v for v in (0, 1, -1) if v != value]
            if value >= 2:
                candidates.append(value - 1)
            for new in dict.fromkeys(candidates):
                yield int_node(new), f"index `{value}` -> `{new}`"


class SliceOperator(NodeOperator):
    """Slice bounds off by one: each given bound ``b`` -> ``b - 1``, ``b + 1``; a reversing step
    ``[::-1]`` removed."""

    name = "slice"
    description = "move a slice bound by -1 or +1; drop a reversing step [::-1]"
    examples = (
        OperatorExample("def f(x, n):\n    return x[1:n]\n",
                        ("def f(x, n):\n    return x[0:n]\n", "def f(x, n):\n    return x[2:n]\n",
                         "def f(x, n):\n    return x[1:n - 1]\n", "def f(x, n):\n    return x[1:n + 1]\n")),
        OperatorExample("def f(shape):\n    return tuple(shape)[::-1]\n",
                        ("def f(shape):\n    return tuple(shape)[:]\n",)),
    )

    def mutations(self, node, parent) -> Mutations:
        if isinstance(node, cst.Subscript):
            for i, el in enumerate(node.slice):
                s = el.slice
                if isinstance(s, cst.Slice) and s.step is not None and int_value(s.step) == -1:
                    elements = list(node.slice)
                    elements[i] = el.with_changes(slice=cst.Slice(lower=s.lower, upper=s.upper))
                    yield node.with_changes(slice=elements), "reversing step `::-1` removed"
        elif isinstance(parent, cst.Slice) and node is not parent.step and (
                node is parent.lower or node is parent.upper):
            value = int_value(node)
            for delta in (-1, 1):
                if value is not None:
                    new = int_node(value + delta)
                else:
                    new = cst.BinaryOperation(left=node, operator=cst.Add() if delta > 0 else cst.Subtract(),
                                              right=cst.Integer("1"))
                    new = fix_operands(new)
                yield new, f"slice bound `{node_code(node)}` {'+' if delta > 0 else '-'} 1"


class Arctan2Operator(NodeOperator):
    """``np.arctan2(y, x)`` -> ``np.arctan2(x, y)`` (also ``math.atan2``)."""

    name = "arctan2"
    description = "swap the two arguments of arctan2/atan2"
    examples = (
        OperatorExample("def f(dx, dy):\n    return np.arctan2(dy, dx) - math.atan2(1.0, 2.0)\n",
                        ("def f(dx, dy):\n    return np.arctan2(dx, dy) - math.atan2(1.0, 2.0)\n",
                         "def f(dx, dy):\n    return np.arctan2(dy, dx) - math.atan2(2.0, 1.0)\n")),
    )

    def mutations(self, node, parent) -> Mutations:
        if not isinstance(node, cst.Call):
            return
        f = module_function(node.func, NUMPY_NAMES | MATH_NAMES)
        if f not in ("arctan2", "atan2"):
            return
        args = list(node.args)
        if len(args) < 2 or any(a.keyword is not None or a.star for a in args[:2]):
            return
        args[0], args[1] = args[0].with_changes(value=args[1].value), args[1].with_changes(value=args[0].value)
        yield node.with_changes(args=args), f"`{f}(y, x)` -> `{f}(x, y)`"


class _RenameOperator(NodeOperator):
    """Swap function names of numpy/math (and, with :attr:`_METHODS`, array methods) according to a table."""

    _TABLE: dict[str, str] = {}
    #: Also rename array methods (``x.sum()``), not only ``np.`` / ``math.`` functions.
    _METHODS: bool = True

    def mutations(self, node, parent) -> Mutations:
        new = _called_attribute(node, parent, self._TABLE, methods=self._METHODS)
        if new is not None:
            old = node.attr.value
            prefix = "." if module_function(node, NUMPY_NAMES | MATH_NAMES) is None else f"{node.value.value}."
            yield _rename(node, new), f"`{prefix}{old}` -> `{prefix}{new}`"


class TrigOperator(_RenameOperator):
    """``sin`` <-> ``cos`` (``np.`` and ``math.``)."""

    name = "trig"
    description = "swap sin and cos"
    _TABLE = _swap_names([("sin", "cos")])
    _METHODS = False
    examples = (
        OperatorExample("def f(v, th):\n    return v * np.cos(th), v * math.sin(th)\n",
                        ("def f(v, th):\n    return v * np.sin(th), v * math.sin(th)\n",
                         "def f(v, th):\n    return v * np.cos(th), v * math.cos(th)\n")),
    )


class SumMeanOperator(_RenameOperator):
    """``sum`` <-> ``mean`` as numpy functions (``np.sum``, ``np.nansum``) and array methods."""

    name = "sum_mean"
    description = "swap sum and mean (numpy functions and array methods)"
    _TABLE = _swap_names([("sum", "mean"), ("nansum", "nanmean")])
    examples = (
        OperatorExample("def f(x):\n    return np.sum(x) + x.mean(axis=1)\n",
                        ("def f(x):\n    return np.mean(x) + x.mean(axis=1)\n",
                         "def f(x):\n    return np.sum(x) + x.sum(axis=1)\n")),
        OperatorExample("def f(x):\n    return sum(x) + x.sum\n", ()),
    )


class StdVarOperator(_RenameOperator):
    """``std`` <-> ``var`` as numpy functions and array methods (a standard deviation used as a variance)."""

    name = "std_var"
    description = "swap std and var (numpy functions and array methods)"
    _TABLE = _swap_names([("std", "var"), ("nanstd", "nanvar")])
    examples = (
        OperatorExample("def f(x):\n    return np.std(x) / x.var()\n",
                        ("def f(x):\n    return np.var(x) / x.var()\n", "def f(x):\n    return np.std(x) / x.std()\n")),
    )


class ExtremumOperator(_RenameOperator):
    """``min`` <-> ``max``: ``np.minimum``/``np.maximum``, ``np.min``/``np.max``, ``np.argmin``/``np.argmax``
    (and ``nan`` forms, array methods)."""

    name = "extremum"
    description = "swap minimum and maximum (minimum/maximum, min/max, argmin/argmax)"
    _TABLE = _swap_names([("minimum", "maximum"), ("min", "max"), ("amin", "amax"), ("argmin", "argmax"),
                          ("nanmin", "nanmax"), ("nanargmin", "nanargmax"), ("fmin", "fmax")])
    examples = (
        OperatorExample("def f(w, n):\n    return np.minimum(w, n - 1), w.argmax()\n",
                        ("def f(w, n):\n    return np.maximum(w, n - 1), w.argmax()\n",
                         "def f(w, n):\n    return np.minimum(w, n - 1), w.argmin()\n")),
    )


class RoundingOperator(_RenameOperator):
    """``floor`` <-> ``ceil`` (``np.`` and ``math.``; e.g. the interval an angle wrap maps to)."""

    name = "rounding"
    description = "swap floor and ceil"
    _TABLE = _swap_names([("floor", "ceil")])
    _METHODS = False
    examples = (
        OperatorExample("def f(t):\n    return np.floor(t, out=t)\n",
                        ("def f(t):\n    return np.ceil(t, out=t)\n",)),
    )


class FunctionRemovalOperator(NodeOperator):
    """A forgotten ``exp``, ``log`` or ``sqrt``: the call is replaced by its argument.

    ``np.exp(x)`` -> ``x`` (also ``np.log``, ``np.sqrt`` and the ``math`` forms).  A numpy call
    with more arguments (``np.sqrt(q, out=d)``) becomes the identity ufunc ``np.positive(q,
    out=d)``, so the output array is still written.
    """

    name = "function_removal"
    description = "remove exp/log/sqrt: replace the call by its argument"
    _FUNCS = ("exp", "log", "sqrt")
    examples = (
        OperatorExample("def f(a, b):\n    return c * np.exp(a + b) - math.log(b)\n",
                        ("def f(a, b):\n    return c * (a + b) - math.log(b)\n",
                         "def f(a, b):\n    return c * np.exp(a + b) - b\n")),
        OperatorExample("def f(q, d):\n    np.sqrt(q, out=d)\n",
                        ("def f(q, d):\n    np.positive(q, out=d)\n",)),
    )

    def mutations(self, node, parent) -> Mutations:
        if not isinstance(node, cst.Call):
            return
        f = module_function(node.func, NUMPY_NAMES | MATH_NAMES)
        if f not in self._FUNCS:
            return
        only = _sole_argument(node)
        if only is not None:
            yield only, f"`{node.func.value.value}.{f}` removed"
        elif module_function(node.func) is not None and _positional(node):
            yield (node.with_changes(func=_rename(node.func, "positive")),
                   f"`np.{f}` -> `np.positive` (removed, output still written)")


class UnaryMinusOperator(NodeOperator):
    """A sign error: a unary minus removed, or added to an assigned or returned value.

    ``-x`` -> ``x`` and ``np.negative(x)`` -> ``x`` (``np.positive`` if it has ``out=``);
    ``y = e`` -> ``y = -(e)`` and ``return a, b`` -> ``return -a, b`` / ``return a, -b``.
    Literal numbers are left to :class:`ConstantOperator` and :class:`OffByOneOperator`;
    augmented assignments to :class:`ArithmeticOperator`.
    """

    name = "unary_minus"
    description = "remove a unary minus, or negate an assigned or returned value"
    examples = (
        OperatorExample("def f(a, b):\n    c = -a\n    return c, a + b\n",
                        ("def f(a, b):\n    c = a\n    return c, a + b\n",
                         "def f(a, b):\n    c = -a\n    return -c, a + b\n",
                         "def f(a, b):\n    c = -a\n    return c, -(a + b)\n")),
        OperatorExample("def f(h, out):\n    x, y = h\n    np.negative(h, out=out)\n    z = 1.0\n",
                        ("def f(h, out):\n    x, y = h\n    np.positive(h, out=out)\n    z = 1.0\n",)),
    )

    def mutations(self, node, parent) -> Mutations:
        if (isinstance(node, cst.UnaryOperation) and isinstance(node.operator, cst.Minus)
                and not _is_number(node)):
            yield node.expression, "unary `-` removed"
        elif isinstance(node, cst.Call) and module_function(node.func) == "negative":
            only = _sole_argument(node)
            if only is not None:
                yield only, "`np.negative` removed"
            elif _positional(node):
                yield node.with_changes(func=_rename(node.func, "positive")), "`np.negative` -> `np.positive`"
        elif isinstance(parent, cst.Assign) and parent.value is node:
            if all(isinstance(t.target, cst.Name | cst.Subscript | cst.Attribute) for t in parent.targets):
                yield from self._negate(node)
        elif isinstance(parent, cst.Return) and parent.value is node:
            if isinstance(node, cst.Tuple):
                for i, el in enumerate(node.elements):
                    for value, description in self._negate(el.value):
                        yield _with_element(node, i, value), f"returned value {i + 1} negated"
            else:
                yield from self._negate(node)

    @staticmethod
    def _negate(node) -> Mutations:
        if _is_number(node) or isinstance(node, (cst.Tuple, cst.SimpleString, cst.List, cst.Dict)):
            return
        if isinstance(node, cst.Name) and node.value in ("None", "True", "False"):
            return
        if isinstance(node, cst.UnaryOperation) and isinstance(node.operator, cst.Minus):
            return
        yield cst.UnaryOperation(operator=cst.Minus(), expression=parenthesize(node)), "value negated"


def _has_out(call: cst.CSTNode) -> bool:
    return isinstance(call, cst.Call) and "out" in _keywords(call)


class StatementDeletionOperator(NodeOperator):
    """A lost assignment: an assignment, an augmented assignment, or an in-place numpy call
    (a call with ``out=``, numpy's way of assigning) is replaced by ``pass``."""

    name = "statement_deletion"
    description = "delete an assignment, augmented assignment or in-place (out=) numpy call"
    examples = (
        OperatorExample("def f(a):\n    b = a * 2\n    b += 1\n    print(b)\n    return b\n",
                        ("def f(a):\n    pass\n    b += 1\n    print(b)\n    return b\n",
                         "def f(a):\n    b = a * 2\n    pass\n    print(b)\n    return b\n")),
        OperatorExample("def f(t):\n    np.floor(t, out=t); t[0] = 1\n",
                        ("def f(t):\n    pass; t[0] = 1\n", "def f(t):\n    np.floor(t, out=t); pass\n")),
    )

    def mutations(self, node, parent) -> Mutations:
        if isinstance(node, (cst.Assign, cst.AugAssign)) or (
                isinstance(node, cst.AnnAssign) and node.value is not None) or (
                isinstance(node, cst.Expr) and _has_out(node.value)):
            text = node_code(node.with_changes(semicolon=cst.MaybeSentinel.DEFAULT)).strip()
            first = text.splitlines()[0] + (" ..." if "\n" in text else "")
            yield cst.Pass(semicolon=node.semicolon), f"`{first}` deleted"


class ZeroReturnOperator(NodeOperator):
    """A result never computed: a returned value ``x`` -> ``np.zeros_like(x)``; for a returned
    tuple, one mutant per element."""

    name = "zero_return"
    description = "return zeros of the same shape (np.zeros_like) instead of a returned value"
    examples = (
        OperatorExample("def f(a, b):\n    return a\n",
                        ("def f(a, b):\n    return np.zeros_like(a)\n",)),
        OperatorExample("def f(a, b):\n    if a is None:\n        return None\n    return a, b + 1\n",
                        ("def f(a, b):\n    if a is None:\n        return None\n    return np.zeros_like(a), b + 1\n",
                         "def f(a, b):\n    if a is None:\n        return None\n    return a, np.zeros_like(b + 1)\n")),
    )

    @staticmethod
    def _zeros(value: cst.BaseExpression) -> cst.Call:
        return cst.Call(func=_np("zeros_like"), args=[cst.Arg(value=value.with_changes(lpar=[], rpar=[])
                                                              if getattr(value, "lpar", None) else value)])

    def mutations(self, node, parent) -> Mutations:
        if not (isinstance(parent, cst.Return) and parent.value is node):
            return
        if isinstance(node, cst.Name) and node.value == "None":
            return
        if isinstance(node, cst.Tuple):
            for i, el in enumerate(node.elements):
                if not isinstance(el, cst.StarredElement):
                    yield _with_element(node, i, self._zeros(el.value)), f"returned value {i + 1} -> zeros"
        else:
            yield self._zeros(node), "returned value -> zeros"


#: Every built-in operator, in the order mutants are generated.
BUILTIN_OPERATORS: tuple[MutationOperator, ...] = (
    ArithmeticOperator(),
    ComparisonOperator(),
    BooleanOperator(),
    ConstantOperator(),
    OffByOneOperator(),
    MatmulOperator(),
    TransposeOperator(),
    AxisOperator(),
    IndexOperator(),
    SliceOperator(),
    Arctan2Operator(),
    TrigOperator(),
    SumMeanOperator(),
    StdVarOperator(),
    ExtremumOperator(),
    RoundingOperator(),
    FunctionRemovalOperator(),
    UnaryMinusOperator(),
    StatementDeletionOperator(),
    ZeroReturnOperator(),
)
