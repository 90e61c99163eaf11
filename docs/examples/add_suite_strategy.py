"""A new suite strategy: random cases, smallest maps first.

Run: ``python docs/examples/add_suite_strategy.py``; the docs test runs it too.
"""

import numpy as np

from faultlab.space import table1_space
from faultlab.space.registry import STRATEGIES, SuiteStrategy, build_suite, suite_kinds
from faultlab.space.suites import random_suite


def lowest_first_suite(space, *, rng, n_cases=None):
    """Random cases, sorted by map size (smallest maps first): cheap cases run first."""
    cases = random_suite(space, rng=rng, n_cases=n_cases)
    return sorted(cases, key=lambda case: case.values["map_size"])


# In faultlab itself the builder goes into a module of faultlab/space/ and this entry into
# STRATEGIES in faultlab/space/registry.py.
STRATEGIES["smallest-first"] = SuiteStrategy("smallest-first", "random cases, smallest maps first",
                                             lowest_first_suite)

suite = build_suite("smallest-first", table1_space(), rng=np.random.default_rng(7), n_cases=6)
sizes = [case.values["map_size"] for case in suite]
print("smallest-first" in suite_kinds(), sizes)
assert "smallest-first" in suite_kinds() and len(suite) == 6 and sizes == sorted(sizes)
