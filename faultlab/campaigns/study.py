"""The test-design strategies study as a campaign: one case pool per strategy, run once.

A study file is an ordinary experiment file (``experiments/study.toml``) plus

* ``[mutation]``: a sample of live mutants of the reference FastSLAM, selected exactly as in a
  mutation campaign (:func:`~faultlab.campaigns.mutation.selection_from_table`); they become the
  variants ``mutant:<id>`` after the file's own variants;
* ``[study]``: the suite sizes evaluated, the number of suites drawn per strategy and size, the
  bootstrap replicates, the seed of both, the family-wise level of a suite and the multiplicity
  rule (:class:`~faultlab.stats.killmatrix.StudySpec`), and ``weights``: the class-weights CSV of
  an earlier effects study (``weights_<fault>.csv`` of ``faultlab effects report``) that an
  ``effect-guided`` suite draws its classes by (:func:`study_class_weights`);
* ``[study.quick]``: keys that replace the file's for ``--quick`` (tables merged key by key);
* ``[declaration]``: the analyses declared before the run (:mod:`faultlab.stats.declaration`),
  recorded in the store when it is created and refused on a resume if they changed.

The *case pool* of a strategy is every case its generator draws in the campaign: ``runs``
evaluation runs, each drawing a new suite of the size in ``[suites]`` through the one case
pipeline (:func:`faultlab.scenario.draw_suite`).  The pool runs once, through the ordinary runner
(:func:`faultlab.runner.run_experiment`: resumable, K repetitions per (case, variant) batched,
common random numbers), so a study is resumed like ``faultlab run`` and its store is an ordinary
campaign store.

The kill matrix and the suites drawn from the pools are computed from the store by
:func:`faultlab.analysis.study.analyse_study`.
"""

from __future__ import annotations

import contextlib
import json
import os
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator, Mapping

from faultlab.campaigns.mutation import selection_from_table
from faultlab.config import merge_tables, read_toml
from faultlab.data import resolve_experiment
from faultlab.errors import ConfigError, FaultlabError
from faultlab.mutation.variants import MutantSelection, is_mutant_variant, mutant_variant
from faultlab.runner import Experiment, RunSummary, parse_experiment, run_experiment
from faultlab.runner.store import STUDY_FILE, check_store, load_sessions, settle_sessions
from faultlab.space import read_class_weights, space_from_mapping
from faultlab.stats.declaration import DECLARATION_KEY, RECORDED, Declaration, declaration_from
from faultlab.stats.killmatrix import StudySpec, study_spec
from faultlab.inference.exact import alternative_of, min_pairs

__all__ = ["STUDY_FILE", "StudyExperiment", "load_study_experiment", "run_study", "sampled_load",
           "study_class_weights"]

#: The suite strategy that draws its classes by the weights of ``[study] weights``.
WEIGHTED_STRATEGY = "effect-guided"


@dataclass(frozen=True)
class StudyExperiment:
    """A validated study: the campaign that runs the pools, the mutants in it and the ``[study]`` settings."""

    experiment: Experiment
    study: StudySpec
    selection: MutantSelection | None
    quick: bool = False
    weights_file: str | None = None
    declaration: Declaration | None = None

    def to_json(self) -> dict:
        sel = self.selection
        return {"study": self.study.to_dict(), "quick": self.quick, "weights_file": self.weights_file,
                DECLARATION_KEY: None if self.declaration is None else self.declaration.to_dict(),
                "mutants": [] if sel is None else list(sel.run),
                "mutant_unit": {} if sel is None else {m: sel.unit[m] for m in sel.run},
                "mutant_operator": {} if sel is None else {m: sel.operator[m] for m in sel.run},
                "pool": {s.kind: s.n_cases for s in self.experiment.suites}, "runs": self.experiment.runs}

