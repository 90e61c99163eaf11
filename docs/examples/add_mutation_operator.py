"""A new mutation operator: swap ``np.minimum`` and ``np.maximum``.

Run: ``python docs/examples/add_mutation_operator.py``; the docs test runs it too.
"""

import libcst as cst

from faultlab.mutation.operatorbase import NodeOperator, OperatorExample

SWAP = {"minimum": "maximum", "maximum": "minimum"}


class MinMaxSwap(NodeOperator):
    """``np.minimum(a, b)`` <-> ``np.maximum(a, b)``."""

    name = "min_max_swap"
    description = "np.minimum <-> np.maximum"
    examples = (
        OperatorExample(
            before="def f(a, b):\n    return np.minimum(a, np.maximum(b, 0))\n",
            after=("def f(a, b):\n    return np.maximum(a, np.maximum(b, 0))\n",
                   "def f(a, b):\n    return np.minimum(a, np.minimum(b, 0))\n")),
    )

    def mutations(self, node, parent):
        if (isinstance(node, cst.Attribute) and isinstance(node.value, cst.Name) and node.value.value == "np"
                and node.attr.value in SWAP):
            new = SWAP[node.attr.value]
            yield node.with_changes(attr=cst.Name(new)), f"`np.{node.attr.value}` -> `np.{new}`"


operator = MinMaxSwap()
for example in operator.examples:
    mutants = operator.mutate_source(example.before)
    print(*mutants, sep="\n")
    assert tuple(mutants) == example.after
