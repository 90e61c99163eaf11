"""ddmin and the prefix search against brute force; the reduction on a planted failure."""

import itertools

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.metamorphic.check import metamorphic_scenario
from faultlab.oracles.shrink import ddmin, reduce_scenario, shortest_failing_prefix


def _one_minimal(result, fails):
    return fails(result) and all(not fails(result[:i] + result[i + 1:]) for i in range(len(result)))


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 24), st.sets(st.integers(0, 23), min_size=1, max_size=4))
def test_ddmin_finds_a_one_minimal_failing_subset(n, culprits):
    culprits = {c % n for c in culprits}
    fails = lambda sub: culprits <= set(sub)  # fails when every culprit is present
    result = ddmin(list(range(n)), fails)
    assert _one_minimal(result, fails)
    assert set(result) == culprits  # for a monotone failure the 1-minimal set is the culprits


def test_ddmin_matches_brute_force_on_a_non_monotone_failure():
    fails = lambda sub: len(sub) >= 2 and (sum(sub) % 5 == 0)  # any pair/triple summing to a multiple of 5
    items = list(range(1, 9))
    result = ddmin(items, fails)
    assert _one_minimal(result, fails)
    smallest = min(len(c) for k in range(1, 9) for c in itertools.combinations(items, k) if fails(list(c)))
    assert len(result) >= smallest


@given(st.integers(1, 300), st.integers(1, 300))
def test_shortest_failing_prefix_is_the_threshold_of_a_monotone_failure(n, threshold):
    threshold = min(threshold, n)
    assert shortest_failing_prefix(n, lambda m: m >= threshold) == threshold


def test_reduction_keeps_the_failure_and_reaches_the_culprit():
    scenario = metamorphic_scenario(seed=3, n_steps=120)
    step = np.repeat(np.arange(scenario.n_steps), np.diff(scenario.obs_offsets))
    culprit = int(scenario.obs_ids[len(step) // 2])
    first_seen = int(step[scenario.obs_ids == culprit][0])

    def fails(s):  # planted: a failure whenever landmark `culprit` is observed
        return bool(np.any(s.obs_ids == culprit))

    red = reduce_scenario(scenario, fails)
    assert red.confirmed and fails(red.scenario)
    assert red.minimal["landmarks"] == 1 and list(red.scenario.landmark_ids) == [culprit]
    assert red.minimal["steps"] == first_seen + 1  # the shortest prefix that observes it
    assert red.original == {"steps": 120, "landmarks": scenario.landmarks.shape[0],
                            "observations": scenario.obs_range.size}


def test_an_unconfirmed_reduction_reports_the_original_case():
    scenario = metamorphic_scenario(seed=3, n_steps=40)
    red = reduce_scenario(scenario, lambda s: True, confirm=lambda s: s.n_steps == 40)
    assert not red.confirmed and red.scenario is scenario