def study_class_weights(value, space: Mapping, *, source: str,
                        base_dir: str | Path | None = None) -> dict[str, dict[str, float]]:
    """The class weights of ``[study] weights``: a CSV file of an earlier effects study, checked against the space.

    Parameters
    ----------
    value
        The key's value: the path of a CSV file with the columns ``parameter, class, weight``
        (``weights_<fault>.csv`` of ``faultlab effects report``); a relative path is read from
        ``base_dir``.
    space : mapping
        The study's ``[space]`` table (Table I overrides), which the weights must fit.
    source : str
        The study file, for messages.
    base_dir : path, optional
        The study file's directory (symbolic links followed); None reads a relative path from the
        working directory.

    Returns
    -------
    dict
        ``{parameter: {class: weight}}``, to become the space's ``[weights]``.

    Raises
    ------
    ConfigError
        One message naming the study file, the key and the CSV file: not a path, no such file, an
        unreadable or malformed file, a file without any weight (an effects study derives none for
        a response without a clear effect), weights that do not fit the space's parameters and
        classes, or ``[space.weights]`` given as well.
    """
    where = f"{source}: study.weights"
    if not isinstance(value, str) or not value:
        raise ConfigError(f"{where}: expected the path of a class-weights CSV file (parameter, class, weight; "
                          f"weights_<fault>.csv of `faultlab effects report`), got {value!r}")
    if "weights" in space:
        raise ConfigError(f"{where}: [space.weights] gives class weights as well; give them once")
    file = Path(value)
    if not file.is_absolute() and base_dir is not None:
        file = Path(base_dir) / file
    if not file.is_file():
        raise ConfigError(f"{where}: {value}: no such file (a weights_<fault>.csv of `faultlab effects report`; "
                          f"a relative path is read from the study file's directory)")
    base = space_from_mapping(space, source=f"{source} [space]")
    try:
        weights = read_class_weights(file)
        if not weights:
            raise ConfigError(f"{value}: holds no class weights (an effects study derives none for a response "
                              f"without a clear effect; choose another response's file)")
        base.with_weights(weights, source=value)
    except ConfigError as exc:  # one line: a parser's message may span several
        raise ConfigError(f"{where}: {' '.join(str(exc).split())}") from None
    return weights


