"""Repetitions against cases at a fixed execution budget: which allocation detects more.

A budget of ``B`` paired executions per variant can buy ``n`` cases of ``K`` repetitions each
(``K x n = B``).  More repetitions make each case's exact sign-flip test sharper (its smallest
two-sided p value is ``2^-(K-1)``); more cases make a suite more likely to contain a case the
variant affects, and give the pooled suite test (:mod:`faultlab.stats.pooling`) more units.

The study runs one case pool once at the largest ``K`` with common random numbers (repetition
``r`` of the baseline and of every variant share their seeds) and judges every case again on its
first ``K'`` repetitions for each allocation (:func:`allocation_study`): the allocations share
the cases and the random numbers, so their differences are paired.  For each allocation it draws
``draws`` suites of ``n = B / K'`` pool cases and records which variants each suite detects

* ``by_case``: the per-case minimum -- some case's p <= ``alpha / n`` (Holm's first step), or a
  crash of the variant alone (the study's rule, :func:`~faultlab.stats.killmatrix.suite_detects`);
* ``by_pool``: the pooled sign-flip test over the suite's case mean log ratios at ``alpha``;
* ``combined``: both at ``alpha / 2`` (:func:`~faultlab.stats.pooling.suite_decisions`), the
  family-wise level staying ``alpha``.

Intervals
---------
The unit of evidence is the pool case.  For the per-case rule a suite detects exactly when it
holds a *strong* case (``p <= alpha / n`` or a crash), so its detection probability for ``n``
independently generated cases has the exact interval of
:func:`~faultlab.stats.killmatrix.exact_detection_interval` (Clopper-Pearson over the pool's
strong cases).  The single-case detection share (strong cases / pool) has its Clopper-Pearson
interval.  The pooled and combined rates depend on which cases meet in a suite and are reported as
rates over drawn suites of this pool, with their Monte Carlo standard error only; no claim about
allocations rests on them without a paired comparison across the pool.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from faultlab.stats.metadata import read_rule
from faultlab.errors import ConfigError, ResultsError
from faultlab.runner.store import STUDY_FILE, load_metadata, load_results
from faultlab.seeds import study_seed_sequence
from faultlab.stats.killmatrix import (detection_probability, draw_suites, exact_detection_interval, kill_matrix,
                                       strong_cases)
from faultlab.stats.pooling import pooled_pvalues, suite_decisions
from faultlab.metrics.detection import DetectionRule
from faultlab.inference.exact import MAX_EXACT_PAIRS, alternative_of, min_p_value
from faultlab.inference.intervals import clopper_pearson
from faultlab.vocabulary import DEFAULT_ALPHA

__all__ = ["ALLOCATION_COLUMNS", "allocations", "suite_pooled_pvalues", "allocation_study", "allocation_summary",
           "analyse_allocation"]

#: Columns of :func:`allocation_study`.
ALLOCATION_COLUMNS = ("variant", "k", "n_cases", "budget", "pool", "draws", "reachable", "strong_cases", "case_rate",
                      "case_low", "case_high", "rate_by_case", "rate_by_case_exact", "by_case_low", "by_case_high",
                      "rate_by_pool", "rate_combined", "mc_se")


def allocations(budget: int, ks, pool: int) -> list[tuple[int, int]]:
    """The ``(K, n)`` pairs with ``K x n = budget`` (ConfigError when ``K`` does not divide it or ``n``
    exceeds the pool)."""
    out = []
    for k in sorted(set(int(k) for k in ks)):
        if k < 1 or budget % k:
            raise ConfigError(f"allocation: K = {k} does not divide the budget of {budget} executions")
        n = budget // k
        if n > pool:
            raise ConfigError(f"allocation: K = {k} needs suites of {n} cases, more than the pool's {pool}")
        out.append((k, n))
    if not out:
        raise ConfigError("allocation: no K given")
    return out


def suite_pooled_pvalues(means: np.ndarray, tested: np.ndarray, *, rng: np.random.Generator) -> np.ndarray:
    """Two-sided pooled p value of each suite over its tested cases' mean log ratios.

    Parameters
    ----------
    means : ndarray, shape (m, n)
        Case mean log ratios of each suite.
    tested : ndarray of bool, shape (m, n)
        Which cases enter (finite mean and tested p value); a suite with none gets NaN.
    rng : numpy.random.Generator
        Used only by suites of more than ``MAX_EXACT_PAIRS`` tested cases (Monte Carlo).
    """
    m, n = means.shape
    out = np.full(m, np.nan)
    full = tested.all(axis=1)
    if full.any():
        out[full] = pooled_pvalues(means[full], rng=rng if n > MAX_EXACT_PAIRS else None)[0]
    for i in np.flatnonzero(~full & tested.any(axis=1)):   # suites holding an untested case
        out[i] = pooled_pvalues(means[i, tested[i]][None, :], rng=rng)[0][0]
    return out


def allocation_study(results: pd.DataFrame, *, budget: int, ks, rule: DetectionRule = DetectionRule(),
                     metric: str = "rms", alpha: float = DEFAULT_ALPHA, draws: int = 2000,
                     seed: int = 0) -> pd.DataFrame:
    """Detection of every variant by suites of ``n = budget / K`` cases judged on ``K`` repetitions.

    Parameters
    ----------
    results : DataFrame
        The runner's results of one case pool (one suite kind) at the largest ``K``, with a
        ``baseline`` variant and the repetition index ``rep``.
    budget : int
        Paired executions per variant and suite (``K x n``).
    ks : iterable of int
        Repetitions compared; each case is judged on its first ``K`` repetitions.
    rule : DetectionRule
        Sidedness of the per-case test (two-sided by default).
    alpha : float
        Family-wise level of one suite.
    draws : int
        Suites drawn per allocation; stream ``study_seed_sequence(seed, "allocation", n)``.

    Returns
    -------
    DataFrame
        One row per (variant, K), :data:`ALLOCATION_COLUMNS`: ``reachable`` (whether the per-case
        test with ``K`` pairs can reach ``alpha / n`` at all: a case of an unreachable allocation
        detects only by crashing, and its zero count is structural), ``strong_cases`` (pool cases that
        alone make a suite of ``n`` detect), ``case_rate`` with its Clopper-Pearson interval
        ``case_low, case_high``; ``rate_by_case`` (drawn suites), ``rate_by_case_exact``
        (hypergeometric on the pool) with the exact interval ``by_case_low, by_case_high`` for
        ``n`` generated cases; ``rate_by_pool``, ``rate_combined`` (drawn suites); ``mc_se``
        (largest Monte Carlo standard error of a drawn-suite rate).
    """
    if "rep" not in results.columns:
        raise ResultsError("allocation: the results have no repetition column 'rep'")
    kinds = results["suite"].astype(str).unique()
    if len(kinds) != 1:
        raise ResultsError(f"allocation: the results must hold one case pool, got suite kinds {sorted(kinds)}")
    k_max = int(results["rep"].max()) + 1
    if max(int(k) for k in ks) > k_max:
        raise ConfigError(f"allocation: K = {max(ks)} exceeds the {k_max} repetitions stored")
    rows = []
    for k, n in allocations(budget, ks, results.groupby(["run", "case"]).ngroups):
        km = kill_matrix(results[results["rep"] < k], rule=rule, metric=metric)
        n_pool = km.p.shape[0]
        rng = np.random.default_rng(study_seed_sequence(seed, "allocation", n))
        idx = draw_suites(n_pool, n, draws, rng=rng)                      # (draws, n)
        p = np.moveaxis(km.p[idx], 1, -1)                                   # (draws, V, n)
        crash = np.moveaxis(km.crash[idx], 1, -1)
        means = np.moveaxis(km.mean_log_ratio[idx], 1, -1)
        tested = np.isfinite(means) & np.isfinite(p)
        v = len(km.variants)
        pooled = suite_pooled_pvalues(means.reshape(-1, n), tested.reshape(-1, n), rng=rng).reshape(draws, v)
        flat = dict(case_p=p.reshape(-1, n), pooled_p=pooled.reshape(-1), crash=crash.reshape(-1, n), alpha=alpha)
        by_case = suite_decisions(**flat, combination="min")["detected"].to_numpy().reshape(draws, v)
        by_pool = suite_decisions(**flat, combination="pooled")["detected"].to_numpy().reshape(draws, v)
        combined = suite_decisions(**flat, combination="both")["detected"].to_numpy().reshape(draws, v)
        strong = strong_cases(km, n, alpha=alpha)
        h = strong.sum(axis=0)
        exact = detection_probability(h, n_pool, n)
        lo, hi = exact_detection_interval(h, n_pool, n)
        reachable = bool(min_p_value(k, alternative=alternative_of(rule.direction)) <= alpha / n)
        for j, variant in enumerate(km.variants):
            c_lo, c_hi = clopper_pearson(int(h[j]), n_pool)
            rates = [by_case[:, j].mean(), by_pool[:, j].mean(), combined[:, j].mean()]
            rows.append({"variant": variant, "k": k, "n_cases": n, "budget": budget, "pool": n_pool, "draws": draws,
                         "reachable": reachable, "strong_cases": int(h[j]), "case_rate": h[j] / n_pool, "case_low": c_lo, "case_high": c_hi,
                         "rate_by_case": rates[0], "rate_by_case_exact": float(exact[j]),
                         "by_case_low": float(lo[j]), "by_case_high": float(hi[j]),
                         "rate_by_pool": rates[1], "rate_combined": rates[2],
                         "mc_se": max(math.sqrt(r * (1 - r) / draws) for r in rates)})
    return pd.DataFrame(rows, columns=list(ALLOCATION_COLUMNS))


def allocation_summary(table: pd.DataFrame) -> pd.DataFrame:
    """Per variant: the allocation whose per-case rule detects most, and whether that is shown.

    An allocation is *shown* better than another when the exact intervals of their per-case-rule
    detection probabilities (``by_case_low, by_case_high``) do not overlap; otherwise the answer
    is "not shown".  Columns: ``variant, best_k, best_rate, best_low, best_high, worst_k,
    worst_rate, worst_low, worst_high, answer``.
    """
    rows = []
    for variant, g in table.groupby("variant", sort=False):
        g = g.sort_values(["rate_by_case_exact", "k"], ascending=[False, False])
        best, worst = g.iloc[0], g.iloc[-1]
        if best["rate_by_case_exact"] == worst["rate_by_case_exact"]:
            answer = "no difference"
        elif best["by_case_low"] > worst["by_case_high"]:
            answer = f"K = {int(best['k'])} shown better than K = {int(worst['k'])}"
        else:
            answer = "not shown"
        rows.append({"variant": variant, "best_k": int(best["k"]), "best_rate": best["rate_by_case_exact"],
                     "best_low": best["by_case_low"], "best_high": best["by_case_high"], "worst_k": int(worst["k"]),
                     "worst_rate": worst["rate_by_case_exact"], "worst_low": worst["by_case_low"],
                     "worst_high": worst["by_case_high"], "answer": answer})
    return pd.DataFrame(rows)


def analyse_allocation(out: str | Path, *, budget: int, ks, draws: int = 2000, seed: int = 0,
                       alpha: float = DEFAULT_ALPHA) -> tuple[pd.DataFrame, pd.DataFrame, dict]:
    """:func:`allocation_study` and :func:`allocation_summary` of a study's store (runs nothing).

    Returns the table, the summary and a meta dict: scale (pool, stored K, steps, particles,
    variants), SLAM time, the sessions' wall time and sampled load (from ``study.json``).
    """
    out = Path(out)
    results = load_results(out)
    meta = load_metadata(out)
    rule, _ = read_rule(meta)
    exp = meta["experiment"]
    table = allocation_study(results, budget=budget, ks=ks, rule=rule, metric=exp.get("metric", "rms"), alpha=alpha,
                             draws=draws, seed=seed)
    try:
        sessions = json.loads((out / STUDY_FILE).read_text()).get("sessions", [])
    except (OSError, ValueError):
        sessions = []
    load = [s[1] for session in sessions for s in session.get("load", [])]
    info = {"budget": budget, "ks": sorted(int(k) for k in ks), "alpha": alpha, "draws": draws, "seed": seed,
            "alternative": alternative_of(rule.direction), "stored_k": int(exp["repetitions"]),
            "pool": int(results.groupby(["run", "case"]).ngroups), "n_steps": exp["n_steps"], "slam": exp["slam"],
            "variants": list(dict.fromkeys(results["variant"].astype(str))), "n_jobs": int(len(results)),
            "status_counts": {str(k): int(v) for k, v in results["status"].astype(str).value_counts().items()},
            "slam_time_s": float(results["runtime_s"].sum()),
            "wall_time_s": float(sum(s.get("wall_time_s") or 0.0 for s in sessions)),
            "load1_mean": float(np.mean(load)) if load else None, "load1_max": float(np.max(load)) if load else None}
    return table, allocation_summary(table), info
