"""The case as the unit: per-case verdicts by the configured rule, case-level rates and suite comparisons.

With K SLAM repetitions per case the K jobs of one case are not independent evidence about a
suite: they share the scenario.  Counting jobs (as the paper's one-repetition protocol could)
makes a p value fall with K on the same cases.  Here every statistic of a suite is over
**cases**, each case judged once from all its repetitions:

Per-case verdict (:func:`rule_verdicts`)
    ``rule = "statistical"``: :func:`faultlab.stats.case_verdicts` (exact paired sign-flip
    test over the K repetitions, two-sided unless the rule's ``direction`` is the paper's
    ``"worse"``), Holm-adjusted within the rule's multiplicity family (:func:`holm_within`);
    ``detected`` when the adjusted p is at most alpha.  A deterministic case (bit-identical
    repetitions, ``test = "exact"``) is judged by its exact difference and stays out of the
    Holm family: a difference is a difference.  Every row carries the observed
    ``direction`` (worse / better) and the paired effect with its interval.
    ``rule = "paper"``: the paper's thresholds on each repetition (:func:`faultlab.stats.outcomes`);
    a repetition whose baseline failed is not judged, a crash or timeout of the faulty variant
    alone counts as detecting; the case is detected when a **strict majority** of its judged
    repetitions detect (with K = 1: that repetition), and ``share`` is the per-case detection
    probability (detecting / judged repetitions).  A case without a judged repetition is
    ``cannot_judge``.  For both rules, ``cannot_judge`` cases are excluded from rates and
    comparisons and counted separately -- never as misses.

Case-level rates (:func:`case_rates`)
    detected / judged cases per suite and fault with exact Clopper-Pearson and Wilson intervals.

Suite comparisons (:func:`compare_suites_by_case`)
    per fault and pair of suites, cases as units and evaluation runs as clusters (the cases of
    one run are drawn together): statsmodels GEE, binomial family, exchangeable working
    correlation, robust (sandwich) standard errors, Wald test of the suite indicator.  When GEE
    cannot fit (perfect separation, e.g. 0/n against k/n, a single cluster, or no convergence)
    a cluster bootstrap of the risk difference is used instead (runs resampled with
    replacement within each suite, generator ``SeedSequence(BOOTSTRAP_SEED)``, percentile
    p value), and ``method`` says so.  Degenerate tables (0/n vs 0/m, n/n vs m/m) carry no
    information and are dropped from the Holm family (``p`` NaN, a note in ``note``).  Holm
    runs per fault over its suite pairs: comparisons of one fault never depend on another's.
"""

from __future__ import annotations

import math
import warnings
from itertools import combinations

import numpy as np
import pandas as pd
from statsmodels.stats.proportion import proportion_confint

from faultlab.errors import ConfigError
from faultlab.metrics.detection import DetectionRule
from faultlab.inference.multiplicity import holm
from faultlab.inference.exact import MAX_EXACT_PAIRS, alternative_of, detectable_shift_factor
from faultlab.inference.intervals import clopper_pearson
from faultlab.stats.verdict import Verdict, case_verdicts
from faultlab.vocabulary import DEFAULT_ALPHA, DEFAULT_POWER, SUITE_ORDER, Outcome, ordered

__all__ = ["CASE_VERDICT_COLUMNS", "CASE_RATE_COLUMNS", "CASE_COMPARISON_COLUMNS", "BOOTSTRAP_SEED",
           "PAPER_COMPARISON_COLUMNS", "AGREEMENT_MARGIN", "REPLICA_FALSE_ALARM_COLUMNS", "replica_false_alarms", "detectable_difference", "compare_with_paper",
           "holm_within", "family_key", "gee_suite_test", "rule_verdicts", "case_rates", "compare_suites_by_case"]

#: ``test`` of a case judged by the paper's thresholds on its repetitions (the paper rule).
THRESHOLDS = "thresholds"
#: Entropy of the cluster bootstrap's generator.
BOOTSTRAP_SEED = 20240502
_BOOTSTRAP_DRAWS = 2000

CASE_VERDICT_COLUMNS: tuple[str, ...] = (
    "suite", "run", "case", "fault", "rule", "verdict", "reason", "test", "n_reps", "n_judged", "n_detecting", "share",
    "p", "p_holm", "family", "alternative", "direction", "median_diff_mm", "median_low_mm", "median_high_mm",
    "ratio", "ratio_low", "ratio_high", "mde_mm")
