"""The operator contract: traversal, parentheses, node replacement."""

import libcst as cst
import pytest

from faultlab.mutation.operatorbase import (
    MutationOperator,
    MutationPoint,
    NodeOperator,
    fits,
    int_value,
    module_function,
    parenthesize,
    precedence,
    walk,
)


class _NegateNames(NodeOperator):
    """Test operator: every name ``x`` read in an expression -> ``-x``."""

    name = "negate_names"
    description = "negate a name"

    def mutations(self, node, parent):
        if isinstance(node, cst.Name) and not isinstance(parent, (cst.Attribute, cst.Call, cst.AssignTarget,
                                                                   cst.FunctionDef)):
            yield cst.UnaryOperation(operator=cst.Minus(), expression=node), f"`{node.value}` negated"


def test_walk_skips_signature_and_decorators_and_keeps_source_order():
    tree = cst.parse_module("@deco(k)\ndef f(p: T = d) -> R:\n    return a + b * c\n")
    names = [n.value for n, _ in walk(tree) if isinstance(n, cst.Name)]
    assert names == ["f", "a", "b", "c"]  # no k, p, T, d, R
    assert walk(tree) is walk(tree)  # remembered per tree


def test_node_operator_adds_parentheses_only_where_the_place_needs_them():
    src = "def f(a, b, c):\n    x = a\n    return b ** c\n"
    out = _NegateNames().mutate_source(src)
    assert out == ["def f(a, b, c):\n    x = -a\n    return b ** c\n",
                   "def f(a, b, c):\n    x = a\n    return (-b) ** c\n",  # -b ** c would be -(b ** c)
                   "def f(a, b, c):\n    x = a\n    return b ** -c\n"]


def test_apply_replaces_by_identity_and_leaves_the_tree_unchanged():
    tree = cst.parse_module("def f(a):\n    return a + a\n")
    points = list(_NegateNames().points(tree))
    assert len(points) == 2 and points[0].node is not points[1].node
    assert _NegateNames().apply(tree, points[1]).code == "def f(a):\n    return a + -a\n"
    assert tree.code == "def f(a):\n    return a + a\n"


def test_abstract_operator_needs_points():
    with pytest.raises(TypeError):
        MutationOperator()


def test_precedence_and_parenthesize():
    expr = cst.parse_expression
    assert precedence(expr("a + b")) < precedence(expr("a * b")) < precedence(expr("-a")) < precedence(expr("a ** b"))
    assert precedence(expr("(a + b)")) == precedence(expr("a"))
    assert parenthesize(expr("a + b")).lpar and not parenthesize(expr("f(a)")).lpar
    # ``a - b`` standing where ``c`` stood in ``x - c`` needs parentheses; in ``c - x`` it does not
    left = expr("x - c")
    assert cst.Module([]).code_for_node(fits(expr("a - b"), left, left.right)) == "(a - b)"
    assert cst.Module([]).code_for_node(fits(expr("a - b"), left, left.left)) == "a - b"


def test_name_helpers():
    assert module_function(cst.parse_expression("np.sin")) == "sin"
    assert module_function(cst.parse_expression("x.sin")) is None
    assert int_value(cst.parse_expression("-3")) == -3 and int_value(cst.parse_expression("0x10")) == 16
    assert int_value(cst.parse_expression("1.0")) is None


def test_points_are_frozen_records():
    node = cst.Name("a")
    p = MutationPoint(node, cst.Name("b"), "a -> b")
    with pytest.raises(Exception):
        p.description = "x"
