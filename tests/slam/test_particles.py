"""The particle state and its copy-on-write landmark storage (faultlab.slam.particles)."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.special import logsumexp

from faultlab.slam.particles import (ParticleState, ancestry_dtype, empty_covariances, empty_means, initial_ancestry,
                                     landmark_rows)


def test_initial_state_is_uniform_at_the_pose_with_an_empty_identity_map():
    state = ParticleState.initial(np.array([1.0, -2.0, 0.5]), 7, capacity=5)
    assert state.n_particles == 7 and state.n_landmarks == 0
    np.testing.assert_array_equal(state.poses, np.tile([1.0, -2.0, 0.5], (7, 1)))
    assert abs(logsumexp(state.logw)) < 1e-12
    np.testing.assert_allclose(np.exp(state.logw), np.full(7, 1 / 7))
    np.testing.assert_array_equal(state.lineage, np.arange(7))
    np.testing.assert_array_equal(state.owner, np.arange(7))
    np.testing.assert_array_equal(state.anc, np.repeat(np.arange(7)[:, None], 5, axis=1))
    assert not state.sequential_sharers


def test_storage_shapes_zeros_and_component_major_layout():
    mu, P, anc = empty_means(4, 3), empty_covariances(4, 3), initial_ancestry(4, 3)
    assert mu.shape == (4, 3, 2) and P.shape == (4, 3, 2, 2) and anc.shape == (4, 3)
    assert not mu.any() and not P.any()
    # one component of one landmark for all particles is contiguous: particle stride = one float
    assert mu.strides[0] == mu.itemsize and P.strides[0] == P.itemsize
    assert anc.dtype == ancestry_dtype(4) == np.int16 and anc.flags.c_contiguous
    assert ancestry_dtype(32767) == np.int16 and ancestry_dtype(32768) == np.int32  # every row number fits


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 6), st.integers(1, 5), st.integers(0, 2**32 - 1))
def test_landmark_rows_is_the_ancestry_read_through_the_lineage(n, cap, seed):
    rng = np.random.default_rng(seed)
    anc = rng.integers(0, n, (n, cap)).astype(np.int32)
    lineage = rng.integers(0, n, n)
    state = ParticleState.initial(np.zeros(3), n, capacity=cap).replace(anc=anc, lineage=lineage)
    cols = rng.integers(0, cap, rng.integers(0, cap + 1))
    rows = landmark_rows(state, cols)
    expected = np.array([[anc[lineage[i], c] for c in cols] for i in range(n)]).reshape(n, len(cols))
    np.testing.assert_array_equal(rows, expected)
