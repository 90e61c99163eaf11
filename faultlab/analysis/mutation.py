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
from statsmodels.stats.contingency_tables import mcnemar

from faultlab.analysis.bundle import TableBundle
from faultlab.stats.metadata import judged_metric
from faultlab.errors import ResultsError
from faultlab.mutation.variants import mutant_variant
from faultlab.mutation.outcome import MutantOutcome
from faultlab.runner.staging import STOPS_KEY
from faultlab.runner.store import MUTATION_FILE, load_metadata, load_results
from faultlab.stats.exactkill import exact_kills
from faultlab.stats.killmatrix import suite_kills
from faultlab.inference.intervals import clopper_pearson
from faultlab.inference.multiplicity import holm
from faultlab.vocabulary import DEFAULT_ALPHA, PAPER_DIRECTION, POWER_TEXT

__all__ = ["MUTATION_TABLES", "MutationAnalysis", "analyse_mutation", "mutation_scores", "compare_suites",
           "mutant_outcomes", "stored_direction", "adaptive_savings", "OBSERVED_EQUIVALENT"]

#: Tables of a :class:`MutationAnalysis`, saved as ``<name>.csv``.
MUTATION_TABLES = ("outcomes", "scores", "mcnemar")
OUTCOME_COLUMNS = ["mutant", "unit", "operator", "run", "suite", "outcome", "survival", "represented_by",
                   "killing_case", "direction", "median_diff_mm", "ratio", "n_cases_run", "n_cases", "min_p",
                   "max_p_equivalence", "min_mde_mm", "reps_used", "n_stopped", "note"]


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


def stored_direction(sel: dict) -> str:
    """The direction a stored campaign's kills (and so its early stopping) used: its ``direction``, or
    the paper's one-sided ``"worse"`` for a campaign recorded before the choice existed."""
    return str(sel.get("direction", PAPER_DIRECTION))