CASE_RATE_COLUMNS: tuple[str, ...] = (
    "suite", "fault", "rule", "n_cases", "n_cannot_judge", "n", "k", "rate", "wilson_low", "wilson_high",
    "cp_low", "cp_high")
CASE_COMPARISON_COLUMNS: tuple[str, ...] = (
    "fault", "suite_a", "suite_b", "k_a", "n_a", "k_b", "n_b", "rate_a", "rate_b", "risk_difference", "n_clusters",
    "method", "p", "p_holm", "note")


def family_key(frame: pd.DataFrame, family: str) -> pd.Series:
    """The multiplicity family of every row (``fault``, ``suite_fault`` or ``case``), as text."""
    if family == "fault":
        return frame["fault"].astype(str)
    if family == "suite_fault":
        return frame["suite"].astype(str) + "/" + frame["fault"].astype(str)
    if family == "case":
        return (frame["suite"].astype(str) + "/" + frame["run"].astype(str) + "/" + frame["case"].astype(str)
                + "/" + frame["fault"].astype(str))
    raise ConfigError(f"family_key: unknown multiplicity family {family!r}")


def holm_within(p, families) -> np.ndarray:
    """Holm-adjusted p values, each family adjusted on its own (NaN p values are not in any family).

    Parameters
    ----------
    p : array_like, shape (n,)
    families : array_like, shape (n,)
        Family label of every p value.

    Returns
    -------
    ndarray, shape (n,)
        statsmodels' Holm adjustment (:func:`faultlab.inference.multiplicity.holm`) within each family; NaN where p is NaN.
    """
    p = np.asarray(p, dtype=float)
    fam = pd.Series(np.asarray(families)).reset_index(drop=True)
    out = np.full(p.shape, np.nan)
    ok = ~np.isnan(p)
    for _, idx in fam[ok].groupby(fam[ok]).groups.items():
        idx = np.asarray(idx)
        out[idx] = holm(p[idx])[1]
    return out


