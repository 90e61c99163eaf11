"""The compiled loops: copies equal numpy's indexing, the sampler equals cumsum + searchsorted.

The arithmetic kernels are checked through their twins (``tests/slam/test_twins.py``) against the
numpy reference units; the bookkeeping kernels here against numpy's fancy indexing.
"""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from faultlab.slam import twins

pytestmark = pytest.mark.skipif(not twins.JIT_ENABLED, reason="compiled twins turned off (FAULTLAB_JIT=0)")

if twins.JIT_ENABLED:
    from faultlab.slam import kernels


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 4), st.integers(1, 5), st.integers(1, 6), st.data())
def test_gather_and_scatter_copy_what_numpy_indexing_copies(b, n, k, data):
    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    cap, bn = k + 3, b * n
    mu_store, P_store = rng.normal(size=(2, cap, bn)), rng.normal(size=(2, 2, cap, bn))
    anc = rng.integers(0, n, size=(bn, cap)).astype(np.int16)  # as the filter stores it
    cols = rng.permutation(cap)[:k].astype(np.intp)
    p0 = n * data.draw(st.integers(0, b - 1))
    p1 = n * data.draw(st.integers(p0 // n + 1, b))
    m = p1 - p0
    rows = anc[p0:p1][:, cols] + (np.arange(p0, p1) // n * n)[:, None]  # (M, k)
    mb, pb = np.empty((2, k, m)), np.empty((2, 2, k, m))
    kernels.gather_pairs(mu_store, P_store, anc, cols, p0, n, mb, pb)
    np.testing.assert_array_equal(mb, mu_store[:, cols[:, None], rows.T])
    np.testing.assert_array_equal(pb, P_store[:, :, cols[:, None], rows.T])
    owner = np.tile(np.arange(n), m // n).astype(np.intp)
    new_mu, new_P = rng.normal(size=(2, k, m)), rng.normal(size=(2, 2, k, m))
    want_mu, want_P, want_anc = mu_store.copy(), P_store.copy(), anc.copy()
    want_mu[:, cols[:, None], np.arange(p0, p1)[None, :]] = new_mu
    want_P[:, :, cols[:, None], np.arange(p0, p1)[None, :]] = new_P
    want_anc[p0:p1, cols] = owner[:, None]
    kernels.scatter_pairs(new_mu, new_P, cols, p0, owner, mu_store, P_store, anc)
    np.testing.assert_array_equal(mu_store, want_mu)
    np.testing.assert_array_equal(P_store, want_P)
    np.testing.assert_array_equal(anc, want_anc)


@settings(max_examples=40, deadline=None)
@given(st.integers(1, 8), st.integers(0, 6), st.integers(0, 3), st.data())
def test_take_rows_is_numpy_row_indexing(n, width, extra, data):
    rng = np.random.default_rng(data.draw(st.integers(0, 2 ** 32 - 1)))
    src = rng.integers(-9, 9, size=(n, width + extra)).astype(np.int16)
    rows = rng.integers(0, n, size=n)
    dst = np.full((n, width + extra), 77, dtype=np.int16)
    kernels.take_rows(src, rows, dst, width)
    np.testing.assert_array_equal(dst[:, :width], src[rows, :width])
    assert (dst[:, width:] == 77).all()


@settings(max_examples=200, deadline=None)
@given(arrays(np.float64, st.integers(1, 40), elements=st.one_of(st.floats(0.0, 1.0), st.sampled_from([0.0, 1e-320]))),
       st.floats(0.0, 1.0, exclude_max=True))
def test_systematic_indices_are_cumsum_then_leftmost_search(w, frac):
    n = w.size
    r = frac / n
    want = np.minimum(np.searchsorted(np.cumsum(w), r + np.arange(n) / n, side="left"), n - 1)
    got = np.empty(n, dtype=np.intp)
    kernels.systematic_indices(w, r, got)
    np.testing.assert_array_equal(got, want)


SUMMANDS = st.one_of(st.floats(-1e6, 1e6), st.floats(-1e300, 1e300), st.sampled_from([0.0, -0.0, 1e-320, 3.0]))


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 128), st.integers(1, 9), st.data())
def test_pairwise_block_columns_adds_each_column_in_numpys_order(k, m, data):
    """numpy's own reduction of each (contiguous) column is the reference, bit for bit."""
    a = data.draw(arrays(np.float64, (k, m), elements=SUMMANDS))
    got = np.empty(m)
    kernels._pairwise_block_columns(a, got)
    for i in range(m):
        want = np.add.reduce(np.ascontiguousarray(a[:, i]))
        assert np.float64(0.0 + got[i]).view(np.int64) == np.float64(want).view(np.int64)


@settings(max_examples=200, deadline=None)
@given(st.one_of(st.integers(0, 20), st.integers(100, 140), st.integers(250, 1100)), st.integers(0, 3), st.data())
def test_pairwise_sum_adds_in_numpys_order(n, lo, data):
    """numpy's own reduction is the reference (its order differs from a plain loop beyond 8 values)."""
    a = data.draw(arrays(np.float64, lo + n, elements=SUMMANDS))
    got = 0.0 + kernels._pairwise_sum(a, lo, n)  # numpy's reduction starts from the identity 0.0
    want = np.add.reduce(a[lo:])
    assert np.float64(got).view(np.int64) == np.float64(want).view(np.int64)