def mutant_outcomes(results: pd.DataFrame, sel: dict, metric: str = "rms", suites: dict | None = None,
                    stops=()) -> pd.DataFrame:
    """One row per (mutant, run, suite), :data:`OUTCOME_COLUMNS`, from a campaign's results and its
    ``mutation.json`` record ``sel`` (``alpha``, ``direction``, ``run``, ``screened``, ``unit``,
    ``operator``, ``represented_by``); see the module docstring.

    ``stops`` are the adaptive stops of the store (:data:`~faultlab.runner.staging.STOPS_KEY`
    entries): a pair stopped early is not killed on its case
    (:func:`~faultlab.stats.killmatrix.suite_kills`).  ``reps_used`` lists the repetitions each
    case run used (``/``-separated, case order), ``n_stopped`` how many of them stopped early;
    ``min_mde_mm`` is the smallest detectable shift over the cases at the per-case level from the
    pairs each case actually used (infinite on a case whose pairs cannot reach the level, written as a
    blank cell: none detectable).
    """
    stopped = {(int(e["run"]), str(e["suite"]), int(e["case"]), str(e["variant"])): str(e["reason"])
               for e in stops or ()}
    alpha = float(sel["alpha"])
    direction = stored_direction(sel)
    ncases = results.groupby(["run", "suite"])["case"].max().to_dict()
    if suites:  # the experiment's case counts: an interrupted campaign has not reached the last cases
        ncases = {k: int(suites.get(k[1], n)) for k, n in ncases.items()}
    rows = []
    per_suite = {}
    exact = sel.get("kill") == EXACT_KILL
    for (run, suite), n in ncases.items():
        part = results[(results["run"] == run) & (results["suite"] == suite)]
        per_suite[(run, suite)] = (exact_kills(part, metric=metric) if exact else
                                   suite_kills(part, case_alpha=float(sel.get("case_alpha") or alpha / n),
                                               metric=metric, direction=direction, stopped=stopped))
    for mid in sel["run"]:
        variant = mutant_variant(mid)
        mine = {rs: v[v["fault"] == variant].sort_values("case") for rs, v in per_suite.items()}
        # bit-identical to the baseline in every paired run of every case of every suite
        observed_equivalent = all(len(mv) == ncases[rs] and mv["identical"].all() for rs, mv in mine.items())
        for (run, suite), mv in mine.items():
            n = ncases[(run, suite)]
            base = dict(mutant=mid, unit=sel["unit"].get(mid, ""), operator=sel["operator"].get(mid, ""), run=run,
                        suite=suite, represented_by="", n_cases=n, n_cases_run=len(mv), note="", survival="",
                        direction="", median_diff_mm=math.nan, ratio=math.nan,
                        reps_used="/".join(str(int(k)) for k in mv["n_reps"]),
                        n_stopped=int((mv["stopped"] != "").sum()))
            kills = mv[mv["kill"] != ""]
            p = pd.to_numeric(mv["p"], errors="coerce")
            mde = pd.to_numeric(mv["mde_mm"], errors="coerce")
            pe = pd.to_numeric(mv["p_equivalence"], errors="coerce")
            base["min_p"] = float(p.min()) if p.notna().any() else math.nan
            base["min_mde_mm"] = float(mde.min()) if mde.notna().any() else math.nan
            base["max_p_equivalence"] = float(pe.max()) if len(pe) and pe.notna().all() else math.nan
            if len(kills):
                first = kills.iloc[0]
                effect = {} if first["kill"] != MutantOutcome.KILLED.value else dict(
                    direction=first["direction"], median_diff_mm=float(first["median_diff_mm"]),
                    ratio=float(first["ratio"]))
                rows.append(base | dict(outcome=first["kill"], killing_case=int(first["case"])) | effect)
            elif len(mv) < n:
                rows.append(base | dict(outcome=INCOMPLETE, killing_case=0,
                                        note=f"{len(mv)} of {n} cases run"))
            elif (mv["verdict"] == "cannot_judge").all():
                rows.append(base | dict(outcome="cannot_judge", killing_case=0,
                                        note="; ".join(sorted(set(mv["reason"].astype(str))))))
            elif exact:
                rows.append(base | dict(outcome=MutantOutcome.SURVIVED.value, killing_case=0, survival=SURVIVED_EXACT,
                                        median_diff_mm=0.0,
                                        note=f"map error identical to the baseline's on all {n} cases (deterministic "
                                             f"SLAM, judged exactly)"))
            elif observed_equivalent:
                rows.append(base | dict(outcome=OBSERVED_EQUIVALENT, killing_case=0,
                                        note="maps bit-identical to the baseline's in every paired run"))
            else:
                equivalent = bool(base["max_p_equivalence"] <= alpha)
                margin = pd.to_numeric(mv["margin_mm"], errors="coerce")
                note = (f"equivalent within +-{margin.min():.0f}-{margin.max():.0f} mm on every case (TOST, "
                        f"p <= {base['max_p_equivalence']:.2g})" if equivalent else
                        "no difference shown; " + (f"smallest detectable shift {base['min_mde_mm']:.0f} mm ({POWER_TEXT} power)"
                                                    if math.isfinite(base["min_mde_mm"]) else
                                                    "no case's pairs could detect any shift"))
                rows.append(base | dict(outcome=MutantOutcome.SURVIVED.value, killing_case=0,
                                        survival=SURVIVED_EQUIVALENT if equivalent else SURVIVED_INCONCLUSIVE,
                                        note=note))
    for mid, cls in sel["screened"].items():
        for (run, suite), n in ncases.items():
            rows.append(dict(mutant=mid, unit=sel["unit"].get(mid, ""), operator=sel["operator"].get(mid, ""),
                             run=run, suite=suite, outcome=cls, survival="",
                             represented_by=sel["represented_by"].get(mid, ""), killing_case=0, direction="",
                             median_diff_mm=math.nan, ratio=math.nan, n_cases_run=0, n_cases=n, min_p=math.nan,
                             max_p_equivalence=math.nan, min_mde_mm=math.nan, reps_used="", n_stopped=0,
                             note="not run (screened out)"))
    return pd.DataFrame(rows, columns=OUTCOME_COLUMNS)