def rule_verdicts(results: pd.DataFrame, pairs: pd.DataFrame, *, rule: DetectionRule,
                  metric: str = "rms", power: float = DEFAULT_POWER) -> pd.DataFrame:
    """One verdict per (suite, run, case, fault) by ``rule`` (module docstring).

    Parameters
    ----------
    results : DataFrame
        The runner's results (one row per job).
    pairs : DataFrame
        :func:`faultlab.stats.outcomes` of ``results`` judged by ``rule``'s thresholds.
    rule : DetectionRule
    metric : {"rms", "emd"}
    power : float
        Power of the smallest detectable shift ``mde_mm``.

    Returns
    -------
    DataFrame
        :data:`CASE_VERDICT_COLUMNS`: ``verdict`` a :class:`~faultlab.stats.Verdict` value,
        ``test`` what judged the case (statistical rule: ``"sign-flip"``, ``"exact"`` for a
        deterministic case, ``""`` where nothing could be tested; paper rule: :data:`THRESHOLDS`),
        ``n_reps`` the faulty repetitions, ``n_judged`` the usable pairs (statistical) or the
        repetitions with a usable baseline (paper), ``n_detecting`` the repetitions that detect
        (paper) or the positive differences (statistical), ``share`` = n_detecting / n_judged,
        ``p`` and ``p_holm`` (statistical rule; NaN for the paper rule), ``family`` the Holm
        family, ``alternative``, ``direction`` and the effect columns of
        :func:`~faultlab.stats.verdict.case_verdicts`, ``mde_mm`` the smallest shift the exact
        test detects with ``power`` at the level the decision uses: the statistical rule's
        sidedness and Holm's first step ``alpha / m`` over the row's family of ``m`` tested
        cases (the paper rule: the exact test at ``alpha``; inf with too few pairs).
    """
    stat = case_verdicts(results, alpha=rule.alpha, metric=metric, power=power, direction=rule.direction)
    key = ["suite", "run", "case", "fault"]
    if stat.empty:
        return pd.DataFrame({c: pd.Series([], dtype=object) for c in CASE_VERDICT_COLUMNS})
    fam = family_key(stat, rule.family)
    out = stat[key].copy()
    out["rule"] = rule.rule
    out["family"] = fam.to_numpy() if rule.statistical else ""
    out["mde_mm"] = stat["mde_mm"].to_numpy(float)
    for name in ("alternative", "direction", "median_diff_mm", "median_low_mm", "median_high_mm", "ratio",
                 "ratio_low", "ratio_high"):
        out[name] = stat[name].to_numpy()
    out["n_reps"] = stat["n_reps"].to_numpy(np.int64)
    if rule.statistical:
        p = stat["p"].to_numpy(float)
        p_holm = holm_within(p, fam.to_numpy())
        verdict = stat["verdict"].to_numpy(object).copy()
        tested = ~np.isnan(p)
        verdict[tested] = np.where(p_holm[tested] <= rule.alpha, Verdict.DETECTED.value,
                                   Verdict.NOT_DETECTED.value)
        out["verdict"] = verdict
        out["reason"] = stat["reason"].to_numpy(object)
        out["test"] = stat["test"].to_numpy(object)
        out["n_judged"] = stat["n_pairs"].to_numpy(np.int64)
        out["n_detecting"] = _positive_differences(results, stat, metric)
        out["p"] = p
        out["p_holm"] = p_holm
        out["mde_mm"] = _decision_mde(stat, fam.to_numpy(), rule, power)
    else:
        oc = pairs.assign(
            judged=pairs["outcome"] != Outcome.BASELINE_FAILED.value,
            hit=pairs["outcome"].isin([Outcome.DETECTED.value, Outcome.CRASH.value, Outcome.TIMEOUT.value]),
            failed=pairs["outcome"].isin([Outcome.CRASH.value, Outcome.TIMEOUT.value]))
        per = oc.groupby(key, sort=False).agg(n_judged=("judged", "sum"), n_detecting=("hit", "sum"),
                                              n_failed=("failed", "sum")).reset_index()
        per = out[key].merge(per, on=key, how="left")
        n_judged = per["n_judged"].fillna(0).to_numpy(np.int64)
        n_hit = per["n_detecting"].fillna(0).to_numpy(np.int64)
        n_failed = per["n_failed"].fillna(0).to_numpy(np.int64)
        detected = 2 * n_hit > n_judged
        verdict = np.where(detected, np.where(n_failed > 0, Verdict.CRASH_DETECTED.value, Verdict.DETECTED.value),
                           Verdict.NOT_DETECTED.value).astype(object)
        verdict[n_judged == 0] = Verdict.CANNOT_JUDGE.value
        out["verdict"] = verdict
        out["reason"] = np.where(n_judged == 0, "baseline_failed", "").astype(object)
        out["test"] = THRESHOLDS
        out["n_judged"] = n_judged
        out["n_detecting"] = n_hit
        out["p"] = np.nan
        out["p_holm"] = np.nan
    with np.errstate(invalid="ignore", divide="ignore"):
        out["share"] = np.where(out["n_judged"] > 0, out["n_detecting"] / out["n_judged"].clip(lower=1), np.nan)
    return out[list(CASE_VERDICT_COLUMNS)].reset_index(drop=True)


def _decision_mde(stat: pd.DataFrame, families: np.ndarray, rule: DetectionRule, power: float) -> np.ndarray:
    """Smallest detectable shift at Holm's first step ``alpha / m`` of each row's family (``m`` tested
    cases) with the rule's sidedness: the level at which a single case can make the decision."""
    tested = stat["p"].notna().to_numpy()
    m = pd.Series(tested.astype(int)).groupby(pd.Series(families)).transform("sum").to_numpy()
    n_pairs = stat["n_pairs"].to_numpy(np.int64)
    sd = stat["baseline_sd_mm"].to_numpy(float)
    alternative = alternative_of(rule.direction)
    out = stat["mde_mm"].to_numpy(float).copy()
    for (k, size) in set(zip(n_pairs[tested].tolist(), m[tested].tolist())):
        rows = tested & (n_pairs == k) & (m == size)
        factor = (detectable_shift_factor(int(k), alpha=rule.alpha / size, power=power, alternative=alternative)
                  if 1 <= k <= MAX_EXACT_PAIRS else math.nan)
        out[rows] = factor * math.sqrt(2.0) * sd[rows]
    return out


