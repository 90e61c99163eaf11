import math

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from scipy import stats
from scipy.spatial import cKDTree
from scipy.spatial.distance import pdist

from faultlab.errors import ScenarioError
from faultlab.scenario import generate_landmarks, generate_scenario, n_symmetric_pairs
from faultlab.space import FIXED_VALUES, CaseSpec


@settings(max_examples=30, deadline=None)
@given(size=st.floats(4, 100), density=st.floats(0.2, 15), seed=st.integers(0, 2**32 - 1))
def test_landmark_count_is_area_times_density_rounded_down(size, density, seed):
    prod = size * density
    assume(prod >= 1 and abs(prod - round(prod)) > 1e-6)  # not on an integer boundary
    v = dict(FIXED_VALUES, map_size=size, landmark_density=density)
    sc = generate_scenario(CaseSpec(v), rng=np.random.default_rng(seed), n_steps=3)
    assert sc.landmarks.shape == (math.floor(prod), 2)
    assert len(np.unique(sc.landmark_ids)) == math.floor(prod)
    half = math.sqrt(size) / 2
    assert np.all(np.abs(sc.landmarks) <= half)


@settings(max_examples=40, deadline=None)
@given(side=st.floats(1, 8), n=st.integers(0, 300), symmetry=st.floats(0, 1),
       dmin=st.floats(0, 0.2), seed=st.integers(0, 2**32 - 1))
def test_no_two_landmarks_closer_than_min_distance(side, n, symmetry, dmin, seed):
    assume(n * math.pi * (dmin / 2) ** 2 < 0.3 * side**2)  # well below the packing limit
    lm, ids = generate_landmarks(side=side, n_landmarks=n, symmetry=symmetry, min_distance=dmin,
                                 rng=np.random.default_rng(seed))
    assert lm.shape == (n, 2)
    np.testing.assert_array_equal(ids, np.arange(n))
    if n > 1:
        assert pdist(lm).min() >= dmin
    assert np.all(np.abs(lm) <= side / 2)


@settings(max_examples=40, deadline=None)
@given(n=st.integers(0, 400), symmetry=st.floats(0, 1), seed=st.integers(0, 2**32 - 1))
def test_symmetric_share_is_mirrored_exactly(n, symmetry, seed):
    lm, _ = generate_landmarks(side=10.0, n_landmarks=n, symmetry=symmetry, min_distance=0.1,
                               rng=np.random.default_rng(seed))
    k = min(math.floor(symmetry * n / 2 + 0.5), n // 2)  # round(share x n / 2) pairs, half up
    assert n_symmetric_pairs(n, symmetry) == k
    np.testing.assert_array_equal(lm[1:2 * k:2], -lm[0:2 * k:2])  # rows 2i and 2i+1: p and -p
    # the individually placed rest has no exact mirror image anywhere in the map
    rest = lm[2 * k:]
    if rest.shape[0]:
        d = np.abs(rest[:, None, :] + lm[None, :, :]).sum(axis=2)
        assert d.min() > 0


def test_symmetry_from_the_case_in_percent():
    v = dict(FIXED_VALUES, map_size=100.0, landmark_density=3.0, symmetry=50.0)
    sc = generate_scenario(CaseSpec(v), rng=np.random.default_rng(0), n_steps=2)
    assert sc.meta["n_symmetric_pairs"] == 75  # 300 landmarks, 50 % -> 150 in 75 pairs
    np.testing.assert_array_equal(sc.landmarks[1:150:2], -sc.landmarks[0:150:2])
    assert not np.array_equal(sc.landmarks[151], -sc.landmarks[150])


def test_positions_are_uniform():
    lm, _ = generate_landmarks(side=20.0, n_landmarks=4000, min_distance=0.1, rng=np.random.default_rng(3))
    for axis in (0, 1):
        assert stats.kstest(lm[:, axis], stats.uniform(loc=-10, scale=20).cdf).pvalue > 0.01


def test_infeasible_density_is_a_scenario_error():
    with pytest.raises(ScenarioError, match="cannot place 500 landmarks at least 0.2 m apart"):
        generate_landmarks(side=2.0, n_landmarks=500, min_distance=0.2, rng=np.random.default_rng(0))


def test_largest_table1_map_is_feasible():
    lm, _ = generate_landmarks(side=20.0, n_landmarks=6000, symmetry=0.9, min_distance=0.1,
                               rng=np.random.default_rng(0))
    assert lm.shape == (6000, 2)
    nearest, _ = cKDTree(lm).query(lm, k=2)
    assert nearest[:, 1].min() >= 0.1
