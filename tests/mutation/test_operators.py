"""Every mutation operator does what its examples say; arithmetic mutants evaluate like an independent oracle."""

import ast
import math
import operator as op

import libcst as cst
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.mutation.operators import BUILTIN_OPERATORS, ArithmeticOperator
from faultlab.mutation.registry import all_operators

OPERATORS = all_operators(plugins=True)
EXAMPLES = [(o.name, i) for o in OPERATORS for i in range(len(o.examples))]


def _operator(name):
    return next(o for o in OPERATORS if o.name == name)


@pytest.mark.parametrize("name, i", EXAMPLES)
def test_operator_example(name, i):
    """The one generic test of every operator's examples (built-in and plugin)."""
    operator = _operator(name)
    example = operator.examples[i]
    tree = cst.parse_module(example.before)
    points = list(operator.points(tree))
    mutated = [operator.apply(tree, p) for p in points]
    assert tuple(m.code for m in mutated) == example.after
    for m in mutated:
        # the text parses back to the very tree the operator built: parentheses are where they must be
        assert cst.parse_module(m.code).deep_equals(m), m.code
        compile(m.code, "<example>", "exec")
    assert tree.code == example.before  # applying a point never changes the original tree


def test_builtin_operators_are_documented_and_uniquely_named():
    names = [o.name for o in BUILTIN_OPERATORS]
    assert len(names) == len(set(names)) >= 18
    required = {"arithmetic", "comparison", "boolean", "constant", "off_by_one", "matmul", "transpose", "axis",
                "index", "slice", "arctan2", "trig", "sum_mean", "std_var", "function_removal", "unary_minus",
                "statement_deletion", "zero_return"}
    assert required <= set(names)
    for o in BUILTIN_OPERATORS:
        assert o.description and "\n" not in o.description
        assert o.examples and any(ex.after for ex in o.examples), f"{o.name} has no example that mutates"


def test_operators_leave_signatures_annotations_and_decorators_alone():
    source = ("@functools.lru_cache(maxsize=2 + 1)\n"
              "def f(x: np.ndarray = np.zeros(2)[0] * -1.0, *, n: int = 3 - 1) -> tuple[float, int]:\n"
              "    return 0\n")
    tree = cst.parse_module(source)
    for o in BUILTIN_OPERATORS:
        for p in o.points(tree):
            changed = o.apply(tree, p).code
            head = changed.splitlines()[:2]
            assert head == source.splitlines()[:2], f"{o.name} mutated the signature: {changed}"


# --------------------------------------------------------------------------- arithmetic vs an oracle

_OPS = {"+": ast.Add, "-": ast.Sub, "*": ast.Mult, "/": ast.Div}
_FUNCS = {ast.Add: op.add, ast.Sub: op.sub, ast.Mult: op.mul, ast.Div: op.truediv, ast.FloorDiv: op.floordiv}
# ArithmeticOperator's documented table, written out independently of its implementation
_TABLE = {ast.Add: (ast.Sub, ast.Mult), ast.Sub: (ast.Add,), ast.Mult: (ast.Div, ast.Add),
          ast.Div: (ast.Mult, ast.FloorDiv)}
_VALUES = {"a": 1.25, "b": 1.75, "c": 1.5, "d": 1.125}


def _expressions():
    leaves = st.sampled_from(sorted(_VALUES)).map(lambda n: ast.Name(id=n, ctx=ast.Load()))
    return st.recursive(leaves, lambda sub: st.builds(
        lambda left, o, right: ast.BinOp(left=left, op=_OPS[o](), right=right), sub, st.sampled_from(sorted(_OPS)),
        sub), max_leaves=7)


def _binops_preorder(node):
    if isinstance(node, ast.BinOp):
        yield node
        yield from _binops_preorder(node.left)
        yield from _binops_preorder(node.right)


def _evaluate(node):
    if isinstance(node, ast.Name):
        return _VALUES[node.id]
    return _FUNCS[type(node.op)](_evaluate(node.left), _evaluate(node.right))


@settings(max_examples=100, deadline=None)
@given(_expressions())
def test_arithmetic_mutants_compute_what_the_replaced_operator_computes(expr):
    source = f"def f(a, b, c, d):\n    return {ast.unparse(expr)}\n"
    expected = []
    for binop in _binops_preorder(expr):  # the oracle: replace one operator in the ast and evaluate
        original = binop.op
        for new in _TABLE[type(original)]:
            binop.op = new()
            try:
                expected.append(_evaluate(expr))
            except ZeroDivisionError:
                expected.append("ZeroDivisionError")
        binop.op = original
    got = []
    for text in ArithmeticOperator().mutate_source(source):
        namespace = {}
        exec(compile(text, "<mutant>", "exec"), namespace)
        try:
            got.append(namespace["f"](**_VALUES))
        except ZeroDivisionError:
            got.append("ZeroDivisionError")
    assert len(got) == len(expected)
    for g, e in zip(got, expected):
        assert g == e or (isinstance(g, float) and isinstance(e, float) and math.isnan(g) and math.isnan(e))
