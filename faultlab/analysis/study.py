"""The test-design strategies study: a case pool per strategy, its kill matrix, suites drawn from it.

Running (:func:`run_study`)
---------------------------
A study file is an ordinary experiment file (``experiments/study.toml``) plus

* ``[mutation]``: a sample of live mutants of the reference FastSLAM, selected exactly as in a
  mutation campaign (:func:`~faultlab.analysis.mutation.selection_from_table`); they become the
  variants ``mutant:<id>`` after the file's own variants;
* ``[study]``: the suite sizes evaluated, the number of suites drawn per strategy and size, the
  bootstrap replicates, the seed of both, the family-wise level of a suite and the multiplicity
  rule (:class:`StudySpec`);
* ``[study.quick]``: keys that replace the file's for ``--quick`` (tables merged key by key).

The *case pool* of a strategy is every case its generator draws in the campaign: ``runs``
evaluation runs, each drawing a new suite of the size in ``[suites]`` through the one case
pipeline (:func:`faultlab.scenario.draw_suite`).  The pool runs once, through the ordinary runner
(:func:`faultlab.runner.run_experiment`: resumable, K repetitions per (case, variant) batched,
common random numbers), so a study is resumed like ``faultlab run`` and its store is an ordinary
campaign store.

Analysing (:func:`analyse_study`)
---------------------------------
The store is reduced to the kill matrix (:func:`faultlab.stats.killmatrix.kill_matrix`: per pool
case and variant, the exact p value, the crash flag and the paper rule's flag), and every suite
size is evaluated by drawing suites from each strategy's pool
(:func:`faultlab.stats.killmatrix.evaluate_strategies`); see that module for the suite rule, the
confidence intervals and the power statement.
"""

from __future__ import annotations

import contextlib
import copy
import dataclasses
import json
import math
import os
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator, Mapping

import numpy as np
import pandas as pd

from faultlab.analysis.bundle import TableBundle
from faultlab.analysis.metadata import count_expected_jobs, read_rule
from faultlab.analysis.mutation import selection_from_table
from faultlab.config import Table, read_toml
from faultlab.data import resolve_experiment
from faultlab.errors import ConfigError, ResultsError
from faultlab.mutation.variants import MutantSelection, is_mutant_variant, mutant_id_of, mutant_variant
from faultlab.runner.execute import RunSummary, run_experiment
from faultlab.runner.experiment import Experiment, parse_experiment
from faultlab.runner.store import load_metadata, load_results
from faultlab.stats.cases import detectable_difference
from faultlab.stats.killmatrix import (MULTIPLICITY, KillMatrix, compare_scores, detection_table, evaluate_suites,
                                       kill_matrix, score_table)
from faultlab.stats.verdict import alternative_of, min_pairs
from faultlab.vocabulary import DEFAULT_ALPHA, PAPER_FAULTS

__all__ = ["STUDY_FILE", "STUDY_TABLES", "StudySpec", "StudyExperiment", "StudyAnalysis", "load_study_experiment",
           "run_study", "analyse_study", "study_spec", "sampled_load"]

#: File in the output directory recording the study's settings (read by :func:`analyse_study`).
STUDY_FILE = "study.json"
_STUDY_KEYS = ("sizes", "draws", "bootstrap", "seed", "alpha", "multiplicity", "timeouts_detect", "quick")