def _positive_differences(results: pd.DataFrame, stat: pd.DataFrame, metric: str) -> np.ndarray:
    """Per row of ``stat``: the repetitions where the faulty error exceeds the baseline's."""
    col = f"{metric}_mm"
    key = ["suite", "run", "case"]
    ok = results[results["status"].astype(str) == "ok"]
    base = ok[ok["variant"] == "baseline"][key + ["rep", col]]
    faulty = ok[ok["variant"] != "baseline"].rename(columns={"variant": "fault"})[key + ["fault", "rep", col]]
    m = faulty.merge(base, on=key + ["rep"], suffixes=("", "_b"))
    m["pos"] = m[col].to_numpy(float) > m[f"{col}_b"].to_numpy(float)
    cnt = m.groupby(key + ["fault"])["pos"].sum().reset_index()
    return stat[key + ["fault"]].merge(cnt, on=key + ["fault"], how="left")["pos"].fillna(0).to_numpy(np.int64)


def _judged(verdicts: pd.DataFrame) -> pd.DataFrame:
    v = verdicts[verdicts["verdict"] != Verdict.CANNOT_JUDGE.value]
    return v.assign(y=v["verdict"].isin([Verdict.DETECTED.value, Verdict.CRASH_DETECTED.value]).astype(int))


def case_rates(verdicts: pd.DataFrame, *, alpha: float = DEFAULT_ALPHA) -> pd.DataFrame:
    """Detected / judged cases per suite and fault, with exact Clopper-Pearson and Wilson intervals.

    Parameters
    ----------
    verdicts : DataFrame
        :func:`rule_verdicts`.
    alpha : float
        1 - confidence level.

    Returns
    -------
    DataFrame
        :data:`CASE_RATE_COLUMNS`; ``n_cases`` all cases, ``n_cannot_judge`` those without a
        verdict, ``n`` judged cases, ``k`` detected ones.
    """
    rows = []
    for (suite, fault), g in verdicts.groupby(["suite", "fault"], sort=False):
        j = _judged(g)
        n, k = len(j), int(j["y"].sum())
        wl, wh = proportion_confint(k, n, alpha=alpha, method="wilson") if n else (math.nan, math.nan)
        cl, ch = clopper_pearson(k, n, alpha=alpha)
        rows.append({"suite": suite, "fault": fault, "rule": g["rule"].iloc[0], "n_cases": len(g),
                     "n_cannot_judge": len(g) - n, "n": n, "k": k, "rate": k / n if n else math.nan,
                     "wilson_low": wl, "wilson_high": wh, "cp_low": cl, "cp_high": ch})
    table = pd.DataFrame(rows, columns=list(CASE_RATE_COLUMNS))
    return _sort(table, "suite", "fault")


def _sort(table: pd.DataFrame, suite_col: str, fault_col: str) -> pd.DataFrame:
    if table.empty:
        return table.reset_index(drop=True)
    rank = {s: i for i, s in enumerate(ordered(table[suite_col].unique(), SUITE_ORDER))}
    return (table.assign(_r=table[suite_col].map(rank)).sort_values([fault_col, "_r"], kind="stable")
            .drop(columns="_r").reset_index(drop=True))


