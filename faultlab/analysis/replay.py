"""Adaptive repetitions replayed on a fixed-K store: what stopping early would have saved and changed.

Repetition ``r`` of a case runs with the same SLAM seed whatever the design
(:func:`faultlab.seeds.slam_seed` keys it by run, suite, case and repetition only), so the rows
an adaptive campaign (``[adaptive]``, :mod:`faultlab.runner.staging`) stores are exactly the
fixed-K campaign's rows of the repetitions it ran.  Its decisions depend on those rows alone, so
:func:`replay_adaptive` reaches them from a complete fixed-K store without running a SLAM: stage
by stage it calls the runner's own look (:func:`faultlab.runner.staging.look_before_stage`, the rule of
:func:`faultlab.inference.sequential.interim_look`), stop records
(:func:`~faultlab.runner.staging.record_stops`) and job selection
(:func:`~faultlab.runner.staging.stage_jobs`) on the rows the adaptive campaign would hold at
that look.

It then judges the truncated rows and the full rows with the campaign's analysis
(:meth:`faultlab.analysis.Analysis.from_frame`: the stored detection rule, its test, sidedness,
alpha and Holm family) and compares the per-case verdicts.  A verdict can change only in these
ways, and each changed row says which:

* the pair stopped for futility and the remaining repetitions would have brought the fixed-K
  test to rejection (a power loss of the futility bound; :mod:`faultlab.inference.sequential`);
* the pair stopped and a later repetition holds a failure: of the baseline (the fixed-K verdict
  is ``cannot_judge``) or of the faulty variant alone (``crash_detected``);
* the pair ran all ``K`` repetitions but its Holm-adjusted p value moved, because other cases of
  its Holm family stopped early with other p values, or left the family: a pair stopped with
  fewer usable pairs than the exact test needs to reach alpha (:func:`faultlab.inference.exact.min_pairs`)
  is ``cannot_judge`` (``too_few_pairs``), and a smaller family makes Holm's steps less strict
  for the cases left.  A design whose first stage is at least ``min_pairs`` avoids both the
  ``cannot_judge`` verdicts and this shrinking family (a note says so).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Mapping

import numpy as np
import pandas as pd

from faultlab.analysis.bundle import TableBundle
from faultlab.stats.metadata import count_expected_jobs, judged_metric, read_rule
from faultlab.analysis.result import Analysis
from faultlab.analysis.schema import ALL_VARIANTS, TableSchema
from faultlab.errors import ConfigError, ResultsError
from faultlab.runner.jobs import JobKey
from faultlab.inference.sequential import StagedDesign
from faultlab.runner.staging import STOPS_KEY, look_before_stage, record_stops, stage_jobs
from faultlab.runner.store import SKIPPED_VARIANTS_KEY, load_metadata, load_results
from faultlab.stats.detection import DetectionRule
from faultlab.inference.exact import alternative_of, min_pairs
from faultlab.stats.verdict import TOO_FEW_PAIRS, Verdict
from faultlab.vocabulary import BASELINE, JobStatus

__all__ = ["AdaptiveReplay", "REPLAY_TABLES", "REPLAY_SUMMARY", "REPLAY_PAIRS", "REPLAY_VERDICTS", "COMPLETED",
           "replay_adaptive", "replay_rows"]

#: ``reason`` of a pair that ran every stage; a case's baseline runs as far as its variants.
COMPLETED = "completed"
_FOLLOWS = "follows_variants"

REPLAY_SUMMARY = TableSchema.define(
    "summary", "One row per variant and one for all: (case, variant) pairs, those that stopped before K "
               "(a baseline: when every variant of its case did), SLAM executions of the fixed and the adaptive "
               "design, verdicts changed.",
    ("variant", "n_pairs", "n_stopped", "executions_fixed", "executions_adaptive", "saved_pct", "n_changed"),
    n_stopped="int", executions_fixed="int", executions_adaptive="int", saved_pct="float", n_changed="int",
    n_pairs="int")
REPLAY_PAIRS = TableSchema.define(
    "pairs", "One row per (run, suite, case, variant): repetitions used, stages run and why it stopped.",
    ("run", "suite", "case", "variant", "reps_fixed", "reps_adaptive", "stages_run", "stop"),
    reps_fixed="int", reps_adaptive="int", stages_run="int", stop="str")
REPLAY_VERDICTS = TableSchema.define(
    "verdicts", "One row per (suite, run, case, fault): the per-case verdict of the fixed and the adaptive "
                "design, and why it changed.",
    ("suite", "run", "case", "fault", "family", "stop", "reps_fixed", "reps_adaptive", "verdict_fixed",
     "verdict_adaptive", "reason_fixed", "reason_adaptive", "p_fixed", "p_adaptive", "p_holm_fixed",
     "p_holm_adaptive", "changed", "why"),
    stop="str", reps_fixed="int", reps_adaptive="int", verdict_fixed="str", verdict_adaptive="str",
    reason_fixed="str", reason_adaptive="str", p_fixed="float",
    p_adaptive="float", p_holm_fixed="float", p_holm_adaptive="float", changed="bool", why="str")
#: Tables of an :class:`AdaptiveReplay`, saved as ``<name>.csv``.
REPLAY_TABLES = (REPLAY_SUMMARY.name, REPLAY_PAIRS.name, REPLAY_VERDICTS.name)


@dataclass(frozen=True, eq=False)
class AdaptiveReplay(TableBundle):
    """An adaptive design replayed on a fixed-K store (frozen; save/load as CSV + JSON).

    Attributes
    ----------
    summary : DataFrame
        :data:`REPLAY_SUMMARY`: per variant (and ``"(all)"``) the executions of both designs and
        the share saved, the pairs stopped and the verdicts changed.
    pairs : DataFrame
        :data:`REPLAY_PAIRS`: per (run, suite, case, variant) the repetitions used, the stages run
        and the stop reason (a :class:`~faultlab.inference.sequential.Look` value, ``"completed"``,
        or ``"follows_variants"`` for a baseline).
    verdicts : DataFrame
        :data:`REPLAY_VERDICTS`: per (case, fault) both verdicts, p values, Holm-adjusted p values,
        ``changed`` and ``why``.
    meta : dict
        ``store``, ``design`` (the ``[adaptive]`` table), ``K``, ``metric``, ``rule`` (the
        detection rule stated), ``executions_fixed``, ``executions_adaptive``, ``saved_pct``,
        ``stops`` (as an adaptive campaign records them under ``adaptive_stops``), ``notes``.
    """

    summary: pd.DataFrame
    pairs: pd.DataFrame
    verdicts: pd.DataFrame
    meta: dict = field(default_factory=dict)

    TABLES = REPLAY_TABLES
    SCHEMAS = (REPLAY_SUMMARY, REPLAY_PAIRS, REPLAY_VERDICTS)
    META_FILE = "replay_meta.json"
    WHAT = "adaptive replay"

    @property
    def executions_fixed(self) -> int:
        return int(self.meta["executions_fixed"])

    @property
    def executions_adaptive(self) -> int:
        return int(self.meta["executions_adaptive"])

    @property
    def saved_pct(self) -> float:
        return float(self.meta["saved_pct"])

    @property
    def stops(self) -> list[dict]:
        return list(self.meta["stops"])

    @property
    def changed(self) -> pd.DataFrame:
        """The rows of :attr:`verdicts` whose verdict changed."""
        return self.verdicts[self.verdicts["changed"].to_numpy(bool)].reset_index(drop=True)


def _design(design, metadata: Mapping, *, store) -> StagedDesign:
    if design is None:
        stored = (metadata.get("experiment") or {}).get("adaptive")
        if not stored:
            raise ConfigError(f"{store}: its experiment has no [adaptive] table: give the design to replay "
                              f"(stages, e.g. 5,10; level, alternative, futility)")
        design = stored
    if isinstance(design, Mapping):
        design = StagedDesign.from_mapping(design, where="adaptive design")
    if not isinstance(design, StagedDesign):
        raise ConfigError(f"adaptive design: expected a StagedDesign or an [adaptive] mapping, got "
                          f"{type(design).__name__}")
    return design


def _check_complete(results: pd.DataFrame, metadata: Mapping, *, store, k: int) -> None:
    """Every (case, variant) of the store holds repetitions 0 .. K-1, and no pair stopped early."""
    stops = metadata.get(STOPS_KEY) or []
    if stops:
        raise ResultsError(f"{store}: an adaptive campaign ({len(stops)} (case, variant) pair(s) stopped early): "
                           f"a replay needs a fixed-K store holding every repetition")
    exp = metadata.get("experiment") or {}
    skipped = {s["fault"] for s in metadata.get(SKIPPED_VARIANTS_KEY) or ()}
    variants = [v for v in exp.get("variants") or sorted(set(results["variant"])) if v not in skipped]
    cases = results[["run", "suite", "case"]].drop_duplicates().itertuples(index=False, name=None)
    have = set(results[["run", "suite", "case", "variant", "rep"]].itertuples(index=False, name=None))
    want = [(int(r), s, int(c), v, rep) for r, s, c in cases for v in variants for rep in range(k)]
    missing = [w for w in want if w not in have]
    if missing:
        first = JobKey(*missing[0])
        raise ResultsError(f"{store}: {len(missing)} of the {len(want)} jobs of its cases are missing ({first} "
                           f"first; K = {k} repetitions of every case and variant); complete the campaign (rerun "
                           f"`faultlab run` on it) before replaying an adaptive design")
    expected = count_expected_jobs(metadata, adaptive=False)
    if expected is not None and len(want) < expected:
        raise ResultsError(f"{store}: {len(want)} of the {expected} jobs of its experiment belong to cases with "
                           f"results, the other cases have none; complete the campaign (rerun `faultlab run` on "
                           f"it) before replaying an adaptive design")


@dataclass(frozen=True)
class _StoredJob:
    """A stored row as :func:`~faultlab.runner.staging.stage_jobs` sees a job: its key."""

    key: JobKey


def replay_rows(results: pd.DataFrame, *, design: StagedDesign, metric: str) -> tuple[pd.DataFrame, list[dict]]:
    """The rows an adaptive campaign with ``design`` would store, and its stop records.

    Parameters
    ----------
    results : DataFrame
        Every row of a complete fixed-K campaign (:func:`faultlab.runner.load_results`),
        ``K = design.total``.
    design : StagedDesign
    metric : {"rms", "emd"}
        The metric the looks judge (the experiment's ``metric``, as the runner uses).

    Returns
    -------
    (rows, stops) : (DataFrame, list of dict)
        The subset of ``results`` (same order and columns) and the stops as the runner records
        them under :data:`~faultlab.runner.staging.STOPS_KEY`.
    """
    keys = [JobKey(int(r), s, int(c), v, int(rep)) for r, s, c, v, rep in
            results[["run", "suite", "case", "variant", "rep"]].itertuples(index=False, name=None)]
    row_of = {k: i for i, k in enumerate(keys)}
    specs = [_StoredJob(k) for k in keys]
    kept = np.zeros(len(results), dtype=bool)
    running, stops = None, []
    for stage in range(len(design.stages)):
        if stage > 0:
            held = results[kept]  # what the adaptive store holds at this look
            decisions, running = look_before_stage(held, design=design, stage=stage, metric=metric,
                                                   running=running)
            stops = record_stops(decisions, design=design, stage=stage, previous=stops)
        for spec in stage_jobs(specs, design=design, stage=stage, running=running):
            kept[row_of[spec.key]] = True
    return results[kept].reset_index(drop=True), stops


def _pairs(results: pd.DataFrame, rows: pd.DataFrame, stops: list[dict], design: StagedDesign) -> pd.DataFrame:
    key = ["run", "suite", "case", "variant"]
    fixed = results.groupby(key, sort=True).size().rename("reps_fixed")
    used = rows.groupby(key, sort=True).size().rename("reps_adaptive")
    out = pd.concat([fixed, used], axis=1).fillna(0).astype(int).reset_index()
    why = {(e["run"], e["suite"], e["case"], e["variant"]): e["reason"] for e in stops}
    reason = [why.get((int(r), s, int(c), v), _FOLLOWS if v == BASELINE else COMPLETED)
              for r, s, c, v in out[key].itertuples(index=False, name=None)]
    stages = np.asarray(design.stages)
    out["stages_run"] = np.searchsorted(stages, out["reps_adaptive"].to_numpy(), side="left") + 1
    out["stop"] = reason
    return REPLAY_PAIRS.conform(out)


def _first_failure(results: pd.DataFrame, *, run, suite, case, variant, after: int) -> int | None:
    sel = results[(results["run"] == run) & (results["suite"] == suite) & (results["case"] == case)
                  & (results["variant"] == variant) & (results["rep"] >= after)
                  & (results["status"].astype(str) != JobStatus.OK.value)]
    return None if sel.empty else int(sel["rep"].min())


def _why(row, results: pd.DataFrame, *, k: int, alpha: float, needed: int | None, alternative: str) -> str:
    """Why the verdict of one (case, fault) differs between the designs (module docstring)."""
    if not row.changed:
        return ""
    ident = dict(run=row.run, suite=row.suite, case=row.case)

    def fmt(x: float) -> str:
        return "-" if np.isnan(x) else f"{x:.3g}"

    moved = (f"p {fmt(row.p_fixed)} with {k} repetitions, {fmt(row.p_adaptive)} with {row.reps_adaptive}; "
             f"Holm-adjusted {fmt(row.p_holm_fixed)} -> {fmt(row.p_holm_adaptive)} (alpha {alpha:g})")
    if row.reps_adaptive == k:
        return (f"ran all {k} repetitions; its Holm-adjusted p moved {fmt(row.p_holm_fixed)} -> "
                f"{fmt(row.p_holm_adaptive)} (alpha {alpha:g}) because other cases of the family "
                f"'{row.family}' stopped early: their p values changed, or they left the family "
                f"({TOO_FEW_PAIRS})")
    stopped = f"stopped after {row.reps_adaptive} of {k} repetitions ({row.stop})"
    if row.reason_adaptive == TOO_FEW_PAIRS and needed is not None:
        return (f"{stopped}; the {alternative} exact test needs {needed} usable pairs to reach alpha = {alpha:g}, "
                f"so the truncated rows cannot judge the case ({TOO_FEW_PAIRS}); with all {k}: {row.verdict_fixed}, "
                f"p {fmt(row.p_fixed)}, Holm-adjusted {fmt(row.p_holm_fixed)}")
    if row.verdict_fixed == Verdict.CANNOT_JUDGE.value:
        rep = _first_failure(results, variant=BASELINE, after=row.reps_adaptive, **ident)
        return f"{stopped}; the baseline failed in repetition {rep}, which the adaptive design did not run"
    if row.verdict_fixed == Verdict.CRASH_DETECTED.value:
        rep = _first_failure(results, variant=row.fault, after=row.reps_adaptive, **ident)
        return f"{stopped}; the faulty variant failed in repetition {rep}, which the adaptive design did not run"
    if row.verdict_fixed == Verdict.DETECTED.value:
        return (f"{stopped}; the remaining repetitions would have brought the fixed-K test to rejection "
                f"(a power loss of the futility bound): {moved}")
    return f"{stopped}: {moved}"


def _verdicts(full: Analysis, adaptive: Analysis, pairs: pd.DataFrame, results: pd.DataFrame, *,
              k: int, rule: DetectionRule) -> pd.DataFrame:
    key = ["suite", "run", "case", "fault"]
    cols = key + ["verdict", "reason", "p", "p_holm", "n_reps"]
    merged = full.case_verdicts[cols + ["family"]].merge(adaptive.case_verdicts[cols], on=key, how="outer",
                                                        suffixes=("_fixed", "_adaptive"), validate="1:1")
    stop = pairs.rename(columns={"variant": "fault"})[["run", "suite", "case", "fault", "stop"]]
    merged = merged.merge(stop, on=["run", "suite", "case", "fault"], how="left", validate="1:1")
    merged = merged.rename(columns={"n_reps_fixed": "reps_fixed", "n_reps_adaptive": "reps_adaptive"})
    merged["changed"] = merged["verdict_fixed"].astype(str) != merged["verdict_adaptive"].astype(str)
    merged = REPLAY_VERDICTS.conform(merged.assign(why=""))
    alternative = alternative_of(rule.direction)
    needed = min_pairs(rule.alpha, alternative=alternative) if rule.statistical else None
    merged["why"] = [_why(r, results, k=k, alpha=rule.alpha, needed=needed, alternative=alternative)
                     for r in merged.itertuples(index=False)]
    return REPLAY_VERDICTS.conform(merged)


def _summary(pairs: pd.DataFrame, verdicts: pd.DataFrame) -> pd.DataFrame:
    rows = []
    for variant, g in [*pairs.groupby("variant", sort=False), (ALL_VARIANTS, pairs)]:
        v = verdicts if variant == ALL_VARIANTS else verdicts[verdicts["fault"] == variant]
        fixed, used = int(g["reps_fixed"].sum()), int(g["reps_adaptive"].sum())
        rows.append({"variant": variant, "n_pairs": int(len(g)),
                     "n_stopped": int((g["reps_adaptive"] < g["reps_fixed"]).sum()),
                     "executions_fixed": fixed, "executions_adaptive": used,
                     "saved_pct": 100.0 * (1 - used / fixed) if fixed else np.nan,
                     "n_changed": int(v["changed"].sum())})
    return REPLAY_SUMMARY.conform(pd.DataFrame(rows))


def replay_adaptive(store: str | Path, design: StagedDesign | Mapping | None = None, *,
                    metric: str | None = None) -> AdaptiveReplay:
    """Replay adaptive repetitions on a complete fixed-K store (module docstring).

    Parameters
    ----------
    store : path
        Results directory of a fixed-K campaign (or its ``results.sqlite``).
    design : StagedDesign or mapping, optional
        The ``[adaptive]`` design (stages ending at the store's ``K``, level, alternative,
        futility); default the stored experiment's own ``[adaptive]`` table.
    metric : {"rms", "emd"}, optional
        The metric of the looks and the verdicts; default the experiment's.

    Returns
    -------
    AdaptiveReplay

    Raises
    ------
    ConfigError
        No design (none given, none stored), or its last stage is not the store's ``K``.
    ResultsError
        The store is missing, empty, incomplete (a repetition, variant or case without a row) or
        an adaptive campaign whose pairs stopped early.
    """
    metadata = load_metadata(store)
    results = load_results(store)
    if results.empty:
        raise ResultsError(f"the results store at {store} holds no rows yet: nothing to replay")
    k = int((metadata.get("experiment") or {}).get("repetitions") or results["rep"].max() + 1)
    design = _design(design, metadata, store=store)
    if design.total != k:
        raise ConfigError(f"adaptive design: the last stage ({design.total}) must equal the store's K = {k} "
                          f"repetitions, got stages {list(design.stages)}")
    _check_complete(results, metadata, store=store, k=k)
    metric = judged_metric(metadata, metric)
    rule, _ = read_rule(metadata)
    rows, stops = replay_rows(results, design=design, metric=metric)
    replayed_meta = dict(metadata)
    replayed_meta["experiment"] = dict(metadata.get("experiment") or {}) | {"adaptive": design.to_dict()}
    replayed_meta[STOPS_KEY] = stops
    full = Analysis.from_frame(results, metadata, paper=False, metric=metric)
    adaptive = Analysis.from_frame(rows, replayed_meta, paper=False, metric=metric)
    pairs = _pairs(results, rows, stops, design)
    verdicts = _verdicts(full, adaptive, pairs, results, k=k, rule=rule)
    notes = []
    if rule.statistical and alternative_of(rule.direction) != design.alternative:
        notes.append(f"the design's interim test is {design.alternative} while the store's rule tests "
                     f"{alternative_of(rule.direction)}: the looks and the verdicts test different hypotheses")
    if rule.statistical and design.level < rule.alpha:
        notes.append(f"the design's per-case level {design.level:g} is below the rule's alpha {rule.alpha:g}: "
                     f"curtailment may stop a case a later Holm step would have rejected")
    if rule.statistical and design.stages[0] < min_pairs(rule.alpha, alternative=alternative_of(rule.direction)):
        notes.append(f"a pair stopped after {design.stages[0]} repetitions cannot be judged by the store's rule: the "
                     f"{alternative_of(rule.direction)} exact test needs "
                     f"{min_pairs(rule.alpha, alternative=alternative_of(rule.direction))} usable pairs to reach "
                     f"alpha = {rule.alpha:g}, so its verdict is cannot_judge ({TOO_FEW_PAIRS}) where the fixed "
                     f"design says not_detected; a first stage of that many repetitions keeps such verdicts")
    fixed, used = len(results), len(rows)
    meta = {"store": str(store), "design": design.to_dict(), "K": k, "metric": metric, "rule": rule.describe(),
            "alpha": rule.alpha, "executions_fixed": fixed, "executions_adaptive": used,
            "saved_pct": 100.0 * (1 - used / fixed), "stops": stops, "n_changed": int(verdicts["changed"].sum()),
            "notes": notes}
    return AdaptiveReplay(summary=_summary(pairs, verdicts), pairs=pairs, verdicts=verdicts, meta=meta)