@dataclass(frozen=True)
class StudySpec:
    """The ``[study]`` table: how suites are drawn from the pools and judged.

    Attributes
    ----------
    sizes : tuple of int
        Suite sizes evaluated (each at most the smallest pool).
    draws : int
        Suites drawn per strategy and size.
    bootstrap : int
        Bootstrap replicates over pool cases (the confidence intervals).
    seed : int
        Root of the suite draws and the bootstrap (:func:`faultlab.seeds.study_seed_sequence`).
    alpha : float
        Family-wise level of one suite.
    multiplicity : {"holm", "bonferroni"}
        Rule within a suite's cases.
    timeouts_detect : bool
        Whether a variant's timeout on a case detects it (default false: on a shared machine the
        wall-clock limit measures the load as much as the variant; crashes always detect).
    """

    sizes: tuple[int, ...] = (1, 2, 5, 10, 20)
    draws: int = 2000
    bootstrap: int = 1000
    seed: int = 0
    alpha: float = DEFAULT_ALPHA
    multiplicity: str = "holm"
    timeouts_detect: bool = False

    def to_dict(self) -> dict:
        return {"sizes": list(self.sizes), "draws": self.draws, "bootstrap": self.bootstrap, "seed": self.seed,
                "alpha": self.alpha, "multiplicity": self.multiplicity, "timeouts_detect": self.timeouts_detect}


def study_spec(data: Mapping, *, source: str) -> StudySpec:
    """Validate a ``[study]`` table into a :class:`StudySpec` (ConfigError naming file and key)."""
    t = Table(data, "study", source)
    t.check_unknown(_STUDY_KEYS)
    d = StudySpec()
    sizes = t.get("sizes", list(d.sizes))
    if (not isinstance(sizes, list) or not sizes
            or any(isinstance(n, bool) or not isinstance(n, int) or n < 1 for n in sizes)):
        raise t.error("sizes", f"must be a non-empty list of integers >= 1, got {sizes!r}")
    if len(set(sizes)) != len(sizes):
        raise t.error("sizes", f"lists a size twice: {sizes!r}")
    alpha = t.float("alpha", d.alpha, positive=True)
    if not alpha < 1:
        raise t.error("alpha", f"must lie in (0, 1), got {alpha!r}")
    return StudySpec(sizes=tuple(sorted(sizes)), draws=t.int("draws", d.draws, minimum=1),
                     bootstrap=t.int("bootstrap", d.bootstrap, minimum=1), seed=t.int("seed", d.seed, minimum=0),
                     alpha=alpha, multiplicity=t.str("multiplicity", d.multiplicity, choices=MULTIPLICITY),
                     timeouts_detect=t.bool("timeouts_detect", d.timeouts_detect))


@dataclass(frozen=True)
class StudyExperiment:
    """A validated study: the campaign that runs the pools, the mutants in it and the ``[study]`` settings."""

    experiment: Experiment
    study: StudySpec
    selection: MutantSelection | None
    quick: bool = False

    def to_json(self) -> dict:
        sel = self.selection
        return {"study": self.study.to_dict(), "quick": self.quick,
                "mutants": [] if sel is None else list(sel.run),
                "mutant_unit": {} if sel is None else {m: sel.unit[m] for m in sel.run},
                "mutant_operator": {} if sel is None else {m: sel.operator[m] for m in sel.run},
                "pool": {s.kind: s.n_cases for s in self.experiment.suites}, "runs": self.experiment.runs}


def _merge(data: dict, overrides: Mapping) -> dict:
    """``data`` with ``overrides`` replacing its keys; a table replaces key by key."""
    out = copy.deepcopy(data)
    for key, value in overrides.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = {**out[key], **copy.deepcopy(dict(value))}
        else:
            out[key] = copy.deepcopy(value)
    return out


