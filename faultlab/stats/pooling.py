"""Suite-level pooling: the case as the unit, beside the per-case minimum.

A suite's per-case rule (some case rejects after Holm or Bonferroni over the suite's ``n`` cases,
:mod:`faultlab.stats.killmatrix`) detects a *concentrated* effect -- a large change on few cases.
It misses by design a *diffuse* effect, a small change on most cases that no single case's ``K``
repetitions can show at ``alpha / n``.  The pooled test looks at the suite as a whole:

Pooled test
-----------
Per case ``i`` the mean over its usable repetitions of the log ratio
``l_ir = log(faulty_ir / baseline_ir)`` (:func:`case_log_ratio_means`): the log ratio keeps a
case with a 5 m error from outweighing one with 50 mm.  Under "the variant changes nothing" the
``K`` paired runs of a case are exchangeable (common random numbers), so each case mean is
symmetric about 0, independently across cases, and the exact sign-flip test over the ``n`` case
means (:func:`pooled_pvalues`, ``2^n`` patterns, enumerated up to ``n = MAX_EXACT_PAIRS``; beyond,
a seeded Monte Carlo with its standard error) tests "the variant shifts the error on this suite"
with the case as the unit -- no pseudo-replication, no normal approximation.  Two-sided by
default.  Its smallest p value is that of the per-case test with ``n`` in place of ``K``
(``2^-(n-1)`` two-sided), so it can reject at ``alpha / 2 = 0.025`` only from
``min_pairs(0.025, two-sided) = 7`` cases: pooling adds nothing to suites of 5 cases (the paper's).

Combining the two (:func:`suite_decisions`)
-------------------------------------------
``"both"`` (default): the suite detects when the per-case minimum rejects at ``alpha / 2``
(Holm's first step ``alpha / (2 n)``) *or* the pooled test rejects at ``alpha / 2``: by
Bonferroni the family-wise level stays ``alpha``.  ``"min"`` and ``"pooled"`` use one test at
``alpha``.  The choice of ``"both"`` comes from :func:`pooling_power` (committed output:
``reports/pooling/power.csv``, see ``docs/explanation/suite-pooling.md``): on diffuse effects the
per-case minimum has almost no power where the pooled test has nearly full power, on a
concentrated effect the pooled test over ``n`` cases has almost none; halving each level costs
each test a few points of power on its own kind of effect and buys both.

Verdicts that can be reached
----------------------------
A test whose smallest attainable p value exceeds its level cannot reject whatever the data: its
"not detected" would be a foregone conclusion.  :func:`suite_verdicts` states, per route, the
smallest attainable p (``case_p_min``: the smallest over the tested cases of ``2^-(K-1)``
two-sided, against ``alpha / (2 n)``; ``pooled_p_min``: ``2^-(n-1)`` two-sided over ``n`` tested
cases, against ``alpha / 2``) and says ``cannot_judge`` where no route can reach its level (and
nothing crashed): 5 cases pooled give at best 0.0625 > 0.025.

The campaign-level verdict (:func:`campaign_verdicts`)
------------------------------------------------------
A fault that shifts the error a little on every case is missed by every suite of 5 cases, yet the
campaign as a whole can show it.  Per fault: the exact sign-flip test over the mean log ratios of
**all** its tested cases (every suite and run; the case is the unit, its K repetitions averaged
first, so no repetition counts as evidence on its own), two-sided unless the rule says "worse".
Given the drawn cases the repetitions of different cases are independent, so under "the fault
changes nothing on these cases" every case mean is symmetric about 0 independently of the others:
the test is exact conditionally on the cases, however they were drawn (stratified suites, nested
in runs); ``n_draws`` says how many suite draws they come from, over which a generalisation to the
parameter space would have to be made.  The effect: the mean log ratio over the cases, reported
as the geometric-mean factor ``exp(mean)`` with the interval that inverts the same test
(:func:`~faultlab.inference.exact.sign_flip_interval`), so the interval excludes 1 exactly when the
unadjusted test rejects.  Holm over the campaign's faults (family ``faults``) at ``alpha``; the A/A
replica, a control, is judged alone (family ``control``).  ``cannot_judge`` when the smallest
attainable p exceeds ``alpha``.  A deterministic case (:mod:`faultlab.stats.verdict`) enters with its
exact log ratio.
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy.stats import permutation_test

from faultlab.errors import ConfigError
from faultlab.seeds import study_seed_sequence
from faultlab.inference.exact import (MAX_EXACT_PAIRS, alternative_of, min_p_value, min_pairs, sign_flip_interval,
                                      sign_flip_pvalues)
from faultlab.inference.multiplicity import holm
from faultlab.stats.verdict import EXACT, Verdict, case_verdicts
from faultlab.vocabulary import DEFAULT_ALPHA, DEFAULT_DIRECTION, REPLICA, Change

__all__ = ["COMBINATIONS", "DEFAULT_COMBINATION", "MONTE_CARLO_RESAMPLES", "SUITE_VERDICT_COLUMNS",
           "CAMPAIGN_VERDICT_COLUMNS", "case_log_ratio_means", "pooled_pvalues", "suite_decisions", "suite_verdicts",
           "campaign_verdicts", "pooling_power"]

#: How the per-case minimum and the pooled test combine into a suite's verdict.
COMBINATIONS: tuple[str, ...] = ("both", "min", "pooled")
#: The combination the power simulation supports (module docstring).
DEFAULT_COMBINATION = "both"
#: Sign patterns drawn when a suite has more than ``MAX_EXACT_PAIRS`` cases.
MONTE_CARLO_RESAMPLES = 99_999


def case_log_ratio_means(faulty, baseline) -> np.ndarray:
    """Per case, the mean over the repetitions of ``log(faulty / baseline)``.

    Parameters
    ----------
    faulty, baseline : array_like, shape (..., K)
        Paired map errors (positive; NaN marks an unusable pair, left out of the mean).

    Returns
    -------
    ndarray, shape (...,)
        NaN for a case without a usable pair.
    """
    f = np.asarray(faulty, dtype=float)
    b = np.asarray(baseline, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        lr = np.log(f / b)
    lr = np.where(np.isfinite(lr), lr, np.nan)
    ok = np.isfinite(lr)
    n = ok.sum(axis=-1)
    with np.errstate(invalid="ignore"):
        return np.where(n > 0, np.where(ok, lr, 0.0).sum(axis=-1) / np.maximum(n, 1), np.nan)


def _mean(x, axis):
    return np.mean(x, axis=axis)


def pooled_pvalues(case_means, *, alternative: str = "two-sided", rng: np.random.Generator | None = None,
                   resamples: int = MONTE_CARLO_RESAMPLES) -> tuple[np.ndarray, float]:
    """Exact sign-flip p value over each suite's case means (the case as the unit).

    Parameters
    ----------
    case_means : array_like, shape (m, n)
        One suite per row, its ``n`` case means (finite; cases without a usable pair must be left
        out by the caller).
    alternative : {"two-sided", "greater", "less"}
    rng : numpy.random.Generator, optional
        Needed only when ``n > MAX_EXACT_PAIRS`` (Monte Carlo over ``resamples`` sign patterns).
    resamples : int

    Returns
    -------
    p : ndarray, shape (m,)
    mc_se : float
        Largest Monte Carlo standard error of a p value (0 when enumerated).
    """
    x = np.atleast_2d(np.asarray(case_means, dtype=float))
    if x.shape[1] <= MAX_EXACT_PAIRS:
        return np.atleast_1d(sign_flip_pvalues(x, alternative=alternative)), 0.0
    if rng is None:
        raise ConfigError(f"pooled_pvalues: {x.shape[1]} cases exceed the {MAX_EXACT_PAIRS} the exact test "
                          "enumerates; a Monte Carlo test needs an rng")
    res = permutation_test((x,), _mean, permutation_type="samples", n_resamples=resamples, alternative=alternative,
                           vectorized=True, axis=-1, random_state=rng)
    p = np.asarray(res.pvalue, dtype=float).reshape(-1)
    return p, float(np.sqrt(np.max(p * (1 - p)) / resamples))


def suite_decisions(case_p, pooled_p, crash, *, alpha: float = DEFAULT_ALPHA,
                    combination: str = DEFAULT_COMBINATION) -> pd.DataFrame:
    """Whether each suite detects, by the per-case minimum, the pooled test, or both at ``alpha / 2``.

    Parameters
    ----------
    case_p : array_like, shape (m, n)
        Per-case p values of each suite (NaN: untested, counts as 1).
    pooled_p : array_like, shape (m,)
        :func:`pooled_pvalues` of each suite (NaN: not pooled, counts as 1).
    crash : array_like of bool, shape (m, n)
        Failures of the variant alone that count as detections.
    alpha : float
        Family-wise level of one suite's decision.
    combination : {"both", "min", "pooled"}

    Returns
    -------
    DataFrame
        One row per suite: ``by_case`` (some case's p <= the per-case level ``a / n``),
        ``by_pool`` (pooled p <= ``a``), ``crashed`` and ``detected``, with ``a = alpha / 2``
        for ``"both"``, ``alpha`` otherwise (the unused test's column is False).
    """
    if combination not in COMBINATIONS:
        raise ConfigError(f"suite_decisions: combination must be one of {', '.join(COMBINATIONS)}, "
                          f"got {combination!r}")
    if not 0 < alpha < 1:
        raise ConfigError(f"suite_decisions: alpha must lie in (0, 1), got {alpha!r}")
    p = np.atleast_2d(np.asarray(case_p, dtype=float))
    p = np.where(np.isnan(p), 1.0, p)
    pooled = np.asarray(pooled_p, dtype=float).reshape(-1)
    pooled = np.where(np.isnan(pooled), 1.0, pooled)
    crashed = np.atleast_2d(np.asarray(crash, dtype=bool)).any(axis=1)
    level = alpha / 2 if combination == "both" else alpha
    n = p.shape[1]
    by_case = (p.min(axis=1) <= level / n) if combination != "pooled" else np.zeros(p.shape[0], bool)
    by_pool = (pooled <= level) if combination != "min" else np.zeros(p.shape[0], bool)
    return pd.DataFrame({"by_case": by_case, "by_pool": by_pool, "crashed": crashed,
                         "detected": crashed | by_case | by_pool})


#: Columns of :func:`suite_verdicts`.
SUITE_VERDICT_COLUMNS: tuple[str, ...] = (
    "suite", "run", "fault", "alternative", "n_cases", "n_tested", "n_crashed", "n_exact", "min_p", "case_p_min",
    "detected_min", "pooled_p", "pooled_p_min", "pooled_verdict", "by_case", "by_pool", "detected_combined", "verdict")

#: Seed of the Monte Carlo pooled test of a suite run with more than ``MAX_EXACT_PAIRS`` tested cases.
SUITE_VERDICT_SEED = 20261126


def _reached(detected: bool, reachable: bool) -> str:
    """A verdict: detected, or not detected where the test could have rejected, else cannot judge."""
    if detected:
        return Verdict.DETECTED.value
    return Verdict.NOT_DETECTED.value if reachable else Verdict.CANNOT_JUDGE.value


def suite_verdicts(results: pd.DataFrame, *, alpha: float = DEFAULT_ALPHA, metric: str = "rms",
                   direction: str = DEFAULT_DIRECTION) -> pd.DataFrame:
    """Per (suite, run, fault): the suite-level decision by the per-case minimum and combined with pooling.

    The family is the suite run's ``n`` cases.  ``detected_min``: the fault crashed alone on a
    case, a deterministic case shows a difference (judged exactly; ``n_exact`` such cases), or the
    smallest per-case exact sign-flip p value (over the case's K repetitions,
    :func:`~faultlab.stats.verdict.case_verdicts`) is at most ``alpha / n`` (Holm's first step);
    ``detected_combined``: one of those certain detections, or ``by_case`` (smallest p <= ``alpha / (2 n)``),
    or ``by_pool`` (the pooled sign-flip test over the tested cases' mean log ratios, ``pooled_p``, at
    most ``alpha / 2``) -- :func:`suite_decisions` with ``"both"``, family-wise level ``alpha``.
    A case that cannot be judged enters with p = 1 and no mean.  Sidedness from ``direction``
    (two-sided by default, ``"worse"`` one-sided) for both tests.

    What could be reached (module docstring): ``case_p_min`` and ``pooled_p_min`` are the
    smallest p values the two routes can attain; ``pooled_verdict`` is the pooled test's own
    verdict at ``alpha / 2`` and ``verdict`` the combined one, each ``cannot_judge`` where its
    test(s) could not reach the level whatever the data.

    Parameters
    ----------
    results : DataFrame
        The runner's results (``run, suite, case, rep, variant, status`` and the metric's column).

    Returns
    -------
    DataFrame
        :data:`SUITE_VERDICT_COLUMNS`, one row per (suite, run, fault).
    """
    alternative = alternative_of(direction)
    v = case_verdicts(results, alpha=alpha, metric=metric, direction=direction)
    rows = []
    rng = np.random.default_rng(SUITE_VERDICT_SEED)
    for (suite, run, fault), g in v.groupby(["suite", "run", "fault"], sort=False):
        p = g["p"].to_numpy(float)
        exact = (g["test"] == EXACT).to_numpy(bool)
        crash = (g["verdict"] == Verdict.CRASH_DETECTED.value).to_numpy(bool)
        certain = crash | (exact & (g["verdict"] == Verdict.DETECTED.value).to_numpy(bool))
        means = g["mean_log_ratio"].to_numpy(float)
        tested = (np.isfinite(p) | exact) & np.isfinite(means) & ~crash
        n_tested = int(tested.sum())
        pooled = (pooled_pvalues(means[tested][None, :], alternative=alternative, rng=rng)[0][0]
                  if tested.any() else np.nan)
        minimum = suite_decisions(p[None, :], [pooled], certain[None, :], alpha=alpha, combination="min")
        both = suite_decisions(p[None, :], [pooled], certain[None, :], alpha=alpha, combination="both")
        case_floor = g["p_min"].to_numpy(float)[np.isfinite(p)]
        case_p_min = float(case_floor.min()) if case_floor.size else np.nan
        pooled_p_min = float(min_p_value(n_tested, alternative=alternative)) if n_tested else np.nan
        by_pool = bool(both["by_pool"].iloc[0])
        pool_reachable = n_tested > 0 and pooled_p_min <= alpha / 2
        case_reachable = case_floor.size > 0 and case_p_min <= alpha / (2 * len(g))
        detected = bool(both["detected"].iloc[0])
        rows.append({"suite": suite, "run": int(run), "fault": fault, "alternative": alternative,
                     "n_cases": len(g), "n_tested": n_tested, "n_crashed": int(crash.sum()),
                     "n_exact": int(exact.sum()),
                     "min_p": float(np.nanmin(p)) if np.isfinite(p).any() else np.nan, "case_p_min": case_p_min,
                     "detected_min": bool(minimum["detected"].iloc[0]), "pooled_p": float(pooled),
                     "pooled_p_min": pooled_p_min, "pooled_verdict": _reached(by_pool, pool_reachable),
                     "by_case": bool(both["by_case"].iloc[0]), "by_pool": by_pool,
                     "detected_combined": detected,
                     "verdict": _reached(detected, pool_reachable or case_reachable or bool(exact.any()))})
    return pd.DataFrame(rows, columns=list(SUITE_VERDICT_COLUMNS))


#: Columns of :func:`campaign_verdicts`.
CAMPAIGN_VERDICT_COLUMNS: tuple[str, ...] = (
    "fault", "test", "alternative", "alpha", "family", "n_cases", "n_tested", "n_crashed", "n_exact", "n_draws",
    "mean_log_ratio", "mean_log_ratio_low", "mean_log_ratio_high", "ratio", "ratio_low", "ratio_high", "direction",
    "p", "p_min",
    "p_holm", "mc_se", "verdict")

#: Seed of the Monte Carlo test and interval of a fault with more than ``MAX_EXACT_PAIRS`` tested cases.
CAMPAIGN_VERDICT_SEED = 20261128
#: ``test`` of :func:`campaign_verdicts`.
CAMPAIGN_TEST = "sign-flip over case means"


def campaign_verdicts(results: pd.DataFrame, *, alpha: float = DEFAULT_ALPHA, metric: str = "rms",
                      direction: str = DEFAULT_DIRECTION) -> pd.DataFrame:
    """Per fault: the campaign-level verdict over all its cases (module docstring).

    Parameters
    ----------
    results : DataFrame
        The runner's results (``run, suite, case, rep, variant, status`` and the metric's column).
    alpha : float
        Level of the family (Holm over the faults) and 1 - confidence level of the interval.
    metric : {"rms", "emd", "ate"}
    direction : {"either", "worse"}
        Two-sided (default) or the paper's one-sided test.

    Returns
    -------
    DataFrame
        :data:`CAMPAIGN_VERDICT_COLUMNS`, one row per fault: ``n_tested`` the cases with a
        paired mean log ratio (crashed cases and those whose baseline failed left out, ``n_crashed``
        counted; a case with too few repetitions for its own test enters with its mean),
        ``n_exact`` of them judged exactly (deterministic), ``n_draws`` the suite draws (run,
        suite) they come from; ``mean_log_ratio`` with ``mean_log_ratio_low, mean_log_ratio_high``
        and the factor ``ratio = exp(mean_log_ratio)`` with its interval (NaN where no interval can exclude 0:
        too few cases); ``direction`` the sign of the mean (:class:`~faultlab.vocabulary.Change`);
        ``p`` the test's, ``p_min`` its smallest attainable value, ``p_holm`` Holm's adjusted p
        within ``family``; ``mc_se`` the Monte Carlo standard error of ``p`` (0 when exact);
        ``verdict`` detected / not_detected / cannot_judge (``p_min > alpha``).
    """
    alternative = alternative_of(direction)
    v = case_verdicts(results, alpha=alpha, metric=metric, direction=direction)
    rows = []
    for fault, g in v.groupby("fault", sort=False):
        crash = (g["verdict"] == Verdict.CRASH_DETECTED.value).to_numpy(bool)
        exact = (g["test"] == EXACT).to_numpy(bool)
        means = g["mean_log_ratio"].to_numpy(float)
        # a case too small for its own test (K below min_pairs) still has its mean: the case is the unit here
        tested = (g["reason"] != "baseline_failed").to_numpy(bool) & ~crash & np.isfinite(means)
        x = means[tested]
        n = int(x.size)
        rng = np.random.default_rng(study_seed_sequence(CAMPAIGN_VERDICT_SEED, "campaign", str(fault)))
        p, se = (pooled_pvalues(x[None, :], alternative=alternative, rng=rng) if n else (np.array([np.nan]), 0.0))
        low, high = sign_flip_interval(x, level=1 - alpha, rng=rng) if n else (np.nan, np.nan)
        mean = float(x.mean()) if n else np.nan
        p_min = float(min_p_value(n, alternative=alternative)) if n else np.nan
        rows.append({"fault": fault, "test": CAMPAIGN_TEST, "alternative": alternative, "alpha": float(alpha),
                     "family": "control" if fault == REPLICA else "faults", "n_cases": len(g), "n_tested": n,
                     "n_crashed": int(crash.sum()), "n_exact": int((exact & tested).sum()),
                     "n_draws": int(g.loc[tested, ["run", "suite"]].drop_duplicates().shape[0]),
                     "mean_log_ratio": mean, "mean_log_ratio_low": low, "mean_log_ratio_high": high,
                     "ratio": math.exp(mean) if n else np.nan,
                     "ratio_low": math.exp(low) if math.isfinite(low) else np.nan,
                     "ratio_high": math.exp(high) if math.isfinite(high) else np.nan,
                     "direction": (Change.WORSE if mean > 0 else Change.BETTER if mean < 0 else Change.NONE).value,
                     "p": float(p[0]), "p_min": p_min, "mc_se": float(se)})
    out = pd.DataFrame(rows, columns=[c for c in CAMPAIGN_VERDICT_COLUMNS if c not in ("p_holm", "verdict")])
    p_holm = np.full(len(out), np.nan)
    for family in ("faults", "control"):
        sel = ((out["family"] == family) & out["p"].notna()).to_numpy(bool)
        if sel.any():
            p_holm[sel] = holm(out.loc[sel, "p"].to_numpy(float))[1]
    out["p_holm"] = p_holm
    reachable = out["p_min"].to_numpy(float) <= alpha
    detected = np.nan_to_num(p_holm, nan=1.0) <= alpha
    out["verdict"] = [_reached(bool(d), bool(r)) for d, r in zip(detected, reachable)]
    return out[list(CAMPAIGN_VERDICT_COLUMNS)]


def pooling_power(*, n_cases: int = 10, k: int = 11, draws: int = 1000, alpha: float = DEFAULT_ALPHA,
                  seed: int = 20261125, diffuse=(0.1, 0.2, 0.3), concentrated=(1.0, 1.5, 2.0)) -> pd.DataFrame:
    """Power of the three combinations on planted diffuse and concentrated effects (simulation).

    Model: per case and repetition the log ratio ``l_ir = shift_i + e_ir``, ``e_ir ~ N(0, 1)``
    (shifts in units of one repetition's noise).  *Diffuse*: the same shift on every case;
    *concentrated*: the shift on one case only; *null*: no shift (the family-wise false alarm
    rate).  Per-case p values: the exact two-sided sign-flip test over the ``K`` log ratios;
    pooled p: the exact two-sided sign-flip test over the ``n`` case means.  ``k`` defaults to
    the fewest repetitions with which one case of ``n`` can reject two-sided at ``alpha / (2 n)``.

    Returns
    -------
    DataFrame
        ``effect, shift, n_cases, k, draws, combination, power, mc_se``.
    """
    if k < min_pairs(alpha / (2 * n_cases), alternative="two-sided"):
        raise ConfigError(f"pooling_power: K = {k} cannot reach alpha / (2 n) two-sided")
    scenarios = [("null", 0.0)] + [("diffuse", s) for s in diffuse] + [("concentrated", s) for s in concentrated]
    rows = []
    for effect, shift in scenarios:  # one stream per scenario
        rng = np.random.default_rng(study_seed_sequence(seed, "pooling", effect, round(1000 * shift)))
        e = rng.standard_normal((draws, n_cases, k))
        shifts = np.zeros(n_cases)
        if effect == "diffuse":
            shifts[:] = shift
        elif effect == "concentrated":
            shifts[0] = shift
        lr = e + shifts[None, :, None]
        case_p = sign_flip_pvalues(lr.reshape(-1, k), alternative="two-sided").reshape(draws, n_cases)
        pooled, _ = pooled_pvalues(lr.mean(axis=2), alternative="two-sided")
        crash = np.zeros((draws, n_cases), bool)
        for combination in COMBINATIONS:
            det = suite_decisions(case_p, pooled, crash, alpha=alpha, combination=combination)["detected"]
            power = float(det.mean())
            rows.append({"effect": effect, "shift": shift, "n_cases": n_cases, "k": k, "draws": draws,
                         "combination": combination, "power": power,
                         "mc_se": math.sqrt(power * (1 - power) / draws)})
    return pd.DataFrame(rows)


if __name__ == "__main__":  # pragma: no cover - writes the committed simulation output
    import sys
    from pathlib import Path

    target = Path(sys.argv[1] if len(sys.argv) > 1 else "reports/pooling/power.csv")
    target.parent.mkdir(parents=True, exist_ok=True)
    pooling_power().to_csv(target, index=False, float_format="%.4g")
    print(target)