INCOMPLETE = "incomplete"
#: A live mutant whose maps were bit-identical to the baseline's in every paired run: equivalent as
#: observed on these cases; it leaves the score's denominator and is listed apart.
OBSERVED_EQUIVALENT = "equivalent_observed"
#: How a survivor survived: shown equivalent within the margin on every case (TOST), or not.
SURVIVED_EQUIVALENT = "equivalent"
SURVIVED_INCONCLUSIVE = "inconclusive"
#: A survivor of an exact (deterministic) campaign: its map error equals the baseline's on every case.
SURVIVED_EXACT = "exact"
#: ``kill`` of a campaign on a target judged exactly (repetitions = 1: a deterministic SLAM).
EXACT_KILL = "exact"
KILL_CLASSES = (MutantOutcome.KILLED.value, MutantOutcome.CRASH.value, MutantOutcome.TIMEOUT.value)


def adaptive_savings(results: pd.DataFrame, experiment: dict, stops) -> dict | None:
    """What adaptive repetitions saved (None for a fixed-K campaign): the design, the pairs
    stopped early, the executions stored and those all ``K`` repetitions of the same (case,
    variant) pairs would have needed (the cases that ran: early stopping across cases is apart)."""
    design = experiment.get("adaptive") if isinstance(experiment, dict) else None
    if not design:
        return None
    k = int(design["stages"][-1])
    fixed = int(results.groupby(["run", "suite", "case", "variant"]).ngroups) * k
    reasons: dict = {}
    for e in stops or ():
        reasons[str(e["reason"])] = reasons.get(str(e["reason"]), 0) + 1
    return dict(stages=list(design["stages"]), futility=design["futility"], n_stops=len(stops or ()),
                stop_reasons=reasons, executions=len(results), executions_fixed_k=fixed,
                executions_saved=fixed - len(results))


def mutation_scores(outcomes: pd.DataFrame, *, alpha: float = DEFAULT_ALPHA, trivial=()) -> pd.DataFrame:
    """Mutation score per suite kind, per (suite kind, operator) and per (suite kind, unit).

    Score = killed / (killed + survived + incomplete) over the (mutant, run) rows that ran
    (``crash`` and ``timeout`` count as killed), with a Clopper-Pearson ``1 - alpha`` interval.
    An ``incomplete`` mutant (not killed by the cases run so far of an interrupted campaign)
    counts as not killed, so the score of an interrupted campaign is a lower bound.  Survivors
    split into ``equivalent`` (TOST on every case) and ``inconclusive``; mutants observed
    equivalent (bit-identical maps) leave the denominator and are counted in
    ``equivalent_observed``.

    ``trivial`` (the mutants screening declared trivially killed: they fail on every probe) adds
    the *informative* score per suite kind (``by = "informative"``): the same over the mutants
    not in ``trivial``.
    """
    judged = outcomes[outcomes["outcome"].isin((*KILL_CLASSES, MutantOutcome.SURVIVED.value, INCOMPLETE))]
    observed = outcomes[outcomes["outcome"] == OBSERVED_EQUIVALENT]
    rows = []
    trivial = set(trivial)
    for by in (None, "operator", "unit", *(["informative"] if trivial else [])):
        informative = by == "informative"
        keys = ["suite"] + ([by] if by and not informative else [])
        frame = judged[~judged["mutant"].isin(trivial)] if informative else judged
        n_observed = observed.groupby(keys).size().to_dict() if len(observed) else {}
        for key, g in frame.groupby(keys, sort=True):
            key = key if isinstance(key, tuple) else (key,)
            k = int(g["outcome"].isin(KILL_CLASSES).sum())
            n = len(g)
            lo, hi = clopper_pearson(k, n, alpha=alpha)
            rows.append(dict(suite=key[0], by=by or "all", group=key[1] if by and not informative else "all",
                             killed=k, judged=n,
                             crash=int((g["outcome"] == "crash").sum()), timeout=int((g["outcome"] == "timeout").sum()),
                             incomplete=int((g["outcome"] == INCOMPLETE).sum()),
                             survived_equivalent=int((g["survival"] == SURVIVED_EQUIVALENT).sum()),
                             survived_inconclusive=int((g["survival"] == SURVIVED_INCONCLUSIVE).sum()),
                             equivalent_observed=int(n_observed.get(key if by and not informative else key[0], 0)),
                             score=k / n, ci_low=lo, ci_high=hi))
    return pd.DataFrame(rows, columns=["suite", "by", "group", "killed", "judged", "crash", "timeout", "incomplete",
                                       "survived_equivalent", "survived_inconclusive", "equivalent_observed",
                                       "score", "ci_low", "ci_high"])


