"""The test-design strategies study's analysis: the kill matrix of its pools and suites drawn from them.

The study's campaign (its file, its pools, its sessions) is :mod:`faultlab.campaigns.study`; the
``[study]`` settings are :class:`faultlab.stats.killmatrix.StudySpec`.

The store is reduced to the kill matrix (:func:`faultlab.stats.killmatrix.kill_matrix`: per pool
case and variant, the exact p value, the crash flag and the paper rule's flag), and every suite
size is evaluated by drawing suites from each strategy's pool
(:func:`faultlab.stats.killmatrix.evaluate_strategies`); see that module for the suite rule, the
confidence intervals and the power statement.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from faultlab.analysis.bundle import TableBundle
from faultlab.stats.metadata import count_expected_jobs, judged_metric, read_rule
from faultlab.errors import ResultsError
from faultlab.mutation.variants import is_mutant_variant, mutant_id_of
from faultlab.runner.store import STUDY_FILE, load_metadata, load_results, load_sessions, settle_sessions
from faultlab.stats.cases import detectable_difference
from faultlab.stats.controls import CONTROL_COLUMNS, CONTROL_SUMMARY_COLUMNS, aa_controls, aa_summary
from faultlab.stats.declaration import (DECLARATION_KEY, DECLARED_COLUMNS, Declaration, declaration_from,
                                        declared_table, label_rows)
from faultlab.stats.killmatrix import (DETECTION_COMPARISON_COLUMNS, MEAN_DETECTION_COLUMNS, WHOLE_COLUMNS,
                                       KillMatrix, StudySpec, compare_detection, compare_mean_detection,
                                       case_scores, compare_scores, detection_table,
                                       evaluate_suites, kill_matrix, score_table, study_spec, whole_suite_table,
                                       whole_suites)
from faultlab.inference.exact import alternative_of, min_pairs
from faultlab.vocabulary import BASELINE, MDD_COLUMN, PAPER_FAULTS

__all__ = ["STUDY_TABLES", "StudyAnalysis", "analyse_study", "reanalyse_saved_study"]

#: Tables of a :class:`StudyAnalysis`, saved as ``<name>.csv``.
STUDY_TABLES = ("kill_matrix", "detection", "scores", "comparisons", "power", "whole", "detection_comparisons",
                "detection_means", "declared", "controls", "controls_summary")
_META_FILE = "study_meta.json"


@dataclass(frozen=True, eq=False)
class StudyAnalysis(TableBundle):
    """Everything the study's report shows, computed once (frozen; save/load as CSV + JSON).

    Attributes
    ----------
    kill_matrix : DataFrame
        :meth:`KillMatrix.to_frame` of the pools.
    detection : DataFrame
        :func:`~faultlab.stats.killmatrix.detection_table` for every variant (``kind`` = fault or mutant).
    scores : DataFrame
        :func:`~faultlab.stats.killmatrix.score_table`.
    comparisons : DataFrame
        :func:`~faultlab.stats.killmatrix.compare_scores`.
    power : DataFrame
        Per strategy: pool size, suites drawn, bootstrap replicates, the Monte Carlo error bound
        of a drawn-suite rate and the smallest difference in a size-1 detection probability (a
        share of pool cases) between this and every other pool that a two-sample test detects
        with the default power at 0.05, at rates 0.5 and 0.1 (columns ``<MDD_COLUMN>_at_<rate>``).
    whole : DataFrame
        :func:`~faultlab.stats.killmatrix.whole_suite_table` of the strategies in ``[study] whole``:
        each evaluation run's generated suite (e.g. a whole pairwise covering array) judged whole.
    detection_comparisons : DataFrame
        :func:`~faultlab.stats.killmatrix.compare_detection` for every fault: the strategies' single-case
        detection probabilities compared pair by pair, with intervals, Holm and equivalence margins.
    detection_means : DataFrame
        :func:`~faultlab.stats.killmatrix.compare_mean_detection` over the faults: the single-case
        detection probability averaged over the faults, compared pair by pair with the case and with
        the evaluation run as the unit.
    declared : DataFrame
        :func:`~faultlab.stats.declaration.declared_table`: the study's declared analyses (empty
        without a declaration); ``detection_means``, ``detection_comparisons`` and ``comparisons``
        carry a column ``analysis`` saying which of their rows are declared and which exploratory.
    controls : DataFrame
        :func:`~faultlab.stats.controls.aa_controls`: every strategy against itself (A/A).
    controls_summary : DataFrame
        :func:`~faultlab.stats.controls.aa_summary`: the A/A false-alarm rates, per comparison and
        per family kept apart.
    meta : dict
        Settings, mutants, run time per session, sampled machine load, SLAM time, job counts.
    """

    kill_matrix: pd.DataFrame
    detection: pd.DataFrame
    scores: pd.DataFrame
    comparisons: pd.DataFrame
    power: pd.DataFrame
    whole: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=list(WHOLE_COLUMNS)))
    detection_comparisons: pd.DataFrame = field(
        default_factory=lambda: pd.DataFrame(columns=list(DETECTION_COMPARISON_COLUMNS)))
    detection_means: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=list(MEAN_DETECTION_COLUMNS)))
    declared: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=list(DECLARED_COLUMNS)))
    controls: pd.DataFrame = field(default_factory=lambda: pd.DataFrame(columns=list(CONTROL_COLUMNS)))
    controls_summary: pd.DataFrame = field(
        default_factory=lambda: pd.DataFrame(columns=list(CONTROL_SUMMARY_COLUMNS)))
    meta: dict = field(default_factory=dict)

    TABLES = STUDY_TABLES
    META_FILE = _META_FILE
    WHAT = "study analysis"


def _power(pool_sizes: dict, spec: StudySpec) -> pd.DataFrame:
    rows = []
    for a, n_a in pool_sizes.items():
        others = [n for b, n in pool_sizes.items() if b != a] or [n_a]
        rows.append({"strategy": a, "pool": n_a, "draws": spec.draws, "bootstrap": spec.bootstrap,
                     "mc_se_max": 0.5 / math.sqrt(spec.draws),
                     **{f"{MDD_COLUMN}_at_{rate}": max(detectable_difference(rate, n_a, n) for n in others)
                        for rate in (0.5, 0.1)}})
    return pd.DataFrame(rows)


def _load_summary(sessions: list) -> dict:
    samples = [s for session in sessions for s in session.get("load", [])]
    if not samples:
        return {}
    one = [s[1] for s in samples]
    return {"samples": len(samples), "load1_mean": sum(one) / len(one), "load1_max": max(one),
            "load1_min": min(one)}


def _of_run(by_id: dict, variants) -> dict:
    """``by_id`` (mutant id -> value) restricted to the mutant variants that ran, keyed by variant."""
    return {v: by_id[mutant_id_of(v)] for v in variants if mutant_id_of(v) in by_id}


def _whole(km: KillMatrix, spec: StudySpec, mutants, *, k: int | None = None,
           alternative: str = "greater") -> tuple[pd.DataFrame, dict]:
    """:func:`whole_suite_table` of ``spec.whole``, leaving out (and listing, strategy -> K needed)
    the strategies whose whole suites are too large for the stored K to reach alpha / n."""
    skipped = {}
    if k is not None:
        for strategy in spec.whole:
            rows = km.rows(strategy)
            n = int(km.cases.iloc[rows].groupby("run").size().max()) if rows.size else 1
            if k < min_pairs(spec.alpha / n, alternative=alternative):
                skipped[strategy] = min_pairs(spec.alpha / n, alternative=alternative)
    judged = whole_suites(km, [w for w in spec.whole if w not in skipped], alpha=spec.alpha,
                          method=spec.multiplicity, timeouts_detect=spec.timeouts_detect, seed=spec.seed)
    return whole_suite_table(judged, mutants=mutants, alpha=spec.alpha), skipped


def _evaluate(km: KillMatrix, spec: StudySpec, *, k: int | None, alternative: str):
    """Drawn suites of every size from every pool, the detection table, the whole suites and the faults'
    strategy comparisons of a kill matrix: ``(evaluation, mutants, detection, whole, whole_not_evaluated,
    detection_comparisons, detection_means)`` (unlabelled: :func:`_analysis` labels them)."""
    mutants = tuple(v for v in km.variants if is_mutant_variant(v))
    ev = evaluate_suites(km, spec.sizes, draws=spec.draws, bootstrap=spec.bootstrap, seed=spec.seed,
                         alpha=spec.alpha, method=spec.multiplicity, mutants=mutants,
                         timeouts_detect=spec.timeouts_detect)
    detection = detection_table(ev, km.variants)
    detection.insert(1, "kind", ["mutant" if is_mutant_variant(v) else "fault" for v in detection["variant"]])
    whole, skipped = _whole(km, spec, mutants, k=k, alternative=alternative)
    faults = [v for v in km.variants if v != BASELINE and v not in mutants]
    return (ev, mutants, detection, whole, skipped, compare_detection(ev, faults, alpha=spec.alpha),
            compare_mean_detection(km, faults, alpha=spec.alpha, timeouts_detect=spec.timeouts_detect))


def _declaration(stored, source: str) -> Declaration | None:
    return None if stored is None else declaration_from(stored, source=source)


def _analysis(km: KillMatrix, spec: StudySpec, ev, mutants, detection, whole, per_fault, means,
              declaration: Declaration | None, meta: dict) -> StudyAnalysis:
    """The :class:`StudyAnalysis` of an evaluated kill matrix: the declared analyses, the A/A controls,
    and every comparison table labelled declared or exploratory."""
    faults = [v for v in km.variants if v != BASELINE and v not in mutants]
    score = case_scores(km, faults, alpha=spec.alpha, timeouts_detect=spec.timeouts_detect) if faults else \
        np.zeros(len(km.cases))
    declared = declared_table(declaration, score=score, strategy=km.cases["strategy"].to_numpy(),
                              run=km.cases["run"].to_numpy())
    controlled, kind = (faults, "fault") if faults else (list(mutants), "mutant")
    controls = aa_controls(km, controlled, alpha=spec.alpha, timeouts_detect=spec.timeouts_detect, kind=kind) \
        if controlled else pd.DataFrame(columns=list(CONTROL_COLUMNS))
    meta = meta | {DECLARATION_KEY: None if declaration is None else declaration.to_dict()}
    return StudyAnalysis(kill_matrix=km.to_frame(), detection=detection, scores=score_table(ev),
                         comparisons=label_rows(compare_scores(ev, alpha=spec.alpha), declaration, "comparisons"),
                         power=_power(ev.pool_sizes, spec), whole=whole,
                         detection_comparisons=label_rows(per_fault, declaration, "detection_comparisons"),
                         detection_means=label_rows(means, declaration, "detection_means"), declared=declared,
                         controls=controls, controls_summary=aa_summary(controls, alpha=spec.alpha), meta=meta)


def reanalyse_saved_study(directory: str | Path) -> StudyAnalysis:
    """A saved study analysis evaluated again from its kill matrix (``kill_matrix.csv`` and
    ``study_meta.json``), without the store: the suite draws, intervals and comparisons are
    recomputed by the current code; the kill matrix's p values keep the sidedness they were
    computed with (``alternative`` in the meta; one-sided for an analysis saved before it was recorded).
    """
    d = Path(directory)
    try:
        frame = pd.read_csv(d / "kill_matrix.csv", keep_default_na=False, na_values=[""])
        meta = json.loads((d / _META_FILE).read_text())
    except (OSError, ValueError) as exc:
        raise ResultsError(f"{d}: not a saved study analysis ({exc})") from exc
    alternative = meta.get("alternative", "greater")
    if "direction" not in frame.columns:
        diff = frame["mean_diff_mm"].to_numpy(float)
        frame["direction"] = np.where(diff > 0, "worse", np.where(diff < 0, "better", "none"))
    if "mean_log_ratio" not in frame.columns:  # not recorded by the analysis that saved it
        frame["mean_log_ratio"] = np.nan
    km = KillMatrix.from_frame(frame)
    spec = study_spec(meta["study"], source=str(d / _META_FILE))
    ev, mutants, detection, whole, skipped, per_fault, means = _evaluate(km, spec, k=meta.get("repetitions"),
                                                                         alternative=alternative)
    meta = meta | {"alternative": alternative, "sizes_not_evaluated": meta.get("sizes_not_evaluated", {}),
                   "whole_not_evaluated": skipped}
    declaration = _declaration(meta.get(DECLARATION_KEY), str(d / _META_FILE))
    return _analysis(km, spec, ev, mutants, detection, whole, per_fault, means, declaration, meta)


def analyse_study(out: str | Path) -> StudyAnalysis:
    """The study's analysis from its output directory (runs nothing).

    Reads the store and ``study.json`` (written by :func:`faultlab.campaigns.study.run_study`), builds the kill matrix and
    evaluates suites of every size from every strategy's pool (:mod:`faultlab.stats.killmatrix`).
    A directory holding a saved analysis instead (``kill_matrix.csv`` and ``study_meta.json``, no
    ``study.json``) is evaluated again from its kill matrix (:func:`reanalyse_saved_study`).
    """
    out = Path(out)
    if not (out / STUDY_FILE).exists() and (out / _META_FILE).exists():
        return reanalyse_saved_study(out)
    try:
        info = json.loads((out / STUDY_FILE).read_text())
    except (OSError, ValueError) as exc:
        raise ResultsError(f"{out}: not a study's output directory ({STUDY_FILE}: {exc})") from exc
    spec = study_spec(info["study"], source=str(out / STUDY_FILE))
    results = load_results(out)
    meta = load_metadata(out)
    rule, _ = read_rule(meta)
    exp = meta["experiment"]
    # sizes whose per-case level alpha / n the stored K cannot reach with the rule's sidedness are not
    # evaluated (every such suite would detect by crashes only) and are listed in the meta
    alternative = alternative_of(rule.direction)
    k = int(exp["repetitions"])
    too_large = {int(n): min_pairs(spec.alpha / n, alternative=alternative) for n in spec.sizes
                 if k < min_pairs(spec.alpha / n, alternative=alternative)}
    if len(too_large) == len(spec.sizes):
        raise ResultsError(f"{out}: K = {k} repetitions reach no suite size's per-case level with the "
                           f"{alternative} test (sizes {list(spec.sizes)})")
    spec = dataclasses.replace(spec, sizes=tuple(n for n in spec.sizes if n not in too_large))
    # a kill matrix of the rows stored so far would judge cases on fewer repetitions, or leave cases out,
    # without saying so: an unfinished study is not analysed
    expected = count_expected_jobs(meta)
    if expected is not None and int(meta["n_rows"]) < expected:
        raise ResultsError(f"{out}: the study is unfinished ({int(meta['n_rows']):,} of {expected:,} SLAM executions "
                           f"stored); `faultlab study run` on it resumes the study")
    km = kill_matrix(results, rule=rule, metric=judged_metric(meta))
    ev, mutants, detection, whole, whole_skipped, per_fault, means = _evaluate(km, spec, k=k,
                                                                               alternative=alternative)
    status = results["status"].astype(str).value_counts().to_dict()
    sessions = settle_sessions(info.get("sessions", []), load_sessions(out))
    meta_out = {
        "study": spec.to_dict(), "quick": info.get("quick", False), "pool": info.get("pool", {}),
        "runs": exp["runs"], "repetitions": exp["repetitions"], "n_steps": exp["n_steps"], "slam": exp["slam"],
        "timeout_s": exp["timeout_s"], "seed": exp["seed"], "rule": rule.to_dict(), "faults": [v for v in km.variants if v not in mutants],
        "paper_faults": [f for f in PAPER_FAULTS if f in km.variants], "mutants": list(mutants),
        "mutant_unit": _of_run(info.get("mutant_unit", {}), mutants),
        "mutant_operator": _of_run(info.get("mutant_operator", {}), mutants),
        "n_jobs": int(len(results)), "status_counts": {str(k): int(v) for k, v in status.items()},
        "slam_time_s": float(results["runtime_s"].sum()), "store_wall_time_s": float(meta["wall_time_s"]),
        "sessions": [{k: v for k, v in s.items() if k != "load"} for s in sessions],
        "wall_time_s": float(sum(s.get("wall_time_s") or 0.0 for s in sessions)),
        "load": _load_summary(sessions), "complete": expected is not None,
        "cannot_judge_cases": int((~km.judged).any(axis=1).sum()),
        "alternative": alternative, "sizes_not_evaluated": {str(n): need for n, need in too_large.items()},
        "whole_not_evaluated": whole_skipped,
        "weights": {"file": info.get("weights_file"), "classes": (exp.get("space") or {}).get("weights")},
        "crash_cases": {v: int(n) for v, n in zip(km.variants, km.crash.sum(axis=0)) if n},
        "timeout_cases": {v: int(n) for v, n in zip(km.variants, km.timeout.sum(axis=0)) if n},
    }
    declaration = _declaration(meta.get(DECLARATION_KEY), str(out))
    return _analysis(km, spec, ev, mutants, detection, whole, per_fault, means, declaration, meta_out)

