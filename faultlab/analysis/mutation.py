"""The analysis of a mutation campaign's store: outcomes per mutant and suite, scores, suite comparisons.

The campaign itself (mutants selected by a ``[mutation]`` table, statistical kills at
``alpha / n_cases``, early stopping) is :mod:`faultlab.campaigns.mutation`; a case kills a mutant
as :func:`faultlab.stats.killmatrix.suite_kills` says.

:class:`MutationAnalysis` holds ``outcomes`` (one row per mutant and suite), ``scores`` (mutation
score per suite kind, per suite kind and operator, per suite kind and unit, with exact
Clopper-Pearson intervals) and ``mcnemar`` (suite kinds compared on the same mutant and run pairs
with the exact McNemar test, Holm-adjusted over the comparisons).  Score = killed (incl. crash and
timeout) / (killed + survived); mutants the baseline made unjudgeable are excluded and counted.
"""

from __future__ import annotations

import itertools
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from statsmodels.stats.multitest import multipletests
from statsmodels.stats.contingency_tables import mcnemar
from statsmodels.stats.proportion import proportion_confint

from faultlab.analysis.bundle import TableBundle
from faultlab.errors import ResultsError
from faultlab.mutation.variants import mutant_variant
from faultlab.mutation.outcome import MutantOutcome
from faultlab.runner.store import MUTATION_FILE, load_metadata, load_results
from faultlab.stats.killmatrix import suite_kills

__all__ = ["MUTATION_TABLES", "MutationAnalysis", "analyse_mutation", "mutation_scores", "compare_suites",
           "clopper_pearson"]

#: Tables of a :class:`MutationAnalysis`, saved as ``<name>.csv``.
MUTATION_TABLES = ("outcomes", "scores", "mcnemar")
OUTCOME_COLUMNS = ["mutant", "unit", "operator", "run", "suite", "outcome", "represented_by", "killing_case",
                   "n_cases_run", "n_cases", "min_p", "min_mde_mm", "note"]


def clopper_pearson(k: int, n: int, alpha: float = 0.05) -> tuple[float, float]:
    """Exact two-sided (1 - alpha) interval of a binomial proportion (NaN, NaN for n = 0)."""
    if n == 0:
        return math.nan, math.nan
    lo, hi = proportion_confint(k, n, alpha=alpha, method="beta")
    return float(lo), float(hi)


@dataclass(frozen=True, eq=False)
class MutationAnalysis(TableBundle):
    """Outcomes, scores and suite comparisons of a mutation campaign (frozen; save/load as CSV + JSON).

    Attributes
    ----------
    outcomes : DataFrame
        One row per (mutant, run, suite) (``OUTCOME_COLUMNS``): ``outcome`` is a
        :class:`MutantOutcome` value or ``cannot_judge``; screened-out mutants have one row per
        suite with their class and ``represented_by`` for duplicates (which inherit nothing).
    scores, mcnemar : DataFrame
    meta : dict
        ``alpha``, run time, counts.
    """

    outcomes: pd.DataFrame
    scores: pd.DataFrame
    mcnemar: pd.DataFrame
    meta: dict = field(default_factory=dict)

    TABLES = MUTATION_TABLES
    META_FILE = "mutation_meta.json"
    WHAT = "mutation analysis"


def _outcomes(results: pd.DataFrame, sel: dict, metric: str, suites: dict | None = None) -> pd.DataFrame:
    alpha = float(sel["alpha"])
    ncases = results.groupby(["run", "suite"])["case"].max().to_dict()
    if suites:  # the experiment's case counts: an interrupted campaign has not reached the last cases
        ncases = {k: int(suites.get(k[1], n)) for k, n in ncases.items()}
    rows = []
    per_suite = {}
    for (run, suite), n in ncases.items():
        part = results[(results["run"] == run) & (results["suite"] == suite)]
        per_suite[(run, suite)] = suite_kills(part, case_alpha=alpha / n, metric=metric)
    for mid in sel["run"]:
        variant = mutant_variant(mid)
        for (run, suite), v in per_suite.items():
            mv = v[v["fault"] == variant].sort_values("case")
            n = ncases[(run, suite)]
            base = dict(mutant=mid, unit=sel["unit"].get(mid, ""), operator=sel["operator"].get(mid, ""), run=run,
                        suite=suite, represented_by="", n_cases=n, n_cases_run=len(mv), note="")
            kills = mv[mv["kill"] != ""]
            p = pd.to_numeric(mv["p"], errors="coerce")
            mde = pd.to_numeric(mv["mde_mm"], errors="coerce")
            base["min_p"] = float(p.min()) if p.notna().any() else math.nan
            base["min_mde_mm"] = float(mde.min()) if mde.notna().any() else math.nan
            if len(kills):
                first = kills.iloc[0]
                rows.append(base | dict(outcome=first["kill"], killing_case=int(first["case"])))
            elif len(mv) < n:
                rows.append(base | dict(outcome=INCOMPLETE, killing_case=0,
                                        note=f"{len(mv)} of {n} cases run"))
            elif (mv["verdict"] == "cannot_judge").all():
                rows.append(base | dict(outcome="cannot_judge", killing_case=0,
                                        note="; ".join(sorted(set(mv["reason"].astype(str))))))
            else:
                rows.append(base | dict(outcome=MutantOutcome.SURVIVED.value, killing_case=0,
                                        note=f"smallest detectable shift {base['min_mde_mm']:.0f} mm (80 % power)"))
    for mid, cls in sel["screened"].items():
        for (run, suite), n in ncases.items():
            rows.append(dict(mutant=mid, unit=sel["unit"].get(mid, ""), operator=sel["operator"].get(mid, ""),
                             run=run, suite=suite, outcome=cls, represented_by=sel["represented_by"].get(mid, ""),
                             killing_case=0, n_cases_run=0, n_cases=n, min_p=math.nan, min_mde_mm=math.nan,
                             note="not run (screened out)"))
    return pd.DataFrame(rows, columns=OUTCOME_COLUMNS)


