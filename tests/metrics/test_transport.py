import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.optimize import linear_sum_assignment
from scipy.spatial.distance import cdist

from faultlab.errors import ScenarioError, SlamOutputError
from faultlab.metrics import earth_movers_distance


@pytest.mark.parametrize("seed", range(5))
def test_equal_sizes_match_optimal_assignment(seed):
    rng = np.random.default_rng(seed)
    n = 3 + 4 * seed
    p = rng.uniform(0, 10, size=(n, 2))
    q = rng.uniform(0, 10, size=(n, 2))
    d = cdist(p, q)
    rows, cols = linear_sum_assignment(d)
    np.testing.assert_allclose(earth_movers_distance(p, q), d[rows, cols].mean(), rtol=1e-9)


def test_set_with_itself_is_zero_and_symmetric():
    rng = np.random.default_rng(7)
    p = rng.normal(size=(15, 2))
    q = rng.normal(size=(9, 2))
    np.testing.assert_allclose(earth_movers_distance(p, p), 0.0, atol=1e-12)
    np.testing.assert_allclose(earth_movers_distance(p, q), earth_movers_distance(q, p), rtol=1e-9)


def test_unequal_counts_hand_example():
    # Masses 1/3 at x = 0, 1, 5 against 1/2 at x = 0, 5: integral of |F - G| = 1/6 * 1 + 1/6 * 4.
    truth = [[0.0, 0.0], [1.0, 0.0], [5.0, 0.0]]
    est = [[0.0, 0.0], [5.0, 0.0]]
    np.testing.assert_allclose(earth_movers_distance(truth, est), 5.0 / 6.0, rtol=1e-12)
    # Two truth landmarks around one estimate: each half of the mass travels 1 m.
    np.testing.assert_allclose(earth_movers_distance([[0, 0], [2, 0]], [[1, 0]]), 1.0)


@settings(max_examples=25, deadline=None)
@given(tx=st.floats(-50, 50), ty=st.floats(-50, 50), seed=st.integers(0, 2**32 - 1))
def test_translating_a_set_costs_the_shift_length(tx, ty, seed):
    # W1 between a distribution and its translate by t is |t| (no alignment is applied).
    p = np.random.default_rng(seed).uniform(-5, 5, size=(8, 2))
    np.testing.assert_allclose(earth_movers_distance(p, p + [tx, ty]), np.hypot(tx, ty), rtol=1e-7, atol=1e-9)


def test_empty_and_bad_input():
    assert np.isnan(earth_movers_distance([[0.0, 0.0]], np.empty((0, 2))))
    with pytest.raises(SlamOutputError, match="row 1 has a non-finite"):
        earth_movers_distance([[0, 0]], [[0, 0], [np.inf, 0]])
    with pytest.raises(ScenarioError, match="shape"):
        earth_movers_distance([0, 0, 0], [[0, 0]])
