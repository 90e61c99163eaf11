"""Regression, improvement or equivalence of a candidate against a baseline, on log map errors.

``faultlab compare`` measures both versions of a SLAM on the same test cases.  The effect is the
**log ratio** of the map errors, ``log(candidate / baseline)``: map errors of different cases differ
by orders of magnitude, and a change of a SLAM (a slower drift, a scaled noise) acts on them as a
factor, so a log ratio is comparable across cases and the margin ``delta`` is relative
(``margin = log(1 + delta)``; an effect ``e`` is reported as ``exp(e) - 1``, a percentage).

Two questions, each at level ``alpha``, and one interval:

* **regression**: one-sided test of ``H0: effect <= 0`` against ``effect > 0`` (the candidate's error
  is larger); **improvement**: the mirror test;
* **equivalence within delta**: two one-sided tests (TOST, Schuirmann 1987) of ``H0: effect <= -margin``
  and ``H0: effect >= margin``; equivalent when both reject, i.e. the larger p value is <= ``alpha``;
* the ``1 - 2 alpha`` two-sided interval of the effect, whose ends are the one-sided bounds of the
  tests (equivalent <=> the interval lies inside ``(-margin, margin)``; regression <=> its lower end
  is above 0).

The verdict is one of (in this order): ``identical`` (every difference exactly 0: nothing to test),
``equivalent`` (TOST shows it: a change inside the declared margin is not a regression, even when
it is shown to be > 0), ``regression``, ``improvement``, ``inconclusive``.

Pooled over cases (:func:`compare_paired`): the unit of evidence is the independently drawn test
case.  The repetitions of a case are averaged first (the mean of their log errors), so they are
never counted as independent observations; the cases' differences of those means are tested with
the one-sample t test (SciPy ``ttest_1samp``; TOST with statsmodels ``ttost_paired``), whose
interval is the t interval.  For the same SLAM under both names the differences are exchangeable,
so symmetric about 0, and the t test holds its level closely even for skewed error distributions.

Within one case (:func:`compare_samples`): the K repetitions of each version are independent runs
with their own seeds; Welch's t test on the log errors (SciPy ``ttest_ind``, statsmodels
``ttost_ind`` with unequal variances).  A case on which both versions are deterministic is judged
exactly (:func:`compare_exact`): its one difference against the margin, with no test.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np
from scipy import stats
from statsmodels.stats.weightstats import ttost_ind, ttost_paired

from faultlab.errors import ConfigError
from faultlab.inference.exact import check_alpha

__all__ = ["VERDICTS", "IDENTICAL", "EQUIVALENT", "REGRESSION", "IMPROVEMENT", "INCONCLUSIVE", "Comparison",
           "relative_margin", "compare_paired", "compare_samples", "compare_exact", "percent"]

IDENTICAL, EQUIVALENT, REGRESSION, IMPROVEMENT, INCONCLUSIVE = (
    "identical", "equivalent", "regression", "improvement", "inconclusive")
#: Every verdict, best news first.
VERDICTS = (IDENTICAL, EQUIVALENT, IMPROVEMENT, INCONCLUSIVE, REGRESSION)


@dataclass(frozen=True)
class Comparison:
    """The verdict on a log-ratio effect, with what it rests on.

    Attributes
    ----------
    verdict : str
        One of :data:`VERDICTS`.
    effect : float
        Estimated effect, log(candidate / baseline) (NaN when there is nothing to estimate).
    ci_low, ci_high : float
        The ``1 - 2 alpha`` interval of the effect; NaN when judged exactly or degenerate.
    p_regression, p_improvement, p_equivalence : float
        One-sided p values (regression: ``H0 effect <= 0``; improvement: ``H0 effect >= 0``) and the
        TOST p value (the larger of its two); NaN when judged exactly.
    margin : float
        ``log(1 + delta)``.
    alpha : float
    n : int
        Units the verdict rests on (cases, or repetitions of each version within one case).
    test : str
        The rule, in words.
    """

    verdict: str
    effect: float
    ci_low: float
    ci_high: float
    p_regression: float
    p_improvement: float
    p_equivalence: float
    margin: float
    alpha: float
    n: int
    test: str

    def to_dict(self) -> dict:
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in asdict(self).items()}


def percent(effect: float) -> float:
    """A log-ratio effect as a relative change, percent (``100 (exp(e) - 1)``)."""
    return 100.0 * math.expm1(effect) if math.isfinite(effect) else math.nan


def relative_margin(delta: float) -> float:
    """``log(1 + delta)`` for a relative margin ``delta`` in (0, 1)."""
    if isinstance(delta, bool) or not isinstance(delta, (int, float)) or not 0 < delta < 1:
        raise ConfigError(f"equivalence margin delta must lie in (0, 1) (a relative change), got {delta!r}")
    return math.log1p(float(delta))


def _decide(p_reg: float, p_imp: float, p_eq: float, alpha: float) -> str:
    if p_eq <= alpha:
        return EQUIVALENT
    if p_reg <= alpha:
        return REGRESSION
    if p_imp <= alpha:
        return IMPROVEMENT
    return INCONCLUSIVE


def compare_exact(effect: float, *, margin: float, alpha: float, n: int = 1, what: str = "one exact difference"
                  ) -> Comparison:
    """An effect known without sampling error (deterministic SLAMs; the same change on every case):
    ``identical`` when 0, ``equivalent`` inside ``(-margin, margin)``, else regression / improvement."""
    e = float(effect)
    if e == 0.0:
        verdict = IDENTICAL
    elif abs(e) < margin:
        verdict = EQUIVALENT
    else:
        verdict = REGRESSION if e > 0 else IMPROVEMENT
    return Comparison(verdict, e, math.nan, math.nan, math.nan, math.nan, math.nan, margin, alpha, n,
                      f"exact: {what}, against the margin (no test)")


def compare_paired(baseline, candidate, *, margin: float, alpha: float) -> Comparison:
    """Pooled verdict over cases from each case's baseline and candidate log errors (module docstring).

    ``baseline[i]`` and ``candidate[i]`` are case ``i``'s mean log map errors over its repetitions.
    """
    alpha = check_alpha(alpha, "compare")
    b = np.asarray(baseline, dtype=float)
    c = np.asarray(candidate, dtype=float)
    if b.shape != c.shape or b.ndim != 1:
        raise ConfigError(f"compare: baseline and candidate must be 1-d of one length, got {b.shape}, {c.shape}")
    if not (np.isfinite(b).all() and np.isfinite(c).all()):
        raise ConfigError("compare: non-finite log errors (drop the cases a version failed to run first)")
    d = c - b
    n = int(d.size)
    if n and np.all(d == 0):
        return compare_exact(0.0, margin=margin, alpha=alpha, n=n, what=f"all {n} cases identical")
    if n < 2:
        return Comparison(INCONCLUSIVE, float(d.mean()) if n else math.nan, math.nan, math.nan, math.nan, math.nan,
                          math.nan, margin, alpha, n, "fewer than 2 cases: no test")
    if np.all(d == d[0]):
        return compare_exact(float(d[0]), margin=margin, alpha=alpha, n=n,
                             what=f"the same difference on all {n} cases")
    greater = stats.ttest_1samp(d, 0.0, alternative="greater")
    less = stats.ttest_1samp(d, 0.0, alternative="less")
    ci = stats.ttest_1samp(d, 0.0).confidence_interval(confidence_level=1.0 - 2.0 * alpha)
    p_eq = float(ttost_paired(c, b, -margin, margin)[0])
    p_reg, p_imp = float(greater.pvalue), float(less.pvalue)
    return Comparison(_decide(p_reg, p_imp, p_eq, alpha), float(d.mean()), float(ci.low), float(ci.high), p_reg,
                      p_imp, p_eq, margin, alpha, n,
                      f"paired t test over {n} cases on the mean log error of each case (one-sided, alpha "
                      f"{alpha:g}); TOST within +-{percent(margin):.3g} %")


def compare_samples(baseline, candidate, *, margin: float, alpha: float) -> Comparison:
    """Verdict within one case from each version's log errors of independent repetitions (Welch)."""
    alpha = check_alpha(alpha, "compare")
    b = np.asarray(baseline, dtype=float)
    c = np.asarray(candidate, dtype=float)
    if b.ndim != 1 or c.ndim != 1 or not (np.isfinite(b).all() and np.isfinite(c).all()):
        raise ConfigError("compare: the repetitions' log errors must be finite 1-d arrays")
    if b.size < 2 or c.size < 2:
        return Comparison(INCONCLUSIVE, float(c.mean() - b.mean()) if b.size and c.size else math.nan, math.nan,
                          math.nan, math.nan, math.nan, math.nan, margin, alpha, int(min(b.size, c.size)),
                          "fewer than 2 repetitions of a version: no test")
    if np.ptp(b) == 0 and np.ptp(c) == 0:
        return compare_exact(float(c[0] - b[0]), margin=margin, alpha=alpha, n=int(min(b.size, c.size)),
                             what="every repetition identical")
    greater = stats.ttest_ind(c, b, equal_var=False, alternative="greater")
    less = stats.ttest_ind(c, b, equal_var=False, alternative="less")
    ci = stats.ttest_ind(c, b, equal_var=False).confidence_interval(confidence_level=1.0 - 2.0 * alpha)
    p_eq = float(ttost_ind(c, b, -margin, margin, usevar="unequal")[0])
    p_reg, p_imp = float(greater.pvalue), float(less.pvalue)
    return Comparison(_decide(p_reg, p_imp, p_eq, alpha), float(c.mean() - b.mean()), float(ci.low), float(ci.high),
                      p_reg, p_imp, p_eq, margin, alpha, int(min(b.size, c.size)),
                      f"Welch t test on the log errors of {c.size} vs {b.size} repetitions (one-sided, alpha "
                      f"{alpha:g}); TOST within +-{percent(margin):.3g} %")