INCOMPLETE = "incomplete"
KILL_CLASSES = (MutantOutcome.KILLED.value, MutantOutcome.CRASH.value, MutantOutcome.TIMEOUT.value)


def mutation_scores(outcomes: pd.DataFrame, *, alpha: float = 0.05) -> pd.DataFrame:
    """Mutation score per suite kind, per (suite kind, operator) and per (suite kind, unit).

    Score = killed / (killed + survived + incomplete) over the (mutant, run) rows that ran
    (``crash`` and ``timeout`` count as killed), with a Clopper-Pearson ``1 - alpha`` interval.
    An ``incomplete`` mutant (not killed by the cases run so far of an interrupted campaign)
    counts as not killed, so the score of an interrupted campaign is a lower bound.
    """
    judged = outcomes[outcomes["outcome"].isin((*KILL_CLASSES, MutantOutcome.SURVIVED.value, INCOMPLETE))]
    rows = []
    for by in (None, "operator", "unit"):
        keys = ["suite"] + ([by] if by else [])
        for key, g in judged.groupby(keys, sort=True):
            key = key if isinstance(key, tuple) else (key,)
            k = int(g["outcome"].isin(KILL_CLASSES).sum())
            n = len(g)
            lo, hi = clopper_pearson(k, n, alpha)
            rows.append(dict(suite=key[0], by=by or "all", group=key[1] if by else "all", killed=k, judged=n,
                             crash=int((g["outcome"] == "crash").sum()), timeout=int((g["outcome"] == "timeout").sum()),
                             incomplete=int((g["outcome"] == INCOMPLETE).sum()), score=k / n, ci_low=lo, ci_high=hi))
    return pd.DataFrame(rows, columns=["suite", "by", "group", "killed", "judged", "crash", "timeout", "incomplete",
                                       "score", "ci_low", "ci_high"])


def compare_suites(outcomes: pd.DataFrame, suites) -> pd.DataFrame:
    """Exact McNemar test (statsmodels ``mcnemar(exact=True)``) of every pair of suite kinds on the
    (mutant, run) pairs both judged; Holm-adjusted over the pairs."""
    judged = outcomes[outcomes["outcome"].isin((*KILL_CLASSES, MutantOutcome.SURVIVED.value))]
    kill = judged.assign(k=judged["outcome"].isin(KILL_CLASSES)).pivot_table(
        index=["mutant", "run"], columns="suite", values="k", aggfunc="first")
    rows = []
    for a, b in itertools.combinations([s for s in suites if s in kill.columns], 2):
        both = kill[[a, b]].dropna().astype(bool)
        ka, kb = both[a].to_numpy(), both[b].to_numpy()
        t = np.array([[np.sum(ka & kb), np.sum(ka & ~kb)], [np.sum(~ka & kb), np.sum(~ka & ~kb)]])
        p = float(mcnemar(t, exact=True).pvalue) if len(both) else math.nan
        rows.append(dict(suite_a=a, suite_b=b, n=len(both), both=int(t[0, 0]), a_only=int(t[0, 1]),
                         b_only=int(t[1, 0]), neither=int(t[1, 1]), p=p))
    df = pd.DataFrame(rows, columns=["suite_a", "suite_b", "n", "both", "a_only", "b_only", "neither", "p"])
    ok = df["p"].notna().to_numpy()
    df["p_holm"] = math.nan
    if ok.any():
        df.loc[ok, "p_holm"] = multipletests(df.loc[ok, "p"].to_numpy(), method="holm")[1]
    return df


def analyse_mutation(out: str | Path, *, alpha: float = 0.05) -> MutationAnalysis:
    """The :class:`MutationAnalysis` of the campaign saved in ``out`` (runs nothing)."""
    out = Path(out)
    try:
        sel = json.loads((out / MUTATION_FILE).read_text())
    except OSError as exc:
        raise ResultsError(f"{out}: no {MUTATION_FILE}: not a mutation campaign ({exc})") from exc
    meta = load_metadata(out)
    exp = meta.get("experiment", {})
    results = load_results(out)
    metric = exp.get("metric", "rms") if isinstance(exp, dict) else "rms"
    spec = exp.get("suites", {}) if isinstance(exp, dict) else {}
    pairs = spec.items() if isinstance(spec, dict) else (tuple(p) for p in spec)  # stored as [[kind, n], ...]
    outcomes = _outcomes(results, sel, metric, {k: v for k, v in pairs if isinstance(v, int)})
    suites = list(dict.fromkeys(results["suite"]))
    info = dict(alpha=sel["alpha"], n_mutants_run=len(sel["run"]), n_screened=len(sel["screened"]),
                n_jobs=len(results), runtime_s_sum=float(results["runtime_s"].sum()),
                status_counts={k: int(v) for k, v in results["status"].value_counts().items()},
                repetitions=int(results["rep"].max()) + 1, suites=suites,
                outcome_counts={f"{s}:{o}": int(n) for (s, o), n in
                                outcomes.groupby(["suite", "outcome"]).size().items()})
    return MutationAnalysis(outcomes=outcomes, scores=mutation_scores(outcomes, alpha=alpha),
                            mcnemar=compare_suites(outcomes, suites), meta=info)
