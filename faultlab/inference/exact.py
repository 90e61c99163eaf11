"""Exact sign-flip tests of paired differences: p values, their smallest attainable value, power.

The per-case test of :mod:`faultlab.stats.verdict` is an exact sign-flip (paired permutation) test
of ``K`` paired differences with the mean as statistic: under the null hypothesis each difference
is symmetric about 0, so given the ``|d_r|`` every one of the ``2^K`` sign patterns is equally
likely and the p value is the share of patterns whose mean is at least as extreme as the observed
one (:func:`scipy.stats.permutation_test`'s definition, reproduced bit for bit by
:mod:`faultlab.inference.signflip`).  The smallest attainable p value is ``2^-K`` one-sided and
twice that two-sided (:func:`min_p_value`), so a rejection at ``alpha`` needs :func:`min_pairs`
pairs.  :func:`detectable_shift_factor` is the smallest shift, in standard deviations of the
differences, the test detects with a given power (the model and method are in
:mod:`faultlab.stats.verdict`, "Smallest detectable shift").
"""

from __future__ import annotations

import math
import numbers
from functools import lru_cache

import numpy as np

from faultlab.errors import ConfigError
from faultlab.inference.signflip import reference_pvalues, split_pvalues
from faultlab.vocabulary import DEFAULT_ALPHA, DEFAULT_POWER, DIRECTIONS

__all__ = ["ALTERNATIVES", "MAX_EXACT_PAIRS", "MDE_SEED", "check_alpha", "check_count", "check_alternative",
           "alternative_of", "min_p_value", "min_pairs", "sign_flip_pvalues", "sign_flip_interval",
           "detectable_shift_factor"]

#: The alternatives of :func:`sign_flip_pvalues` (SciPy's names): ``"greater"`` (the faulty error is
#: larger), ``"less"``, ``"two-sided"``.
ALTERNATIVES: tuple[str, ...] = ("greater", "less", "two-sided")


#: Largest number of pairs the exact test enumerates (2^20 sign patterns).
MAX_EXACT_PAIRS = 20

#: Entropy of the generator of the smallest-detectable-shift simulation.
MDE_SEED = 20240501

_MDE_DRAWS = 4000
_MDE_SIMULATED_UP_TO = 12
#: Float budget of one vectorised batch of the detectable-shift simulation (subsets x draws).
_BATCH_BUDGET = 2 ** 22


def check_alpha(alpha, where: str) -> float:
    if isinstance(alpha, bool) or not isinstance(alpha, numbers.Real) or not 0 < alpha < 1:
        raise ConfigError(f"{where}: alpha must lie in (0, 1), got {alpha!r}")
    return float(alpha)


def check_count(k, where: str, name: str = "K") -> int:
    if isinstance(k, bool) or not isinstance(k, (numbers.Integral, np.integer)) or k < 0:
        raise ConfigError(f"{where}: {name} must be an integer >= 0, got {k!r}")
    return int(k)


def check_alternative(alternative, where: str) -> str:
    if alternative not in ALTERNATIVES:
        raise ConfigError(f"{where}: alternative must be one of {', '.join(map(repr, ALTERNATIVES))}, "
                          f"got {alternative!r}")
    return alternative


def alternative_of(direction: str) -> str:
    """The sign-flip test's alternative for a declared direction: ``"either"`` -> ``"two-sided"``,
    ``"worse"`` (the paper's one-sided notion) -> ``"greater"``."""
    if direction not in DIRECTIONS:
        raise ConfigError(f"direction must be one of {', '.join(map(repr, DIRECTIONS))}, got {direction!r}")
    return "two-sided" if direction == "either" else "greater"


def min_p_value(k, *, alternative: str = "greater"):
    """Smallest attainable p value of the exact sign-flip test with ``k`` pairs.

    One-sided ``2^-k`` (all differences of one sign); two-sided ``min(1, 2 * 2^-k)`` (the
    all-positive and the all-negative pattern).

    Parameters
    ----------
    k : int or array_like of int
        Number of (non-zero) paired differences, >= 0.
    alternative : {"greater", "less", "two-sided"}

    Returns
    -------
    float or ndarray
        ``2.0 ** -k`` one-sided, ``min(1, 2.0 ** (1 - k))`` two-sided (1 for k = 0).
    """
    check_alternative(alternative, "min_p_value")
    factor = 2.0 if alternative == "two-sided" else 1.0
    arr = np.asarray(k)
    if arr.ndim == 0:
        return min(1.0, factor * 2.0 ** -check_count(k, "min_p_value"))
    if not np.issubdtype(arr.dtype, np.integer) or np.any(arr < 0):
        raise ConfigError(f"min_p_value: k must be integers >= 0, got {arr!r}")
    return np.minimum(1.0, factor * np.ldexp(1.0, -arr.astype(np.int64)))