def compare_suites(outcomes: pd.DataFrame, suites, *, alpha: float = DEFAULT_ALPHA) -> pd.DataFrame:
    """Every pair of suite kinds compared on the (mutant, run) pairs both judged.

    Columns: the exact McNemar test (statsmodels ``mcnemar(exact=True)``: ``p``, Holm-adjusted over the
    pairs ``p_holm``) on the counts ``both, a_only, b_only, neither``; the score difference ``diff``
    (a - b: ``(a_only - b_only) / n``) with a ``1 - alpha`` interval ``ci_low, ci_high``; and
    ``equivalent_within``, the smallest margin d for which two one-sided tests at ``alpha`` show the
    difference within +-d (the largest magnitude of the ``1 - 2 alpha`` interval).

    The interval is the difference of the two discordant shares, each within its exact
    Clopper-Pearson interval at half the miss rate (Bonferroni): conservative (a test checks its
    coverage by simulation) and never of zero width.  The mutants are the independently drawn
    units, so the interval needs one pair per mutant; with several runs of a mutant it is NaN (not
    judged).
    """
    judged = outcomes[outcomes["outcome"].isin((*KILL_CLASSES, MutantOutcome.SURVIVED.value))]
    kill = judged.assign(k=judged["outcome"].isin(KILL_CLASSES)).pivot_table(
        index=["mutant", "run"], columns="suite", values="k", aggfunc="first")
    rows = []
    for a, b in itertools.combinations([s for s in suites if s in kill.columns], 2):
        both = kill[[a, b]].dropna().astype(bool)
        ka, kb = both[a].to_numpy(), both[b].to_numpy()
        t = np.array([[np.sum(ka & kb), np.sum(ka & ~kb)], [np.sum(~ka & kb), np.sum(~ka & ~kb)]])
        n = len(both)
        p = float(mcnemar(t, exact=True).pvalue) if n else math.nan
        lo = hi = lo2 = hi2 = math.nan
        if n and both.index.get_level_values("mutant").is_unique:  # one pair per mutant
            lo, hi = _difference_interval(int(t[0, 1]), int(t[1, 0]), n, level=1 - alpha)
            lo2, hi2 = _difference_interval(int(t[0, 1]), int(t[1, 0]), n, level=1 - 2 * alpha)
        rows.append(dict(suite_a=a, suite_b=b, n=n, both=int(t[0, 0]), a_only=int(t[0, 1]), b_only=int(t[1, 0]),
                         neither=int(t[1, 1]), p=p, diff=(int(t[0, 1]) - int(t[1, 0])) / n if n else math.nan,
                         ci_low=lo, ci_high=hi, equivalent_within=max(abs(lo2), abs(hi2))))
    df = pd.DataFrame(rows, columns=["suite_a", "suite_b", "n", "both", "a_only", "b_only", "neither", "p", "diff",
                                     "ci_low", "ci_high", "equivalent_within"])
    ok = df["p"].notna().to_numpy()
    df.insert(df.columns.get_loc("p") + 1, "p_holm", math.nan)
    if ok.any():
        df.loc[ok, "p_holm"] = holm(df.loc[ok, "p"].to_numpy())[1]
    return df


