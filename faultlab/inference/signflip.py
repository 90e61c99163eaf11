"""Exact sign-flip p values: SciPy's enumeration, and the same values from two halves.

The reference (:func:`reference_pvalues`) is :func:`scipy.stats.permutation_test` with
``permutation_type="samples"`` and ``n_resamples=np.inf``: it evaluates ``mean`` on each of the
``2^K`` sign patterns of a row of ``K`` paired differences and counts the patterns at least as
extreme as the observed mean.  At ``K = 20`` that is ``2^20 x 20`` additions per row, about
1.4 s a row.  :func:`split_pvalues` returns the same p values, bit for bit, in milliseconds.

What SciPy computes, exactly
----------------------------
With ``d`` the ``(m, K)`` rows, ``eps = 100`` machine epsilons and ``gamma = |eps * observed|``:

* ``observed = np.mean(d, axis=-1)``;
* each null value is ``np.mean`` of the row with some signs flipped.  SciPy stacks the flipped
  copies so that the pair axis is the *outermost* in memory, so NumPy sums it **sequentially**:
  ``s = x_0; s = s + x_1; ...; s = s + x_{K-1}``, then ``s / K``.  (The observed mean of a
  contiguous row is summed pairwise instead, in another order: hence the tolerance.)  The one
  exception: when a batch of patterns holds a single pattern of a single row, the sum runs over
  one strided vector and NumPy sums it pairwise, like the observed mean.  SciPy's batches hold
  ``max(1, BATCH_BUDGET // (m K))`` patterns; with ``m = 1`` and ``K = 20`` the last batch holds
  one pattern (``2^20 = 5 x 209715 + 1``), the all-negative one, whose null value is then
  ``np.mean(-d)``;
* ``greater``: the share of null values ``>= observed - gamma``; ``less``: ``<= observed +
  gamma``; ``two-sided``: twice the smaller of the two, clipped to [0, 1].

From two halves
---------------
Split the pairs into a prefix (the first ``h``) and a suffix (the other ``K - h``).  A pattern's
sequential sum is the prefix's sequential sum ``P`` followed by ``K - h`` more rounded additions
fixed by the suffix's signs, then a rounded division by ``K``.  Each of these steps is a
correctly rounded, hence monotone (non-decreasing), function of its running value, so for a
fixed suffix pattern the null value is a non-decreasing function ``g(P)`` of the prefix sum.  So
with the ``2^h`` prefix sums sorted, the patterns with ``g(P) >= t`` are a tail of the sorted
list and those with ``g(P) <= t`` a head; a bisection over the sorted sums finds each boundary
in ``h + 1`` evaluations of ``g``, each made of the very additions and the division NumPy
performs.  The counts are therefore SciPy's counts exactly -- no tolerance is re-derived, only
reproduced -- at a cost of a sort of ``2^h`` sums and ``2^(K-h) (h + 1) (K - h)`` additions per
row and alternative instead of ``2^K K`` additions; with ``K - h`` about ``K / 3``, at ``K = 20``
a sort of 8,192 sums and 12,544 additions instead of 20,971,520 additions.  Every step is a
whole-array NumPy operation over the rows.
"""

from __future__ import annotations

import numpy as np
from scipy.stats import permutation_test

__all__ = ["BATCH_BUDGET", "TIE_TOLERANCE", "reference_batch", "reference_pvalues", "split_pvalues"]

#: Float budget of one vectorised batch of the reference's enumeration (patterns x rows x pairs).
#: The batch fixes the memory layout SciPy sums in, hence the last bit of some null values
#: (module docstring): :func:`split_pvalues` reproduces the values of exactly this batching.
BATCH_BUDGET = 2 ** 22

#: SciPy's relative tolerance of the comparison with the observed statistic (100 machine epsilons).
TIE_TOLERANCE = np.finfo(np.float64).eps * 100

#: Elements of the largest intermediate array of :func:`split_pvalues` (rows x prefix patterns, or
#: rows x suffix patterns x suffix pairs); rows are processed in chunks within it.
_CHUNK_BUDGET = 2 ** 21


def _mean_statistic(x, axis):
    return np.mean(x, axis=axis)


