"""The relation contract's helpers: estimate distance, ground truth as an estimate, follow-up records."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.errors import ScenarioError
from faultlab.metamorphic.builtin import example_scenario
from faultlab.metamorphic.relation import META_KEY, estimate_distance, map_error, truth_estimate, with_record
from faultlab.metrics import map_errors
from faultlab.slam import Estimate


def _brute_distance(a: Estimate, b: Estimate) -> float:
    """Textbook transcription: match by id with a dict, sum squared distances in a loop."""
    da, db = a.as_dict(), b.as_dict()
    if set(da) != set(db):
        return math.inf
    total = sum((da[i][0] - db[i][0]) ** 2 + (da[i][1] - db[i][1]) ** 2 for i in da)
    total += (a.pose[0] - b.pose[0]) ** 2 + (a.pose[1] - b.pose[1]) ** 2
    return math.sqrt(total / (len(da) + 1))


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 12), st.integers(0, 2 ** 32 - 1))
def test_estimate_distance_matches_a_brute_force_transcription(m, seed):
    rng = np.random.default_rng(seed)
    ids = rng.choice(1000, size=m, replace=False)
    a = Estimate(rng.normal(size=3), ids, rng.normal(size=(m, 2)))
    perm = rng.permutation(m)  # the same landmarks listed in another order
    b = Estimate(rng.normal(size=3), ids[perm], rng.normal(size=(m, 2)))
    assert estimate_distance(a, b) == pytest.approx(_brute_distance(a, b), rel=1e-12)
    assert estimate_distance(a, a) == 0.0
    assert estimate_distance(a, b) == pytest.approx(estimate_distance(b, a), rel=1e-12)
    if m:  # another landmark set is infinitely far
        c = Estimate(a.pose, np.append(ids[:-1], 5000), a.landmarks)
        assert estimate_distance(a, c) == math.inf
        assert estimate_distance(a, Estimate(a.pose, ids[:-1], a.landmarks[:-1])) == math.inf


def test_estimate_distance_by_hand():
    a = Estimate(np.array([0.0, 0.0, 1.0]), np.array([1, 2]), np.array([[0.0, 0.0], [1.0, 1.0]]))
    b = Estimate(np.array([3.0, 4.0, -2.0]), np.array([2, 1]), np.array([[1.0, 1.0], [0.0, 0.0]]))
    assert estimate_distance(a, b) == pytest.approx(math.sqrt(25.0 / 3))  # only the pose moved, by 5 m


def test_truth_estimate_and_map_error():
    sc = example_scenario()
    truth = truth_estimate(sc)
    np.testing.assert_array_equal(truth.pose, [1.0, 0.0, math.pi / 2])
    assert truth.landmark_ids.tolist() == [10, 20]
    assert map_error(sc, truth) == 0.0
    moved = Estimate(truth.pose, truth.landmark_ids, truth.landmarks + [[0.3, 0.0], [-0.3, 0.0]])
    assert map_error(sc, moved) * 1000 == pytest.approx(map_errors(sc, moved, metrics=("rms",)).rms_mm)


def test_with_record_replaces_arrays_and_records_parameters():
    sc = example_scenario()
    out = with_record(sc, "demo", obs_range=sc.obs_range * 2, angle=np.float64(0.5), ids=np.array([1, 2]))
    np.testing.assert_array_equal(out.obs_range, sc.obs_range * 2)
    assert out.meta[META_KEY] == {"relation": "demo", "angle": 0.5, "ids": [1, 2]}
    assert META_KEY not in sc.meta and sc.obs_range[0] == pytest.approx(math.sqrt(2) + 0.2)  # source untouched
    with pytest.raises(ScenarioError, match="obs_range"):
        with_record(sc, "demo", obs_range=sc.obs_range[:1])