def load_study_experiment(path: str | Path, *, quick: bool = False) -> StudyExperiment:
    """Read a study file (or the shipped ``study``); ``quick`` applies its ``[study.quick]`` table.

    Raises
    ------
    ConfigError
        Anything malformed (naming the file and key), a size larger than a strategy's pool, or K
        too small for the largest size: a case of a suite of ``n`` cases is judged at
        ``alpha / n``, which the exact sign-flip test reaches only from ``K = min_pairs(alpha / n)``.
    """
    file = resolve_experiment(path, what="study file")
    data, text = read_toml(file, what="study file")
    source = str(path) + (" (--quick)" if quick else "")
    data = dict(data)
    study = dict(data.pop("study", {}) or {})
    if not isinstance(study, dict):
        raise ConfigError(f"{path}: study must be a table")
    quick_table = study.pop("quick", {})
    if not isinstance(quick_table, Mapping):
        raise ConfigError(f"{path}: study.quick must be a table")
    if quick:
        data = _merge(data | {"study": study}, quick_table)
        study = dict(data.pop("study", {}))
    spec = study_spec(study, source=source)
    mutation = data.pop("mutation", None)
    selection = None
    variants = list(data.get("variants", []))
    if any(is_mutant_variant(v) for v in variants):
        raise ConfigError(f"{source}: variants: mutants come from [mutation], not from variants")
    if mutation is not None:
        if not isinstance(mutation, Mapping):
            raise ConfigError(f"{source}: mutation must be a table")
        selection = selection_from_table(dict(mutation), source=source)
        data["variants"] = variants + [mutant_variant(m) for m in selection.run]
    exp = parse_experiment(data, source=source, text=text)
    for s in exp.suites:
        pool = exp.runs * (s.n_cases or 0)
        if s.n_cases is not None and max(spec.sizes) > pool:
            raise ConfigError(f"{source}: study.sizes: a suite of {max(spec.sizes)} cases cannot be drawn from the "
                              f"{pool} cases of the {s.kind} pool (runs x suites.{s.kind})")
    alternative = alternative_of(exp.detection.direction)
    need = min_pairs(spec.alpha / max(spec.sizes), alternative=alternative)
    if exp.repetitions < need:
        raise ConfigError(f"{source}: repetitions = {exp.repetitions} is too few: a case of a suite of "
                          f"{max(spec.sizes)} cases is judged at {spec.alpha}/{max(spec.sizes)}, which the exact "
                          f"{alternative} sign-flip test reaches only from K = {need}")
    return StudyExperiment(experiment=exp, study=spec, selection=selection, quick=quick)


@contextlib.contextmanager
def sampled_load(interval_s: float = 30.0) -> Iterator[list]:
    """Sample the machine's load averages (``os.getloadavg``) every ``interval_s`` while the block runs.

    Yields the list the samples are appended to: ``[unix time, load 1 min, 5 min, 15 min]``, one at
    the start, one per interval and one at the end.
    """
    samples: list = []
    stop = threading.Event()

    def sample() -> None:
        while True:
            samples.append([time.time(), *os.getloadavg()])
            if stop.wait(interval_s):
                return

    worker = threading.Thread(target=sample, daemon=True)
    worker.start()
    try:
        yield samples
    finally:
        stop.set()
        worker.join()
        samples.append([time.time(), *os.getloadavg()])


def _saved_sessions(out: Path, sexp: StudyExperiment) -> list:
    try:
        old = json.loads((out / STUDY_FILE).read_text())
    except (OSError, ValueError):
        return []
    keys = ("quick", "mutants", "pool", "runs")  # the campaign; [study] settings may change between sessions
    same = all(old.get(k) == sexp.to_json()[k] for k in keys)
    return list(old.get("sessions", [])) if same else []


def run_study(sexp: StudyExperiment | str | Path, out: str | Path, *, jobs: int = 2, backend: str = "loky",
              force_new: bool = False, progress: bool = True) -> RunSummary:
    """Run (or resume) a study's pools through the runner; record its settings and every session's
    wall time, jobs and sampled machine load in ``out/study.json``."""
    if not isinstance(sexp, StudyExperiment):
        sexp = load_study_experiment(sexp)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    sessions = [] if force_new else _saved_sessions(out, sexp)
    record = {"started": time.time(), "jobs": jobs, "backend": backend, "cpus": os.cpu_count(), "n_new": 0,
              "wall_time_s": math.nan, "state": "interrupted", "load": []}
    sessions.append(record)

    def save() -> None:
        (out / STUDY_FILE).write_text(json.dumps(sexp.to_json() | {"sessions": sessions}, indent=1))

    save()
    t0 = time.perf_counter()
    try:
        with sampled_load() as load:
            record["load"] = load
            summary = run_experiment(sexp.experiment, out, jobs=jobs, backend=backend, force_new=force_new,
                                     progress=progress)
            record.update(state="complete", n_new=summary.n_new)
    finally:
        record["wall_time_s"] = time.perf_counter() - t0
        save()  # an interrupted session is recorded too
    return summary


