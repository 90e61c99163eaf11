"""A/A controls of a strategies study: each strategy against itself on independent draws.

A strategy's pool holds one generated suite per evaluation run, and the runs are independent
draws of the generator.  Its A/A control splits the runs in two halves (alternate runs in run
order: the first, third, ... against the second, fourth, ...), so the two halves are independent
samples of the same strategy, and compares them with the tests the study compares two strategies
with:

* **per fault**: the share of a half's cases that alone detect the fault, by the two-sided
  Agresti-Caffo test of two proportions (statsmodels ``test_proportions_2indep``), as
  :func:`~faultlab.stats.killmatrix.compare_detection`; the family is the strategy's faults;
* **mean over the faults, the case as unit**: Welch's t test of the halves' case scores, as
  :func:`~faultlab.stats.killmatrix.compare_mean_detection`;
* **mean over the faults, the run as unit**: the t test over the differences of consecutive runs'
  mean scores (run 1 - run 2, run 3 - run 4, ...; :func:`faultlab.inference.clusters.compare_by_cluster`),
  the cluster-level analysis the declared comparisons use.

Every null hypothesis is true here, so every rejection is a false alarm.  Two rates are kept apart
and never set side by side as if comparable: the **per-comparison** rate (rejections at ``alpha``
without adjustment over all comparisons of a kind: its nominal value is ``alpha``) and the
**family-wise** outcome (whether Holm over a strategy's family rejects any: its nominal rate is at
most ``alpha`` per family, and a study has one family per strategy).  The comparisons of one
strategy share its cases, so their count is not an independent sample size: the Clopper-Pearson
interval of the per-comparison rate is nominal.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd
from scipy.stats import ttest_ind
from statsmodels.stats.proportion import test_proportions_2indep

from faultlab.inference.clusters import compare_by_cluster
from faultlab.inference.intervals import clopper_pearson
from faultlab.inference.multiplicity import holm
from faultlab.stats.killmatrix import KillMatrix, case_scores, strong_cases
from faultlab.vocabulary import DEFAULT_ALPHA

__all__ = ["CONTROL_COLUMNS", "CONTROL_SUMMARY_COLUMNS", "aa_halves", "aa_controls", "aa_summary"]

#: Columns of :func:`aa_controls`: one row per (strategy, comparison).
CONTROL_COLUMNS = ("strategy", "comparison", "unit", "variant", "runs_a", "runs_b", "n_a", "n_b", "diff", "p",
                   "false_alarm", "p_holm_family", "family_false_alarm")
#: Columns of :func:`aa_summary`: one row per kind of comparison.
CONTROL_SUMMARY_COLUMNS = ("comparison", "unit", "comparisons", "false_alarms", "false_alarm_rate",
                           "false_alarm_rate_low", "false_alarm_rate_high", "families", "families_with_false_alarm",
                           "family_rule")


def aa_halves(runs) -> tuple[np.ndarray, np.ndarray]:
    """The two halves of a strategy's evaluation runs: alternate runs in run order."""
    runs = np.unique(np.asarray(runs))
    return runs[0::2], runs[1::2]