def gee_suite_test(y, x, groups, *, working: str = "exchangeable") -> tuple[float, float, float] | None:
    """Binomial GEE of ``y`` on a constant and the suite indicator ``x``, clusters ``groups``.

    Parameters
    ----------
    y : array_like of {0, 1}, shape (n,)
        One outcome per case.
    x : array_like of {0, 1}, shape (n,)
        1 for suite a, 0 for suite b.
    groups : array_like, shape (n,)
        Cluster (evaluation run) of every case.
    working : {"exchangeable", "independence"}
        Working correlation.

    Returns
    -------
    (coef, std_err, p) or None
        Log odds ratio of suite a against b, its robust (sandwich) standard error and the Wald
        p value; None when GEE cannot fit: one cluster, a suite whose cases all agree
        (separation), or no convergence.
    """
    import statsmodels.api as sm
    from statsmodels.tools.sm_exceptions import ConvergenceWarning, PerfectSeparationWarning

    y = np.asarray(y, dtype=float)
    x = np.asarray(x, dtype=int)
    groups = np.asarray(groups)
    if len(np.unique(groups)) < 2:
        return None
    for side in (0, 1):
        ys = y[x == side]
        if ys.size == 0 or ys.min() == ys.max():
            return None
    cov = sm.cov_struct.Exchangeable() if working == "exchangeable" else sm.cov_struct.Independence()
    exog = sm.add_constant(x.astype(float), has_constant="add")
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", ConvergenceWarning)
            warnings.simplefilter("error", PerfectSeparationWarning)
            warnings.simplefilter("ignore", RuntimeWarning)
            fit = sm.GEE(y, exog, groups=groups, family=sm.families.Binomial(), cov_struct=cov).fit()
    except (ConvergenceWarning, PerfectSeparationWarning, np.linalg.LinAlgError, ValueError, ZeroDivisionError):
        return None
    coef, se, p = (float(np.asarray(v)[1]) for v in (fit.params, fit.bse, fit.pvalues))
    return (coef, se, p) if np.isfinite(p) else None


def _gee_p(y: np.ndarray, x: np.ndarray, groups: np.ndarray) -> float | None:
    res = gee_suite_test(y, x, groups)
    return None if res is None else res[2]


def _bootstrap_p(y: np.ndarray, x: np.ndarray, groups: np.ndarray, rng: np.random.Generator) -> float:
    """Two-sided percentile p value of the risk difference from a cluster bootstrap (runs resampled per suite)."""
    draws = np.empty(_BOOTSTRAP_DRAWS)
    sides = []
    for side in (1, 0):
        sel = x == side
        codes, uniq = pd.factorize(groups[sel])
        sums = np.bincount(codes, weights=y[sel], minlength=len(uniq))
        counts = np.bincount(codes, minlength=len(uniq))
        sides.append((sums, counts))
    rates = []
    for sums, counts in sides:
        idx = rng.integers(0, len(sums), size=(_BOOTSTRAP_DRAWS, len(sums)))
        rates.append(sums[idx].sum(axis=1) / counts[idx].sum(axis=1))
    draws = rates[0] - rates[1]
    p = 2 * min(np.mean(draws <= 0), np.mean(draws >= 0))
    return float(min(1.0, p))


def compare_suites_by_case(verdicts: pd.DataFrame) -> pd.DataFrame:
    """Per fault and pair of suites: case-level comparison with runs as clusters (module docstring).

    Parameters
    ----------
    verdicts : DataFrame
        :func:`rule_verdicts` (cannot-judge cases are left out).

    Returns
    -------
    DataFrame
        :data:`CASE_COMPARISON_COLUMNS`; ``method`` is ``"gee"``, ``"cluster_bootstrap"`` or
        ``"degenerate"`` (dropped from the Holm family, ``p`` NaN); ``p_holm`` Holm within the
        fault; ``note`` says why GEE was not used.
    """
    judged = _judged(verdicts)
    rng = np.random.default_rng(np.random.SeedSequence(BOOTSTRAP_SEED))
    rows = []
    for fault in sorted(judged["fault"].unique()):
        f = judged[judged["fault"] == fault]
        for a, b in combinations(ordered(f["suite"].unique(), SUITE_ORDER), 2):
            fa, fb = f[f["suite"] == a], f[f["suite"] == b]
            k_a, n_a, k_b, n_b = int(fa["y"].sum()), len(fa), int(fb["y"].sum()), len(fb)
            both = pd.concat([fa, fb])
            y = both["y"].to_numpy(float)
            x = (both["suite"] == a).to_numpy(int)
            groups = both["run"].to_numpy()
            row = {"fault": fault, "suite_a": a, "suite_b": b, "k_a": k_a, "n_a": n_a, "k_b": k_b, "n_b": n_b,
                   "rate_a": k_a / n_a, "rate_b": k_b / n_b, "risk_difference": k_a / n_a - k_b / n_b,
                   "n_clusters": int(len(np.unique(groups))), "p": math.nan, "note": ""}
            if (k_a == 0 and k_b == 0) or (k_a == n_a and k_b == n_b):
                row.update(method="degenerate", note=f"{k_a}/{n_a} vs {k_b}/{n_b}: no information; left out of "
                                                     f"the Holm family")
            else:
                p = _gee_p(y, x, groups)
                if p is not None:
                    row.update(method="gee", p=p)
                else:
                    row.update(method="cluster_bootstrap", p=_bootstrap_p(y, x, groups, rng),
                               note="GEE cannot fit (separation, one cluster or no convergence): cluster "
                                    f"bootstrap over runs, {_BOOTSTRAP_DRAWS} draws")
            rows.append(row)
    table = pd.DataFrame(rows, columns=[c for c in CASE_COMPARISON_COLUMNS if c != "p_holm"])
    table["p_holm"] = holm_within(table["p"].to_numpy(float), table["fault"].to_numpy()) if len(table) else []
    return table[list(CASE_COMPARISON_COLUMNS)].reset_index(drop=True)