def min_pairs(alpha: float, *, alternative: str = "greater") -> int:
    """The fewest pairs with which the sign-flip test can reject at ``alpha``: smallest K with
    :func:`min_p_value` ``(K) <= alpha``.

    Parameters
    ----------
    alpha : float
        In (0, 1).
    alternative : {"greater", "less", "two-sided"}

    Returns
    -------
    int
        One-sided ``ceil(log2(1 / alpha))`` (5 for alpha = 0.05, 7 for 0.01); two-sided one more
        (6 for 0.05, 8 for 0.01).
    """
    alpha = check_alpha(alpha, "min_pairs")
    check_alternative(alternative, "min_pairs")
    k = max(0, math.ceil(-math.log2(alpha)))
    while 2.0 ** -k > alpha:  # guard the float log against rounding
        k += 1
    while k > 0 and 2.0 ** -(k - 1) <= alpha:
        k -= 1
    return k + 1 if alternative == "two-sided" else k


def sign_flip_pvalues(differences, *, alternative: str = "greater", reference: bool = False) -> np.ndarray:
    """Exact sign-flip p values, one per row (one-sided "greater" unless told otherwise).

    Parameters
    ----------
    differences : array_like, shape (m, K) or (K,)
        Paired differences (faulty - baseline), finite; ``1 <= K <= MAX_EXACT_PAIRS``.
    alternative : {"greater", "less", "two-sided"}
        ``"greater"``: share of the ``2^K`` sign patterns whose mean is at least the row's mean;
        ``"less"``: at most; ``"two-sided"``: twice the smaller of the two, at most 1 (SciPy's
        definition).
    reference : bool
        Enumerate the patterns with :func:`scipy.stats.permutation_test`
        (:func:`faultlab.inference.signflip.reference_pvalues`, about 1.4 s a row at ``K = 20``)
        instead of computing the same values from two halves of the pairs
        (:func:`faultlab.inference.signflip.split_pvalues`, milliseconds a row).

    Returns
    -------
    ndarray, shape (m,) (0-d for 1-d input)
        :func:`scipy.stats.permutation_test`'s p values with all patterns enumerated, bit for bit.
    """
    check_alternative(alternative, "sign_flip_pvalues")
    d = np.asarray(differences, dtype=float)
    one = d.ndim == 1
    d = np.atleast_2d(d)
    if d.ndim != 2:
        raise ConfigError(f"sign_flip_pvalues: differences must have shape (m, K), got {d.shape}")
    m, k = d.shape
    if not 1 <= k <= MAX_EXACT_PAIRS:
        raise ConfigError(f"sign_flip_pvalues: the exact test needs 1 <= K <= {MAX_EXACT_PAIRS} pairs "
                          f"(2^K sign patterns), got K = {k}")
    if not np.all(np.isfinite(d)):
        raise ConfigError("sign_flip_pvalues: differences must be finite")
    if m == 0:
        return np.zeros(0)
    if d.shape[1] == 1:
        # scipy needs two observations; a zero difference leaves the p value unchanged (it doubles
        # both the patterns at least as extreme and the total)
        d = np.concatenate([d, np.zeros((m, 1))], axis=1)
    p = (reference_pvalues if reference else split_pvalues)(d, alternative)
    return p[0] if one else p


