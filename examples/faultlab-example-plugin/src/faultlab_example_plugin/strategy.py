"""A third-party suite strategy: random cases, smallest maps first.

faultlab finds it through the entry point declared in ``pyproject.toml``::

    [project.entry-points."faultlab.suite_strategies"]
    smallest-first = "faultlab_example_plugin.strategy:SMALLEST_FIRST"

An experiment's ``[suites]`` table then names it like a built-in (``smallest-first = 4``).
"""

from __future__ import annotations

from faultlab.space.registry import SuiteStrategy
from faultlab.space.suites import random_suite

__all__ = ["smallest_first_suite", "SMALLEST_FIRST"]


def smallest_first_suite(space, *, rng, n_cases=None):
    """Random cases, sorted by map size (smallest maps first): cheap cases run first."""
    cases = random_suite(space, rng=rng, n_cases=n_cases)
    return sorted(cases, key=lambda case: case.values["map_size"])


#: The strategy as faultlab's catalogue sees it: name, one-line description, builder.
SMALLEST_FIRST = SuiteStrategy("smallest-first", "random cases, smallest maps first", smallest_first_suite)