# --------------------------------------------------------------------------- comparison with the paper

#: A difference of detection rates below this is "no practical difference" from the paper's figure
#: (20 percentage points: with the paper's 15 cases per suite even this is rarely within reach).
AGREEMENT_MARGIN = 0.20

PAPER_COMPARISON_COLUMNS: tuple[str, ...] = (
    "suite", "fault", "paper_k", "paper_n", "k", "n", "paper_rate", "rate", "difference", "p", "detectable_difference",
    "verdict")


def detectable_difference(p_ref: float, n_ref: int, n: int, *, alpha: float = DEFAULT_ALPHA,
                          power: float = DEFAULT_POWER) -> float:
    """Smallest |p - p_ref| a two-sided two-sample test of proportions detects with ``power``.

    statsmodels ``NormalIndPower`` on Cohen's arcsine effect size ``h = 2 asin(sqrt(p)) -
    2 asin(sqrt(p_ref))`` (samples ``n_ref`` and ``n``), converted back to a difference of
    rates at ``p_ref``, the smaller of the upward and the downward shift that stays in [0, 1];
    ``inf`` when neither does (the samples are too small to detect any difference).
    """
    from statsmodels.stats.power import NormalIndPower

    if n_ref < 1 or n < 1:
        return math.inf
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            h = float(NormalIndPower().solve_power(nobs1=n_ref, ratio=n / n_ref, alpha=alpha, power=power,
                                                   alternative="two-sided"))
        except (ValueError, RuntimeError):
            return math.inf
    if not np.isfinite(h):
        return math.inf
    phi = math.asin(math.sqrt(min(max(p_ref, 0.0), 1.0)))
    out = math.inf
    for shifted in (phi + h / 2, phi - h / 2):
        if 0 <= shifted <= math.pi / 2:
            out = min(out, abs(math.sin(shifted) ** 2 - p_ref))
    return out


def compare_with_paper(paper: pd.DataFrame, this_run: pd.DataFrame, *, alpha: float = DEFAULT_ALPHA,
                       margin: float = AGREEMENT_MARGIN) -> pd.DataFrame:
    """Two-sample exact comparison of the paper's detection counts with this run's, per suite and fault.

    Test: Boschloo's exact unconditional test (:func:`scipy.stats.boschloo_exact`, two-sided),
    more powerful than Fisher's conditional test on the same 2 x 2 table.  Verdict:
    ``"differs"`` when p < alpha; ``"agrees"`` when it does not differ **and** the smallest
    difference the test could detect with the default power (:data:`~faultlab.vocabulary.DEFAULT_POWER`)
    at these sample sizes
    (:func:`detectable_difference`) is below ``margin``; otherwise ``"inconclusive"`` (the
    samples are too small for "no difference" to mean anything).

    Parameters
    ----------
    paper : DataFrame
        ``suite, fault, paper_k, paper_n``: the printed figures as counts.
    this_run : DataFrame
        ``suite, fault, k, n``: this run's detected / judged cases.
    alpha, margin : float

    Returns
    -------
    DataFrame
        :data:`PAPER_COMPARISON_COLUMNS`, one row per (suite, fault) present in both.
    """
    from scipy.stats import boschloo_exact

    both = paper.merge(this_run, on=["suite", "fault"], how="inner")
    rows = []
    for r in both.itertuples(index=False):
        pk, pn, k, n = int(r.paper_k), int(r.paper_n), int(r.k), int(r.n)
        if pn < 1 or n < 1:
            continue
        table = np.array([[pk, pn - pk], [k, n - k]])
        if (pk == 0 and k == 0) or (pk == pn and k == n):
            p = 1.0  # identical degenerate rates: no evidence of a difference
        else:
            p = float(boschloo_exact(table, alternative="two-sided").pvalue)
        dd = detectable_difference(pk / pn, pn, n, alpha=alpha)
        verdict = "differs" if p < alpha else ("agrees" if dd < margin else "inconclusive")
        rows.append({"suite": r.suite, "fault": r.fault, "paper_k": pk, "paper_n": pn, "k": k, "n": n,
                     "paper_rate": pk / pn, "rate": k / n, "difference": k / n - pk / pn, "p": min(p, 1.0),
                     "detectable_difference": dd, "verdict": verdict})
    return pd.DataFrame(rows, columns=list(PAPER_COMPARISON_COLUMNS))