def aa_controls(km: KillMatrix, variants, *, alpha: float = DEFAULT_ALPHA, timeouts_detect: bool = False,
                kind: str = "fault") -> pd.DataFrame:
    """Every strategy with at least two runs against itself (see the module docstring): one row per
    comparison with its p value, whether it is a false alarm at ``alpha`` (unadjusted), its Holm
    p value within the strategy's family of per-variant comparisons (NaN for the means, each a family
    of one) and whether that family holds a false alarm under Holm.  ``kind`` names the variants in
    the ``comparison`` column (``per fault``, ``mean over the faults``; ``mutant`` for a study of mutants)."""
    variants = list(variants)
    cols = [km.variants.index(v) for v in variants]
    strong = strong_cases(km, 1, alpha=alpha, timeouts_detect=timeouts_detect)[:, cols]
    score = case_scores(km, variants, alpha=alpha, timeouts_detect=timeouts_detect)
    strategy = km.cases["strategy"].to_numpy()
    run = km.cases["run"].to_numpy()
    rows = []
    for s in km.strategies:
        mine = strategy == s
        first, second = aa_halves(run[mine])
        if first.size == 0 or second.size == 0:
            continue
        a, b = mine & np.isin(run, first), mine & np.isin(run, second)
        base = {"strategy": s, "runs_a": int(first.size), "runs_b": int(second.size), "n_a": int(a.sum()),
                "n_b": int(b.sum())}
        per_fault = []
        for j, v in enumerate(variants):
            ka, kb = int(strong[a, j].sum()), int(strong[b, j].sum())
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                p = float(test_proportions_2indep(ka, base["n_a"], kb, base["n_b"], method="agresti-caffo",
                                                  compare="diff").pvalue)
            per_fault.append(base | {"comparison": f"per {kind}", "unit": "case", "variant": v,
                                     "diff": ka / base["n_a"] - kb / base["n_b"], "p": p})
        p_holm = holm(np.array([r["p"] for r in per_fault]), alpha=alpha)[1]
        family = bool((p_holm <= alpha).any())
        for r, ph in zip(per_fault, p_holm):
            rows.append(r | {"p_holm_family": float(ph), "family_false_alarm": family})
        xa, xb = score[a], score[b]
        p_case = math.nan
        if xa.size > 1 and xb.size > 1 and (np.ptp(xa) > 0 or np.ptp(xb) > 0):
            p_case = float(ttest_ind(xa, xb, equal_var=False).pvalue)
        rows.append(base | {"comparison": f"mean over the {kind}s", "unit": "case", "variant": "",
                            "diff": float(xa.mean() - xb.mean()), "p": p_case, "p_holm_family": math.nan,
                            "family_false_alarm": bool(p_case <= alpha)})
        # consecutive runs paired: run 1 - run 2, run 3 - run 4, ...; an odd last run has no partner
        order = np.unique(run[mine])
        pair = {r: i // 2 for i, r in enumerate(order[: 2 * (order.size // 2)])}
        paired = mine & np.isin(run, list(pair))
        by_run = compare_by_cluster(score[paired], arm=np.isin(run[paired], first),
                                    cluster=np.array([pair[r] for r in run[paired]]), alpha=alpha)
        rows.append(base | {"comparison": f"mean over the {kind}s", "unit": "run", "variant": "",
                            "diff": by_run.estimate, "p": by_run.p, "p_holm_family": math.nan,
                            "family_false_alarm": bool(by_run.p <= alpha)})
    out = pd.DataFrame(rows, columns=[c for c in CONTROL_COLUMNS if c != "false_alarm"])
    out.insert(out.columns.get_loc("p") + 1, "false_alarm", out["p"].to_numpy(float) <= alpha)
    return out[list(CONTROL_COLUMNS)]


def aa_summary(controls: pd.DataFrame, *, alpha: float = DEFAULT_ALPHA) -> pd.DataFrame:
    """Per kind of A/A comparison: the per-comparison false-alarm rate (unadjusted, with its nominal
    Clopper-Pearson interval at ``1 - alpha``: ``false_alarm_rate``, ``false_alarm_rate_low``,
    ``false_alarm_rate_high``) and, in separate columns, the families (one per strategy) with a false
    alarm under their own multiplicity rule (``family_rule``), so the two are never read as one."""
    rows = []
    for (comparison, unit), g in controls.groupby(["comparison", "unit"], sort=False):
        tested = g[np.isfinite(g["p"].to_numpy(float))]
        n, k = len(tested), int(tested["false_alarm"].sum())
        lo, hi = clopper_pearson(k, n, alpha=alpha)
        families = tested.groupby("strategy")["family_false_alarm"].any()
        rows.append({"comparison": comparison, "unit": unit, "comparisons": n, "false_alarms": k,
                     "false_alarm_rate": k / n if n else math.nan, "false_alarm_rate_low": float(lo),
                     "false_alarm_rate_high": float(hi), "families": int(families.size),
                     "families_with_false_alarm": int(families.sum()),
                     "family_rule": f"Holm over the strategy's {comparison[4:]}s" if comparison.startswith("per ")
                     else "one comparison per strategy"})
    return pd.DataFrame(rows, columns=list(CONTROL_SUMMARY_COLUMNS))
