"""Several SLAMs under one protocol: accuracy and fault sensitivity side by side.

:func:`compare_slams` analyses one results store per SLAM (the same experiment with another
``[slam]`` table, e.g. ``experiments/slams.toml``) with :func:`faultlab.analysis.analyse` and
collects, per SLAM, what a cross-SLAM report shows:

* ``accuracy``: the baseline's map error over the cases (:func:`faultlab.stats.accuracy.case_mean_accuracy`),
  in the campaign's primary metric -- Kabsch-aligned RMS for a SLAM with landmark ids, the earth
  mover's distance for one that associates landmarks itself (no ids, no correspondences);
* ``sensitivity``: per fault, the cases the campaign's rule detects among the judged ones, pooled
  over the suites (:func:`faultlab.stats.cases.case_rates`), beside the per-repetition rate of the
  paper's rule (the Analysis's ``detection_rates``); ``n_exact`` of the cases were judged by their
  exact difference (a deterministic SLAM: bit-identical repetitions, :mod:`faultlab.stats.verdict`),
  never by a test over copies of one execution; ``effect_*`` the campaign-level verdict over the
  fault's cases (:func:`faultlab.stats.pooling.campaign_verdicts`: the geometric-mean error factor,
  the interval of the sign-flip test over the cases, its p, smallest attainable p and verdict);
* ``not_judged``: per fault, why it could not be judged: the fault does not apply to the SLAM (it
  replaces a unit the SLAM does not have), cases without a verdict, failed jobs; and SLAMs that
  were not run (optional dependency missing).

Statistics come from :mod:`faultlab.stats` through the per-store :class:`~faultlab.analysis.Analysis`;
the report (:mod:`faultlab.report.slams`) only renders this object.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from faultlab.stats.metadata import judged_metric
from faultlab.analysis.result import analyse
from faultlab.precision import write_csv
from faultlab.runner.store import load_results
from faultlab.stats.accuracy import ACCURACY_COLUMNS, case_mean_accuracy
from faultlab.stats.cases import case_rates
from faultlab.stats.detection import outcomes
from faultlab.stats.rates import tabulate_rates
from faultlab.stats.verdict import EXACT, Verdict
from faultlab.vocabulary import BASELINE, DEFAULT_ALPHA, JobStatus

__all__ = ["SlamComparison", "compare_slams", "ACCURACY", "SENSITIVITY", "NOT_JUDGED"]

#: Columns of :attr:`SlamComparison.accuracy`.
ACCURACY: tuple[str, ...] = ("slam", "name", "association", "metric") + ACCURACY_COLUMNS + (
    "n_failed", "runtime_median_s")
#: Columns of :attr:`SlamComparison.sensitivity`.
SENSITIVITY: tuple[str, ...] = ("slam", "fault", "metric", "rule", "n_cases", "n_cannot_judge", "n", "k", "rate",
                                "cp_low", "cp_high", "n_exact", "mde_median_mm", "mde_min_mm", "mde_max_mm", "rep_k",
                                "rep_n", "rep_rate", "rep_low", "rep_high", "effect_ratio", "effect_low",
                                "effect_high", "effect_p", "effect_p_min", "effect_verdict")
#: Columns of :attr:`SlamComparison.not_judged`.
NOT_JUDGED: tuple[str, ...] = ("slam", "fault", "what", "count", "reason")


@dataclass(frozen=True)
class SlamComparison:
    """The cross-SLAM tables (see the module docstring) and the protocol they come from.

    Attributes
    ----------
    alpha : float
        1 - confidence level of every interval.
    protocol : dict
        Per SLAM label: the experiment's description, hash, metric, rule (JSON-shaped), K, suites,
        steps, the ``[slam]`` table and the campaign's wall time (s, as the store recorded it).
    accuracy, sensitivity, not_judged : DataFrame
        :data:`ACCURACY`, :data:`SENSITIVITY`, :data:`NOT_JUDGED`.
    """

    alpha: float
    protocol: dict
    accuracy: pd.DataFrame
    sensitivity: pd.DataFrame
    not_judged: pd.DataFrame

    def save(self, out: str | Path) -> None:
        """``accuracy.csv``, ``sensitivity.csv``, ``not_judged.csv`` and ``protocol.json`` in ``out``."""
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        for name in ("accuracy", "sensitivity", "not_judged"):
            write_csv(getattr(self, name), out / f"{name}.csv")
        (out / "protocol.json").write_text(json.dumps({"alpha": self.alpha, "slams": self.protocol}, indent=2,
                                                      sort_keys=True) + "\n")


def compare_slams(stores: Mapping[str, str | Path], *, alpha: float = DEFAULT_ALPHA,
                  not_installed: Sequence[str] = ()) -> SlamComparison:
    """Analyse one results store per SLAM and collect the cross-SLAM tables.

    Parameters
    ----------
    stores : mapping
        SLAM label -> results directory (``run_experiment``'s ``out``), in report order.
    alpha : float
        1 - confidence level.
    not_installed : sequence of str
        Labels of SLAMs that were not run (an optional dependency is missing); listed in ``not_judged``.
    """
    acc, sens, missing = [], [], []
    protocol = {}
    for label, store in stores.items():
        a = analyse(store, alpha=alpha, paper=False)
        md = a.metadata
        metric = judged_metric(md)
        exp = md.get("experiment") or {}
        slam = dict(exp.get("slam") or {})
        association = str(slam.get("association", "known"))
        protocol[label] = {"description": md.get("description", ""), "hash": md.get("experiment_hash"),
                           "metric": metric, "rule": md.get("detection"), "repetitions": exp.get("repetitions"),
                           "suites": exp.get("suites"), "n_steps": exp.get("n_steps"), "slam": slam,
                           "wall_time_s": md.get("wall_time_s")}
        value = f"{metric}_mm"
        jobs = a.jobs
        base = jobs[jobs["variant"] == BASELINE]
        ok = base[base["status"] == JobStatus.OK.value]
        row = {"slam": label, "name": slam.get("name", ""), "association": association, "metric": metric,
               **case_mean_accuracy(ok, value=value, case=["run", "suite", "case"], alpha=alpha),
               "n_failed": int(len(base) - len(ok)),
               "runtime_median_s": float(base["runtime_s"].median()) if len(base) else math.nan}
        acc.append(row)
        sens.extend(_sensitivity(label, a, metric, alpha, store))
        missing.extend(_not_judged(label, a))
    for label in not_installed:
        missing.append({"slam": label, "fault": "(all)", "what": "not run", "count": 0,
                        "reason": "its optional dependency is not installed"})
    return SlamComparison(alpha=alpha, protocol=protocol, accuracy=pd.DataFrame(acc, columns=list(ACCURACY)),
                          sensitivity=pd.DataFrame(sens, columns=list(SENSITIVITY)),
                          not_judged=pd.DataFrame(missing, columns=list(NOT_JUDGED)))


def _sensitivity(label: str, a, metric: str, alpha: float, store) -> list[dict]:
    """Per fault: pooled case rates of the campaign's rule and the per-repetition rate of the paper's rule.

    Both in the campaign's primary metric.  ``mde_*_mm``: the median, smallest and largest over the
    fault's judged cases of the smallest shift the case's decision detects with the default power at the
    level it was judged at (the verdicts' ``mde_mm``, :func:`faultlab.stats.verdict.case_verdicts`):
    what a "not detected" could have missed.  The per-repetition rates count every repetition (the
    Analysis's Table II rates judge one repetition per case, in RMS), classified by the campaign's
    rule applied to that metric (:func:`faultlab.stats.detection.outcomes`).
    """
    verdicts = a.case_verdicts
    verdicts = verdicts[verdicts["fault"] != "baseline_replica"]
    if verdicts.empty:
        return []
    pooled = case_rates(verdicts.assign(suite="all"), alpha=alpha)
    results = load_results(store)
    reps = tabulate_rates(outcomes(results.assign(rms_mm=results[f"{metric}_mm"]), rule=a.rule),
                          alpha=alpha).rename(columns={"fault": "variant"})
    campaign = a.campaign_verdicts.set_index("fault")
    exact = a.case_verdicts.loc[a.case_verdicts["test"] == EXACT, "fault"].value_counts()
    rows = []
    for r in pooled.itertuples(index=False):
        cv = campaign.loc[r.fault] if r.fault in campaign.index else None
        rep = reps[reps["variant"] == r.fault]
        k, n = (int(rep["k"].sum()), int(rep["n"].sum())) if len(rep) else (0, 0)
        rep_row = rep.iloc[0] if len(rep) == 1 else None
        mde = verdicts.loc[(verdicts["fault"] == r.fault) & verdicts["mde_mm"].notna(), "mde_mm"].to_numpy(float)
        rows.append({"slam": label, "fault": r.fault, "metric": metric, "rule": r.rule, "n_cases": r.n_cases,
                     "n_cannot_judge": r.n_cannot_judge, "n": r.n, "k": r.k, "rate": r.rate,
                     "cp_low": r.cp_low, "cp_high": r.cp_high, "n_exact": int(exact.get(r.fault, 0)),
                     "mde_median_mm": float(np.median(mde)) if mde.size else math.nan,
                     "mde_min_mm": float(mde.min()) if mde.size else math.nan,
                     "mde_max_mm": float(mde.max()) if mde.size else math.nan, "rep_k": k, "rep_n": n,
                     "rep_rate": k / n if n else math.nan,
                     "rep_low": float(rep_row["wilson_low"]) if rep_row is not None else math.nan,
                     "rep_high": float(rep_row["wilson_high"]) if rep_row is not None else math.nan,
                     **({f"effect_{k}": cv[k] for k in ("ratio", "p", "p_min", "verdict")}
                        | {"effect_low": cv["ratio_low"], "effect_high": cv["ratio_high"]}
                        if cv is not None else {"effect_ratio": math.nan, "effect_low": math.nan,
                                                "effect_high": math.nan, "effect_p": math.nan,
                                                "effect_p_min": math.nan, "effect_verdict": ""})})
    return rows


def _not_judged(label: str, a) -> list[dict]:
    """Faults that do not apply, cases without a verdict (by reason), failed jobs (by variant and status)."""
    rows = [{"slam": label, "fault": s["fault"], "what": "not applicable", "count": 0, "reason": s["reason"]}
            for s in a.metadata.get("skipped_variants") or []]
    v = a.case_verdicts
    cj = v[v["verdict"] == Verdict.CANNOT_JUDGE.value]
    for (fault, reason), g in cj.groupby(["fault", "reason"], sort=True):
        rows.append({"slam": label, "fault": fault, "what": "cases without a verdict", "count": len(g),
                     "reason": reason})
    jobs = a.jobs
    bad = jobs[jobs["status"] != JobStatus.OK.value]
    for (variant, status), g in bad.groupby(["variant", "status"], sort=True):
        rows.append({"slam": label, "fault": variant, "what": f"{status} jobs", "count": len(g),
                     "reason": f"{len(g)} of {int((jobs['variant'] == variant).sum())} jobs ended with {status}"})
    return rows