def reference_batch(m: int, k: int) -> int:
    """Sign patterns per vectorised batch of :func:`reference_pvalues` for ``m`` rows of ``k`` pairs."""
    return max(1, BATCH_BUDGET // (m * k))


def reference_pvalues(d: np.ndarray, alternative: str) -> np.ndarray:
    """Exact sign-flip p values by :func:`scipy.stats.permutation_test`, enumerating all ``2^K`` patterns.

    Parameters
    ----------
    d : ndarray, shape (m, K)
        Paired differences, finite, ``m >= 1``, ``K >= 2`` (SciPy needs two observations).
    alternative : {"greater", "less", "two-sided"}

    Returns
    -------
    ndarray, shape (m,)
    """
    m, k = d.shape
    res = permutation_test((d,), _mean_statistic, permutation_type="samples", n_resamples=np.inf,
                           alternative=alternative, vectorized=True, axis=-1, batch=reference_batch(m, k))
    return np.asarray(res.pvalue, dtype=float).reshape(m)


def _prefix_sums(d: np.ndarray) -> np.ndarray:
    """Sequential sums of ``d``'s columns under all ``2^h`` sign patterns, shape (m, 2^h)."""
    s = np.concatenate([d[:, :1], -d[:, :1]], axis=1)
    for j in range(1, d.shape[1]):
        s = np.concatenate([s + d[:, j:j + 1], s - d[:, j:j + 1]], axis=1)  # a - b is a + (-b), exactly
    return s


def _boundaries(prefix: np.ndarray, suffix: np.ndarray, k: int, threshold: np.ndarray, *,
                at_least: bool) -> np.ndarray:
    """Per row and suffix pattern, the first index of the sorted ``prefix`` whose null value is
    ``>= threshold`` (``at_least``) or ``> threshold`` (otherwise).

    Parameters
    ----------
    prefix : ndarray, shape (m, n)
        Sorted prefix sums.
    suffix : ndarray, shape (K - h, m, S)
        The suffix's signed differences, pair by pair, one column per suffix pattern.
    k : int
        Pairs (the divisor of the mean).
    threshold : ndarray, shape (m,)

    Returns
    -------
    ndarray of int, shape (m, S)
    """
    m, n = prefix.shape
    lo = np.zeros(suffix.shape[1:], dtype=np.int64)
    hi = np.full(suffix.shape[1:], n, dtype=np.int64)
    t = threshold[:, None]
    for _ in range(int(n).bit_length()):  # the interval [lo, hi] of n + 1 candidates halves each step
        active = lo < hi
        mid = (lo + hi) // 2
        s = np.take_along_axis(prefix, np.minimum(mid, n - 1), axis=1)
        for pair in suffix:
            s = s + pair
        null = s / k
        hit = (null >= t) if at_least else (null > t)
        hi = np.where(active & hit, mid, hi)
        lo = np.where(active & ~hit, mid + 1, lo)
    return lo


def _suffix_length(k: int) -> int:
    """Pairs of the suffix: about a third, as a suffix pattern costs ``h + 1`` evaluations of ``K - h``
    additions and a prefix sum only its share of a sort (measured fastest at ``K = 20``)."""
    return (k + 1) // 3


def _split_counts(d: np.ndarray, low: np.ndarray, high: np.ndarray, *, greater: bool,
                  less: bool) -> tuple[np.ndarray | None, np.ndarray | None]:
    """Patterns whose sequential null mean is ``>= low`` and ``<= high``, per row of ``d`` (m, K)."""
    m, k = d.shape
    rest = _suffix_length(k)
    h = k - rest
    prefix = np.sort(_prefix_sums(d[:, :h]), axis=1)
    n = prefix.shape[1]
    signs = 1.0 - 2.0 * ((np.arange(2 ** rest)[:, None] >> np.arange(rest)) & 1)  # (S, K - h) of +-1
    suffix = d.T[h:, :, None] * signs.T[:, None, :]  # (K - h, m, S), exact: products with +-1
    count_ge = count_le = None
    if greater:
        count_ge = (n - _boundaries(prefix, suffix, k, low, at_least=True)).sum(axis=1)
    if less:
        count_le = _boundaries(prefix, suffix, k, high, at_least=False).sum(axis=1)
    return count_ge, count_le


def split_pvalues(d: np.ndarray, alternative: str) -> np.ndarray:
    """The p values of :func:`reference_pvalues`, bit for bit, from two halves (module docstring).

    Parameters
    ----------
    d : ndarray, shape (m, K)
        Paired differences, finite, ``m >= 1``, ``K >= 2``.  Should the reference's batching
        sum every null mean of a single row pairwise (a batch of one pattern, which
        :data:`BATCH_BUDGET` never gives for ``K <= 20``), the reference itself is called.
    alternative : {"greater", "less", "two-sided"}

    Returns
    -------
    ndarray, shape (m,)
    """
    m, k = d.shape
    n_patterns = 2 ** k
    batch = reference_batch(m, k)
    if m == 1 and batch == 1:  # every null mean summed pairwise: only the enumeration reproduces it
        return reference_pvalues(d, alternative)
    observed = np.mean(d, axis=-1)
    gamma = np.abs(TIE_TOLERANCE * observed)
    low = observed - gamma
    high = observed + gamma
    greater = alternative in ("greater", "two-sided")
    less = alternative in ("less", "two-sided")
    count_ge = np.zeros(m, dtype=np.int64)
    count_le = np.zeros(m, dtype=np.int64)
    rest = _suffix_length(k)
    rows = max(1, _CHUNK_BUDGET // max(2 ** (k - rest), 2 ** rest * rest))
    for start in range(0, m, rows):
        part = slice(start, start + rows)
        ge, le = _split_counts(d[part], low[part], high[part], greater=greater, less=less)
        if greater:
            count_ge[part] = ge
        if less:
            count_le[part] = le
    if m == 1 and n_patterns % batch == 1:
        # the last batch holds only the all-negative pattern, summed pairwise (module docstring)
        sequential = d[:, 0] * -1.0
        for j in range(1, k):
            sequential = sequential - d[:, j]
        sequential = sequential / k
        pairwise = np.mean(-d, axis=-1)
        count_ge += (pairwise >= low).astype(np.int64) - (sequential >= low)
        count_le += (pairwise <= high).astype(np.int64) - (sequential <= high)
    p_ge = count_ge.astype(float) / n_patterns
    p_le = count_le.astype(float) / n_patterns
    if alternative == "greater":
        p = p_ge
    elif alternative == "less":
        p = p_le
    else:
        p = np.minimum(p_le, p_ge) * 2
    return np.clip(p, 0.0, 1.0)
