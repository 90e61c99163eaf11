"""Sign-flip p values from two halves: SciPy's enumeration, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.testing import assert_array_equal
from scipy.stats import permutation_test

from faultlab.inference import signflip
from faultlab.inference.signflip import reference_batch, split_pvalues
from faultlab.inference.exact import ALTERNATIVES, sign_flip_pvalues


def scipy_p(d, alternative, batch=None):
    """The oracle: scipy's exact permutation test of the mean, all 2^K sign patterns."""
    res = permutation_test((d,), lambda x, axis: np.mean(x, axis=axis), permutation_type="samples",
                           n_resamples=np.inf, alternative=alternative, vectorized=True, axis=-1, batch=batch)
    return np.asarray(res.pvalue, dtype=float).reshape(d.shape[0])


#: Rows whose exact sum is 0 but whose float sums are a few ulps off, in different directions
#: depending on the order of the additions (found by a search over such decimal rows).
NEAR_ZERO_12 = [0.1, -1.1, 0.3, 1.1, 0.6, -0.7, 0.7, 0.2, -0.2, -1.1, -0.2, 0.3]
NEAR_ZERO_20 = [1.1, 0.7, 0.6, -0.7, -0.2, 1.1, -0.2, -0.7, -1.1, -0.7, -0.1, 0.3, 1.1, -0.7, 0.2, 0.6, -1.1, -0.7,
                0.7, -0.2]

# magnitudes with ties, zeros, decimals whose sums round, integers, and tiny and huge values
# (up to 1e300: 12 of them cannot overflow)
_special = st.sampled_from([0.0, -0.0, 0.1, 0.2, 0.3, 0.7, 1.1, 1.0, 2.0, 3.0, 1e-300, 5e-324, 2.2250738585072014e-308,
                            1e-17, 1e17, 1e300, 123456789.123])
_value = st.one_of(_special, st.integers(-6, 6).map(float),
                   st.floats(min_value=-1e300, max_value=1e300, allow_nan=False, allow_infinity=False),
                   st.floats(min_value=-1e-300, max_value=1e-300, allow_nan=False, allow_infinity=False))


@st.composite
def difference_rows(draw, max_k: int = 12):
    """(m, K) differences: each row either drawn freely or from a small pool of signed magnitudes
    (repeated |d|, exact and near ties, zeros)."""
    k = draw(st.integers(1, max_k))
    m = draw(st.integers(1, 4))
    rows = []
    for _ in range(m):
        if draw(st.booleans()):
            pool = draw(st.lists(_value, min_size=1, max_size=3))
            signed = st.tuples(st.sampled_from(pool), st.booleans()).map(lambda t: -t[0] if t[1] else t[0])
            rows.append(draw(st.lists(signed, min_size=k, max_size=k)))
        else:
            rows.append(draw(st.lists(_value, min_size=k, max_size=k)))
    return np.array(rows, dtype=float)


@settings(max_examples=150, deadline=None)
@given(d=difference_rows(), alternative=st.sampled_from(ALTERNATIVES))
def test_p_values_equal_scipy_permutation_test(d, alternative):
    m, k = d.shape
    # scipy needs two observations: a single pair is tested with a zero added (sign_flip_pvalues' rule)
    padded = d if k > 1 else np.concatenate([d, np.zeros((m, 1))], axis=1)
    expected = scipy_p(padded, alternative)
    assert_array_equal(sign_flip_pvalues(d, alternative=alternative), expected)
    assert_array_equal(split_pvalues(padded, alternative), expected)
    for row, p in zip(d, expected):  # row by row, as callers with one case do
        assert sign_flip_pvalues(row, alternative=alternative) == p


@pytest.mark.parametrize("alternative", ALTERNATIVES)
def test_reference_flag_enumerates_with_scipy_and_agrees(alternative):
    rng = np.random.default_rng(7)
    d = np.vstack([rng.normal(0.3, 1.0, (5, 9)), rng.integers(-2, 3, (5, 9)), [NEAR_ZERO_12[:9]]])
    assert_array_equal(sign_flip_pvalues(d, alternative=alternative, reference=True), scipy_p(d, alternative))
    assert_array_equal(sign_flip_pvalues(d, alternative=alternative),
                       sign_flip_pvalues(d, alternative=alternative, reference=True))


def test_rows_processed_in_chunks_give_the_same_values(monkeypatch):
    rng = np.random.default_rng(3)
    d = np.vstack([rng.normal(0.2, 1.0, (4, 10)), [NEAR_ZERO_12[:10]], np.zeros((1, 10))])
    whole = split_pvalues(d, "two-sided")
    monkeypatch.setattr(signflip, "_CHUNK_BUDGET", 1)  # one row per chunk
    assert_array_equal(split_pvalues(d, "two-sided"), whole)
    assert_array_equal(whole, scipy_p(d, "two-sided"))


def test_overflowing_sums_agree_with_scipy():
    d = np.array([[1.7e308, 1.7e308, -1.0, 1.7e308], [1.7e308, -1.7e308, 1.7e308, 3.0]])
    with np.errstate(over="ignore", invalid="ignore"):
        for alternative in ALTERNATIVES:
            assert_array_equal(split_pvalues(d, alternative), scipy_p(d, alternative))


@pytest.mark.parametrize("alternative", ALTERNATIVES)
def test_single_pattern_batch_summed_pairwise_is_reproduced(monkeypatch, alternative):
    # a budget that leaves SciPy's last batch of one row with one pattern (2^12 = 4095 + 1): that
    # pattern's mean is summed pairwise, which changes the count for this row
    d = np.array([NEAR_ZERO_12])
    monkeypatch.setattr(signflip, "BATCH_BUDGET", 4095 * 12)
    assert reference_batch(1, 12) == 4095
    expected = scipy_p(d, alternative, batch=4095)
    assert_array_equal(split_pvalues(d, alternative), expected)
    if alternative != "less":  # the pairwise mean falls below the observed one, the sequential one does not
        assert not np.array_equal(expected, scipy_p(d, alternative))  # the case matters


def test_single_pattern_batches_fall_back_to_the_enumeration(monkeypatch):
    d = np.array([NEAR_ZERO_12[:10]])
    monkeypatch.setattr(signflip, "BATCH_BUDGET", 10)  # one pattern per batch: every mean pairwise
    for alternative in ALTERNATIVES:
        assert_array_equal(split_pvalues(d, alternative), scipy_p(d, alternative, batch=1))


@pytest.mark.slow
def test_twenty_pairs_equal_scipy_with_the_shipped_batching():
    # one row of 20: SciPy's last batch (2^20 = 5 x 209715 + 1) holds the all-negative pattern alone
    # (one count: every alternative is read off the same sorted sums, checked for K <= 12 above)
    one = np.array([NEAR_ZERO_20])
    assert_array_equal(sign_flip_pvalues(one, alternative="greater"),
                       scipy_p(one, "greater", batch=reference_batch(1, 20)))
    eighteen = np.random.default_rng(20).choice([0.1, 0.2, -0.3, 0.7, 0.0], (1, 18))
    assert_array_equal(sign_flip_pvalues(eighteen, alternative="greater"), scipy_p(eighteen, "greater"))
