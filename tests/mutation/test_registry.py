"""Operators by name; third-party operators through the entry-point group faultlab.mutation_operators."""

import sys
import textwrap

import libcst as cst
import pytest

from faultlab.errors import FaultError
from faultlab.mutation.operators import BUILTIN_OPERATORS
from faultlab.mutation.registry import (
    OPERATOR_ENTRY_POINT_GROUP,
    OperatorPluginWarning,
    all_operators,
    get_operator,
    load_operator_plugins,
)

PLUGIN = '''
import libcst as cst
from faultlab.mutation import NodeOperator, OperatorExample


class HypotToAdd(NodeOperator):
    """np.hypot(a, b) -> np.add(a, b): a norm computed as a sum."""

    name = "hypot_add"
    description = "replace np.hypot by np.add"
    examples = (OperatorExample("def f(a, b):\\n    return np.hypot(a, b)\\n",
                                ("def f(a, b):\\n    return np.add(a, b)\\n",)),)

    def mutations(self, node, parent):
        if (isinstance(node, cst.Attribute) and isinstance(node.value, cst.Name) and node.value.value == "np"
                and node.attr.value == "hypot"):
            yield node.with_changes(attr=cst.Name("add")), "`np.hypot` -> `np.add`"


class Clash(HypotToAdd):
    name = "arithmetic"


CLASH = Clash()
'''


@pytest.fixture
def plugin_dist(tmp_path, monkeypatch):
    """A distribution on sys.path declaring a good, a broken, a clashing operator and faultlab's own."""
    (tmp_path / "fl_test_ops.py").write_text(PLUGIN)
    (tmp_path / "fl_test_broken.py").write_text("raise ImportError('no such thing: broken on purpose')\n")
    info = tmp_path / "fl_test_ops-0.1.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: fl-test-ops\nVersion: 0.1\n")
    (info / "entry_points.txt").write_text(textwrap.dedent(f"""\
        [{OPERATOR_ENTRY_POINT_GROUP}]
        good = fl_test_ops:HypotToAdd
        broken = fl_test_broken:OPERATORS
        clash = fl_test_ops:CLASH
        faultlab_again = faultlab.mutation.operators:BUILTIN_OPERATORS
        """))
    monkeypatch.syspath_prepend(str(tmp_path))
    yield
    for name in ("fl_test_ops", "fl_test_broken"):
        sys.modules.pop(name, None)


def test_plugins_load_and_failures_are_reported_by_name(plugin_dist):
    report = load_operator_plugins(warn=False)
    assert [o.name for o in report.items] == ["hypot_add"]
    assert len(report.errors) == 2
    broken = next(str(e) for e in report.errors if "'broken'" in str(e))
    assert "ImportError: no such thing: broken on purpose" in broken
    clash = next(str(e) for e in report.errors if "'clash'" in str(e))
    assert "duplicate operator name 'arithmetic'" in clash
    with pytest.warns(OperatorPluginWarning) as warned:
        load_operator_plugins()
    assert sorted("broken on purpose" in str(w.message) for w in warned) == [False, True]


def test_plugin_operator_is_found_by_name_and_mutates(plugin_dist):
    with pytest.warns(OperatorPluginWarning):
        op = get_operator("hypot_add")
        names = [o.name for o in all_operators()]
    assert names[:len(BUILTIN_OPERATORS)] == [o.name for o in BUILTIN_OPERATORS] and names[-1] == "hypot_add"
    ex = op.examples[0]
    tree = cst.parse_module(ex.before)
    assert tuple(op.apply(tree, p).code for p in op.points(tree)) == ex.after


def test_builtins_are_found_and_unknown_names_suggest_close_ones():
    assert get_operator("arithmetic") is BUILTIN_OPERATORS[0]
    with pytest.raises(FaultError, match="unknown mutation operator 'arithmetc'; did you mean 'arithmetic'"):
        get_operator("arithmetc")


def test_without_plugins_only_builtins():
    assert all_operators(plugins=False) == list(BUILTIN_OPERATORS)