# --------------------------------------------------------------------------- A/A false alarms

REPLICA_FALSE_ALARM_COLUMNS: tuple[str, ...] = ("rule", "suite", "n_cases", "n_pairs", "flagged", "rate", "low",
                                                "high", "design_effect")


def replica_false_alarms(results: pd.DataFrame, pairs: pd.DataFrame, *, rule: DetectionRule, metric: str = "rms",
                         alpha: float = DEFAULT_ALPHA) -> pd.DataFrame:
    """Empirical false-alarm rate of both rules from the A/A control ``baseline_replica`` vs ``baseline``.

    The replica is the unmodified SLAM with SLAM seeds independent of the baseline's, so every
    "detection" of it is a false alarm.  ``paper``: one trial per repetition whose baseline is
    usable (a crash of the replica alone is flagged, as a fault's would be); trials of one case
    are correlated, so the interval is clustered by case (:func:`faultlab.inference.intervals.clustered_rate`).
    ``statistical``: one trial per judged case (the exact paired test at ``rule.alpha``; the
    replica is its own Holm family, so the per-case level is ``alpha`` under ``family = "fault"``).

    Returns
    -------
    DataFrame
        :data:`REPLICA_FALSE_ALARM_COLUMNS`: per rule, one row per suite and ``"all"``; empty
        without replica jobs.
    """
    from faultlab.inference.intervals import clustered_rate
    from faultlab.vocabulary import BASELINE, REPLICA

    rows = []
    if not (results["variant"] == REPLICA).any():
        return pd.DataFrame(rows, columns=list(REPLICA_FALSE_ALARM_COLUMNS))
    aa = results[results["variant"].isin([BASELINE, REPLICA])]
    stat_rule = DetectionRule(abs_mm=rule.abs_mm, rel=rule.rel, rule="statistical", alpha=rule.alpha,
                              family=rule.family, direction=rule.direction)
    stat = _judged(rule_verdicts(aa, pairs[pairs["fault"] == REPLICA], rule=stat_rule, metric=metric))
    stat = stat[stat["fault"] == REPLICA]
    rep_pairs = pairs[(pairs["fault"] == REPLICA) & (pairs["outcome"] != Outcome.BASELINE_FAILED.value)]
    rep_pairs = rep_pairs.assign(y=rep_pairs["outcome"].isin(
        [Outcome.DETECTED.value, Outcome.CRASH.value, Outcome.TIMEOUT.value]).astype(int))
    for name, trials in (("paper", rep_pairs), ("statistical", stat)):
        suites = ordered(trials["suite"].unique(), SUITE_ORDER)
        for suite in suites + ["all"]:
            t = trials if suite == "all" else trials[trials["suite"] == suite]
            case_id = (t["run"].astype(str) + "/" + t["suite"].astype(str) + "/" + t["case"].astype(str)).to_numpy()
            cr = clustered_rate(t["y"].to_numpy(bool), case_id, alpha=alpha)
            rows.append({"rule": name, "suite": suite, "n_cases": int(len(set(case_id))), "n_pairs": cr.n,
                         "flagged": cr.flagged, "rate": cr.rate, "low": cr.low, "high": cr.high,
                         "design_effect": cr.design_effect})
    return pd.DataFrame(rows, columns=list(REPLICA_FALSE_ALARM_COLUMNS))
