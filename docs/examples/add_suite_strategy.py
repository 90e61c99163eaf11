"""A new suite strategy from a distribution of your own: the example plugin's random cases, smallest maps first.

The strategy (``examples/faultlab-example-plugin/src/faultlab_example_plugin/strategy.py``) is a
:class:`~faultlab.space.registry.SuiteStrategy` that the distribution declares in its ``pyproject.toml``::

    [project.entry-points."faultlab.suite_strategies"]
    smallest-first = "faultlab_example_plugin.strategy:SMALLEST_FIRST"

Installed (``pip install -e examples/faultlab-example-plugin``), it is a ``[suites]`` key like a built-in
in every process, the worker processes of ``faultlab run --jobs 2`` included.

Run: ``python docs/examples/add_suite_strategy.py``; the docs test runs it too.
"""

import numpy as np

from faultlab.space import table1_space
from faultlab.space.registry import build_suite, suite_kinds

suite = build_suite("smallest-first", table1_space(), rng=np.random.default_rng(7), n_cases=6)
sizes = [case.values["map_size"] for case in suite]
print("smallest-first" in suite_kinds(), sizes)
assert "smallest-first" in suite_kinds() and len(suite) == 6 and sizes == sorted(sizes)