def _difference_interval(a_only: int, b_only: int, n: int, *, level: float) -> tuple[float, float]:
    """``level`` interval of ``(a_only - b_only) / n``: each share within its exact interval at level
    ``1 - (1 - level) / 2``."""
    (a_lo, a_hi), (b_lo, b_hi) = (clopper_pearson(k, n, alpha=(1 - level) / 2) for k in (a_only, b_only))
    return a_lo - b_hi, a_hi - b_lo


def _reused_outcomes(reused: dict, *, alpha: float) -> pd.DataFrame:
    """The outcome rows of reused mutants, from the campaigns they ran in, marked in ``note``."""
    parts = []
    for prev in sorted(set(reused.values())):
        ids = [i for i, d in reused.items() if d == prev]
        try:
            old = analyse_mutation(prev, alpha=alpha).outcomes
        except (ResultsError, OSError) as exc:
            raise ResultsError(f"the verdicts this campaign reuses are gone: {prev}: {exc}") from exc
        rows = old[old["mutant"].isin(ids)].copy()
        rows["note"] = [f"verdict reused from {prev} (function unchanged); {n}".rstrip("; ") for n in rows["note"]]
        parts.append(rows)
    return pd.concat(parts, ignore_index=True) if parts else pd.DataFrame(columns=OUTCOME_COLUMNS)


def analyse_mutation(out: str | Path, *, alpha: float = DEFAULT_ALPHA) -> MutationAnalysis:
    """The :class:`MutationAnalysis` of the campaign saved in ``out`` (runs nothing)."""
    out = Path(out)
    try:
        sel = json.loads((out / MUTATION_FILE).read_text())
    except OSError as exc:
        raise ResultsError(f"{out}: no {MUTATION_FILE}: not a mutation campaign ({exc})") from exc
    meta = load_metadata(out)
    exp = meta.get("experiment", {})
    results = load_results(out)
    metric = judged_metric(meta)
    spec = exp.get("suites", {}) if isinstance(exp, dict) else {}
    pairs = spec.items() if isinstance(spec, dict) else (tuple(p) for p in spec)  # stored as [[kind, n], ...]
    stops = meta.get(STOPS_KEY) or []
    outcomes = mutant_outcomes(results, sel, metric, {k: v for k, v in pairs if isinstance(v, int)}, stops=stops)
    reused = dict(sel.get("reused") or {})
    if reused:
        outcomes = pd.concat([outcomes, _reused_outcomes(reused, alpha=alpha)], ignore_index=True)
    suites = list(dict.fromkeys(results["suite"]))
    info = dict(alpha=sel["alpha"], direction=stored_direction(sel), n_mutants_run=len(sel["run"]), n_screened=len(sel["screened"]),
                n_jobs=len(results), runtime_s_sum=float(results["runtime_s"].sum()),
                status_counts={k: int(v) for k, v in results["status"].value_counts().items()},
                repetitions=int(results["rep"].max()) + 1, suites=suites,
                outcome_counts={f"{s}:{o}": int(n) for (s, o), n in
                                outcomes.groupby(["suite", "outcome"]).size().items()},
                adaptive=adaptive_savings(results, exp, stops))
    if "target" in sel:  # a campaign on user code
        info |= dict(target=sel["target"], kill=sel.get("kill"), case_alpha=sel.get("case_alpha"),
                     trivial=list(sel.get("trivial") or []), n_trivial=len(sel.get("trivial") or []),
                     reused=reused, n_reused=len(reused))
    return MutationAnalysis(outcomes=outcomes,
                            scores=mutation_scores(outcomes, alpha=alpha, trivial=sel.get("trivial") or ()),
                            mcnemar=compare_suites(outcomes, suites, alpha=alpha), meta=info)