# --------------------------------------------------------------------------- analysis

#: Tables of a :class:`StudyAnalysis`, saved as ``<name>.csv``.
STUDY_TABLES = ("kill_matrix", "detection", "scores", "comparisons", "power")
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
        with 80 % power at 0.05, at rates 0.5 and 0.1.
    meta : dict
        Settings, mutants, run time per session, sampled machine load, SLAM time, job counts.
    """

    kill_matrix: pd.DataFrame
    detection: pd.DataFrame
    scores: pd.DataFrame
    comparisons: pd.DataFrame
    power: pd.DataFrame
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
                     "mdd80_at_0.5": max(detectable_difference(0.5, n_a, n) for n in others),
                     "mdd80_at_0.1": max(detectable_difference(0.1, n_a, n) for n in others)})
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
    mutants = tuple(v for v in km.variants if is_mutant_variant(v))
    ev = evaluate_suites(km, spec.sizes, draws=spec.draws, bootstrap=spec.bootstrap, seed=spec.seed,
                         alpha=spec.alpha, method=spec.multiplicity, mutants=mutants,
                         timeouts_detect=spec.timeouts_detect)
    detection = detection_table(ev, km.variants)
    detection.insert(1, "kind", ["mutant" if is_mutant_variant(v) else "fault" for v in detection["variant"]])
    meta = meta | {"alternative": alternative, "sizes_not_evaluated": meta.get("sizes_not_evaluated", {})}
    return StudyAnalysis(kill_matrix=km.to_frame(), detection=detection, scores=score_table(ev),
                         comparisons=compare_scores(ev, alpha=spec.alpha), power=_power(ev.pool_sizes, spec),
                         meta=meta)


def analyse_study(out: str | Path) -> StudyAnalysis:
    """The study's analysis from its output directory (runs nothing).

    Reads the store and ``study.json`` (written by :func:`run_study`), builds the kill matrix and
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
    km = kill_matrix(results, rule=rule, metric=exp.get("metric", "rms"))
    mutants = tuple(v for v in km.variants if is_mutant_variant(v))
    ev = evaluate_suites(km, spec.sizes, draws=spec.draws, bootstrap=spec.bootstrap, seed=spec.seed,
                         alpha=spec.alpha, method=spec.multiplicity, mutants=mutants,
                         timeouts_detect=spec.timeouts_detect)
    detection = detection_table(ev, km.variants)
    detection.insert(1, "kind", ["mutant" if is_mutant_variant(v) else "fault" for v in detection["variant"]])
    status = results["status"].astype(str).value_counts().to_dict()
    sessions = info.get("sessions", [])
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
        "load": _load_summary(sessions), "complete": int(meta["n_rows"]) == count_expected_jobs(meta),
        "cannot_judge_cases": int((~km.judged).any(axis=1).sum()),
        "alternative": alternative, "sizes_not_evaluated": {str(n): need for n, need in too_large.items()},
        "crash_cases": {v: int(n) for v, n in zip(km.variants, km.crash.sum(axis=0)) if n},
        "timeout_cases": {v: int(n) for v, n in zip(km.variants, km.timeout.sum(axis=0)) if n},
    }
    return StudyAnalysis(kill_matrix=km.to_frame(), detection=detection, scores=score_table(ev),
                         comparisons=compare_scores(ev, alpha=spec.alpha), power=_power(ev.pool_sizes, spec),
                         meta=meta_out)