@lru_cache(maxsize=None)
def _shift_factor(k: int, alpha: float, power: float) -> float:
    m = math.floor(alpha * 2 ** k)
    if m < 1:
        return math.inf
    if k > _MDE_SIMULATED_UP_TO:
        from statsmodels.stats.power import TTestPower  # loaded on first use: the CLI starts without statsmodels

        return float(TTestPower().solve_power(nobs=k, alpha=alpha, power=power, alternative="larger"))
    # subset-mean matrix: row F holds 1/|F| at the members of the non-empty subset F
    members = ((np.arange(1, 2 ** k)[:, None] >> np.arange(k)) & 1).astype(float)
    means = members / members.sum(axis=1, keepdims=True)
    e = np.random.default_rng(np.random.SeedSequence(MDE_SEED)).standard_normal((_MDE_DRAWS, k))
    chunk = max(1, _BATCH_BUDGET // means.shape[0])
    thresholds = []
    for start in range(0, _MDE_DRAWS, chunk):
        v = means @ e[start:start + chunk].T  # mean(e_F), (2^K - 1, chunk)
        # m-th largest of -mean(e_F) = -(m-th smallest of mean(e_F))
        thresholds.append(-np.partition(v, m - 1, axis=0)[m - 1])
    return float(np.quantile(np.concatenate(thresholds), power))


def detectable_shift_factor(k: int, *, alpha: float = DEFAULT_ALPHA, power: float = DEFAULT_POWER,
                            alternative: str = "greater") -> float:
    """Smallest shift, in units of the differences' standard deviation, detected with ``power``.

    See "Smallest detectable shift" in the module docstring for the model and the method
    (simulation with a fixed generator for ``k <= 12``, the paired t test's power beyond).  The
    two-sided test at ``alpha`` rejects a positive shift when the "greater" p value is at most
    ``alpha / 2`` (or, rarely, the "less" one is), so its factor is the one-sided factor at
    ``alpha / 2`` (conservative by the wrong-sign rejections, negligible at the usual powers).

    Parameters
    ----------
    k : int
        Number of pairs, ``1 <= k <= MAX_EXACT_PAIRS``.
    alpha : float
        Level of the test, in (0, 1): the level the decision uses (e.g. Holm's first step
        ``alpha / n`` over a family of ``n`` cases).
    power : float
        Required probability of rejecting, in (0, 1).
    alternative : {"greater", "less", "two-sided"}
        Sidedness of the decision's test (a one-sided factor is the same for both signs).

    Returns
    -------
    float
        ``c(k)``; ``inf`` when ``2^-k > alpha``.
    """
    k = check_count(k, "detectable_shift_factor", "k")
    if not 1 <= k <= MAX_EXACT_PAIRS:
        raise ConfigError(f"detectable_shift_factor: k must lie in [1, {MAX_EXACT_PAIRS}], got {k}")
    alpha = check_alpha(alpha, "detectable_shift_factor")
    if isinstance(power, bool) or not isinstance(power, numbers.Real) or not 0 < power < 1:
        raise ConfigError(f"detectable_shift_factor: power must lie in (0, 1), got {power!r}")
    if check_alternative(alternative, "detectable_shift_factor") == "two-sided":
        alpha = alpha / 2
    return _shift_factor(k, alpha, float(power))


def _subset_means(x: np.ndarray) -> np.ndarray:
    """The means of the ``2^n - 1`` non-empty subsets of ``x`` (sums and sizes doubled one element at a time)."""
    sums, sizes = np.zeros(1), np.zeros(1)
    for v in x:
        sums = np.concatenate([sums, sums + v])
        sizes = np.concatenate([sizes, sizes + 1])
    return sums[1:] / sizes[1:]


def sign_flip_interval(x, *, level: float = 1 - DEFAULT_ALPHA, rng: np.random.Generator | None = None,
                       resamples: int = 99_999) -> tuple[float, float]:
    """Confidence interval of the centre of symmetry of ``x``: the shifts the two-sided sign-flip test keeps.

    The interval is ``{delta : sign_flip_pvalues(x - delta, "two-sided") > 1 - level}``, the inverse
    of the test of :func:`sign_flip_pvalues` with the mean as statistic, so it excludes 0 exactly when
    that test rejects at ``1 - level``.  Flipping the signs of a subset ``F`` makes the mean of
    ``x - delta`` at least the observed one iff ``mean(x_F) <= delta``; hence the one-sided p value
    at ``delta`` counts the subset means at most ``delta``, and the bounds are the ``m``-th smallest
    and the ``m``-th largest of the ``2^n - 1`` non-empty subset means, ``m = floor((1 - level) / 2 *
    2^n)`` (Hartigan's subset-mean interval).  Beyond :data:`MAX_EXACT_PAIRS` values ``resamples``
    random subsets stand for all of them, as for the Monte Carlo test (``m`` from ``resamples + 1``).

    Parameters
    ----------
    x : array_like, shape (n,)
        Finite values (e.g. one mean log ratio per case).
    level : float
        Confidence level, in (0, 1).
    rng : numpy.random.Generator, optional
        Needed only when ``n > MAX_EXACT_PAIRS``.
    resamples : int
        Random subsets of the Monte Carlo interval.

    Returns
    -------
    (low, high) : tuple of float
        NaN, NaN when no outcome of the test could reject at ``1 - level`` (``m < 1``: too few values).
    """
    alpha = check_alpha(1 - level, "sign_flip_interval")
    x = np.asarray(x, dtype=float).reshape(-1)
    if not np.all(np.isfinite(x)):
        raise ConfigError("sign_flip_interval: values must be finite")
    n = x.size
    if n <= MAX_EXACT_PAIRS:
        m = math.floor(alpha / 2 * 2.0 ** n)
        if m < 1:
            return math.nan, math.nan
        means = _subset_means(x)
    else:
        if rng is None:
            raise ConfigError(f"sign_flip_interval: {n} values exceed the {MAX_EXACT_PAIRS} the exact interval "
                              "enumerates; a Monte Carlo interval needs an rng")
        m = math.floor(alpha / 2 * (resamples + 1))
        members = rng.random((resamples, n)) < 0.5
        size = members.sum(axis=1)
        means = (members @ x) / np.maximum(size, 1)
        # an empty subset flips nothing: it counts on both sides, as the identity pattern does
        low = np.partition(np.where(size > 0, means, -np.inf), m - 1)[m - 1]
        high = -np.partition(-np.where(size > 0, means, np.inf), m - 1)[m - 1]
        return float(low), float(high)
    low = np.partition(means, m - 1)[m - 1]
    high = -np.partition(-means, m - 1)[m - 1]
    return float(low), float(high)