def load_study_experiment(path: str | Path, *, quick: bool = False) -> StudyExperiment:
    """Read a study file (or the shipped ``study``); ``quick`` applies its ``[study.quick]`` table.

    Raises
    ------
    ConfigError
        Anything malformed (naming the file and key; the weights file by :func:`study_class_weights`),
        an ``effect-guided`` suite without ``[study] weights`` (or weights no suite uses), a size
        larger than a strategy's pool, or K
        too small for the largest size: a case of a suite of ``n`` cases is judged at
        ``alpha / n``, which the exact sign-flip test of the rule's sidedness reaches only from
        ``K = min_pairs(alpha / n)`` (two-sided: one more than one-sided).
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
        data = merge_tables(data | {"study": study}, quick_table)
        study = dict(data.pop("study", {}))
    weights_file = study.pop("weights", None)
    spec = study_spec(study, source=source)
    suites = data.get("suites", {})
    weighted = isinstance(suites, Mapping) and WEIGHTED_STRATEGY in suites
    space = data.get("space", {})
    if weights_file is not None:
        if not weighted:
            raise ConfigError(f"{source}: study.weights: no {WEIGHTED_STRATEGY} suite in [suites] draws by them")
        space = dict(space) if isinstance(space, Mapping) else space
        if isinstance(space, Mapping):  # parse_experiment refuses a [space] that is not a table
            data["space"] = space | {"weights": study_class_weights(weights_file, space, source=source,
                                                                     base_dir=file.resolve().parent)}
    elif weighted and not (isinstance(space, Mapping) and "weights" in space):
        raise ConfigError(f"{source}: suites.{WEIGHTED_STRATEGY}: needs class weights: give study.weights = "
                          f"the path of an effects study's weights_<fault>.csv (`faultlab effects report`)")
    declared = data.pop("declaration", None)
    declaration = None if declared is None else declaration_from(declared, source=source, recorded=RECORDED[0])
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
    kinds = [s.kind for s in exp.suites]
    for i, analysis in enumerate(declaration.analyses if declaration is not None else ()):
        for strategy in (analysis.strategy_a, analysis.strategy_b):
            if strategy != "*" and strategy not in kinds:
                raise ConfigError(f"{source}: declaration.analyses[{i}]: {strategy!r} is not one of the study's "
                                  f"suites ({', '.join(kinds)})")
        if analysis.variant != "*" and analysis.variant not in exp.variants:
            raise ConfigError(f"{source}: declaration.analyses[{i}].variant: {analysis.variant!r} is not one of "
                              f"the study's variants")
    for strategy in spec.whole:
        if strategy not in kinds:
            raise ConfigError(f"{source}: study.whole: {strategy!r} is not one of the study's suites "
                              f"({', '.join(kinds)})")
    # the largest family judged: the largest drawn size, or a whole generated suite
    largest = max([*spec.sizes, *(s.n_cases or 0 for s in exp.suites if s.kind in spec.whole)])
    alternative = alternative_of(exp.detection.direction)
    need = min_pairs(spec.alpha / largest, alternative=alternative)
    if exp.repetitions < need:
        raise ConfigError(f"{source}: repetitions = {exp.repetitions} is too few: a case of a suite of "
                          f"{largest} cases is judged at {spec.alpha}/{largest}, which the exact "
                          f"{alternative} sign-flip test reaches only from K = {need}")
    return StudyExperiment(experiment=exp, study=spec, selection=selection, quick=quick, weights_file=weights_file,
                           declaration=declaration)


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


def _read_study_file(out: Path) -> dict | None:
    try:
        return json.loads((out / STUDY_FILE).read_text())
    except (OSError, ValueError):
        return None


def _saved_sessions(out: Path, sexp: StudyExperiment) -> list:
    old = _read_study_file(out)
    if old is None:
        return []
    keys = ("quick", "mutants", "pool", "runs")  # the campaign; [study] settings may change between sessions
    same = all(old.get(k) == sexp.to_json()[k] for k in keys)
    return list(old.get("sessions", [])) if same else []


def run_study(sexp: StudyExperiment | str | Path, out: str | Path, *, jobs: int = 2, backend: str = "loky",
              force_new: bool = False, progress: bool = True) -> RunSummary:
    """Run (or resume) a study's pools through the runner; record its settings and every session's
    wall time, jobs and sampled machine load in ``out/study.json``.

    A session record is written ``running`` before the pools run and completed when they end; a
    session killed before that is settled from the store when the study is next run or analysed
    (:func:`~faultlab.runner.store.settle_sessions`).  A run the store refuses (another experiment, a damaged store, the
    store in use) writes nothing: the check comes before the first write.
    """
    if not isinstance(sexp, StudyExperiment):
        sexp = load_study_experiment(sexp)
    out = Path(out)
    check_store(out, sexp.experiment, force_new=force_new)
    record = {"started": time.time(), "jobs": jobs, "backend": backend, "cpus": os.cpu_count(), "n_new": 0,
              "wall_time_s": None, "state": "running", "load": []}
    sessions: list = []

    def save() -> None:
        text = json.dumps(sexp.to_json() | {"sessions": sessions}, indent=1, allow_nan=False)
        tmp = out / (STUDY_FILE + ".tmp")
        tmp.write_text(text)
        tmp.replace(out / STUDY_FILE)  # never half-written

    def start() -> None:  # the runner accepted the store: from here on the session is recorded
        sessions[:] = [] if force_new else settle_sessions(_saved_sessions(out, sexp), load_sessions(out))
        sessions.append(record)
        save()

    t0 = time.perf_counter()
    summary = None
    try:
        with sampled_load() as load:
            record["load"] = load
            summary = run_experiment(sexp.experiment, out, jobs=jobs, backend=backend, force_new=force_new,
                                     progress=progress, on_start=start,
                                     meta=None if sexp.declaration is None
                                     else {DECLARATION_KEY: sexp.declaration.to_dict()})
            record.update(state="complete", n_new=summary.n_new)
    finally:
        if sessions:  # not refused
            record["wall_time_s"] = time.perf_counter() - t0
            if summary is None:
                record["state"] = "interrupted"
                with contextlib.suppress(FaultlabError):  # a damaged store must not hide the run's own error
                    sessions[-1:] = settle_sessions(sessions, load_sessions(out))[-1:]
            with contextlib.suppress(OSError):  # nor a full disk
                save()
    return summary
