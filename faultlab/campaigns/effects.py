"""The effects study campaign: a Morris screening design, then a Sobol design over what screening keeps.

An effects file (``experiments/effects.toml``) is an ordinary experiment file without ``[suites]``
plus an ``[effects]`` table (:class:`EffectsSpec`) and an optional ``[effects.quick]`` table whose
keys replace the file's for ``--quick`` (tables merged key by key, as for a study file).

Running (:func:`run_effects`) goes through the ordinary runner
(:func:`faultlab.runner.run_experiment`: resumable, locked, batched repetitions with common random
numbers, any backend) in two stages, each its own store:

1. ``OUT/morris``: the Morris design (:func:`faultlab.space.design.morris_design`) over the file's
   factors, one test case per design point (suite ``morris``, case = point number);
2. ``OUT/sobol``: the Sobol/Saltelli design (:func:`faultlab.space.design.sobol_design`) over the
   factors that screening keeps (:func:`faultlab.stats.screening.screen_store`), suite ``sobol``.

Every design is drawn from the file's seed (:func:`faultlab.seeds.design_seed_sequence`), every
case generated from its own seed (:func:`faultlab.seeds.case_seed` with run 1 and the stage as the
suite), every repetition run with the same SLAM seed for all variants.  ``OUT/effects.json``
records the settings, the kept factors and every finished session (start, end, the 1-minute load
average at both); a resume with other settings is refused before anything is written.
"""

from __future__ import annotations

import json
import os
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence


from faultlab.config import Table, merge_tables, read_toml
from faultlab.data import resolve_experiment
from faultlab.errors import ConfigError, ResultsError
from faultlab.runner import RunSummary, run_experiment
from faultlab.runner.experiment import Experiment, parse_experiment
from faultlab.runner.store import results_path
from faultlab.scenario.suite import SuiteCase
from faultlab.seeds import case_seed
from faultlab.space.design import Design, check_factors, design_size, study_design
from faultlab.stats.screening import read_effects_json, screen_store
from faultlab.vocabulary import BASELINE, EFFECTS_FILE, EFFECTS_STAGES

__all__ = ["EFFECTS_FILE", "STAGES", "EffectsSpec", "EffectsExperiment", "load_effects_experiment", "parse_effects",
           "effects_spec", "stage_design", "design_cases", "run_effects", "effects_plan"]

#: The two stages, in running order (:data:`faultlab.vocabulary.EFFECTS_STAGES`).
STAGES: tuple[str, ...] = EFFECTS_STAGES
_KEYS = ("factors", "trajectories", "levels", "keep", "sobol_base", "resamples", "seed", "quick")


@dataclass(frozen=True)
class EffectsSpec:
    """The ``[effects]`` table.

    Attributes
    ----------
    factors : tuple of str
        Parameters the Morris design varies (default all 11); the others keep the fixed suite's values.
    trajectories : int
        Morris trajectories ``r`` (``r (d + 1)`` cases).
    levels : int
        Morris grid levels (even).
    keep : int
        Screening keeps, per response, the ``keep >= 2`` parameters with the largest ``mu*``; the
        union over responses goes on to the Sobol stage.
    sobol_base : int
        Saltelli base sample ``N`` (a power of two; ``N (k + 2)`` cases for ``k`` kept factors); 0
        skips the Sobol stage.
    resamples : int
        Bootstrap replicates of every index interval.
    seed : int
        Root of the designs and of the bootstraps.
    """

    factors: tuple[str, ...] = ()
    trajectories: int = 10
    levels: int = 4
    keep: int = 3
    sobol_base: int = 16
    resamples: int = 1000
    seed: int = 0

    def to_dict(self) -> dict:
        return {"factors": list(self.factors), "trajectories": self.trajectories, "levels": self.levels,
                "keep": self.keep, "sobol_base": self.sobol_base, "resamples": self.resamples, "seed": self.seed}


def effects_spec(data: Mapping, *, source: str) -> EffectsSpec:
    """Validate an ``[effects]`` table (one ConfigError naming file and key)."""
    t = Table(data, "effects", source)
    t.check_unknown(_KEYS)
    d = EffectsSpec()
    raw = t.get("factors", "all")
    if raw == "all":
        factors = check_factors(None)
    elif isinstance(raw, list) and all(isinstance(f, str) for f in raw):
        factors = check_factors(raw, where=f"{source}: effects.factors")
    else:
        raise t.error("factors", f"must be \"all\" or a list of parameter names, got {raw!r}")
    levels = t.int("levels", d.levels, minimum=2)
    if levels % 2:
        raise t.error("levels", f"must be even (Morris' grid), got {levels}")
    base = t.int("sobol_base", d.sobol_base, minimum=0)
    if base and (base < 4 or base & (base - 1)):
        raise t.error("sobol_base", f"must be 0 (no Sobol stage) or a power of two >= 4, got {base}")
    return EffectsSpec(factors=factors, trajectories=t.int("trajectories", d.trajectories, minimum=2),
                       levels=levels, keep=t.int("keep", d.keep, minimum=2), sobol_base=base,
                       resamples=t.int("resamples", d.resamples, minimum=10), seed=t.int("seed", d.seed, minimum=0))


@dataclass(frozen=True)
class EffectsExperiment:
    """A validated effects study: the campaign settings (SLAM, variants, K, ...) and ``[effects]``."""

    experiment: Experiment
    spec: EffectsSpec
    quick: bool = False
    source: str = ""

    def to_json(self) -> dict:
        """What ``effects.json`` records: the settings, and what the analysis needs to rebuild the designs
        (the space overrides) and to describe the run (SLAM, steps, K, variants, metric)."""
        exp = self.experiment
        return {"effects": self.spec.to_dict(), "quick": self.quick, "experiment_hash": exp.hash,
                "source": self.source, "text": exp.text, "space": exp.space,
                "experiment": {"slam": exp.slam.to_dict(), "n_steps": exp.n_steps, "repetitions": exp.repetitions,
                               "variants": list(exp.variants), "metric": exp.metric}}



def load_effects_experiment(path: str | Path, *, quick: bool = False) -> EffectsExperiment:
    """Read an effects file (or the shipped ``effects``); ``quick`` applies its ``[effects.quick]``.

    Raises
    ------
    ConfigError
        Anything malformed (naming file and key), ``[suites]`` in the file (the design makes the
        cases), no baseline among the variants, an impossible design size.
    """
    file = resolve_experiment(path, what="effects file")
    _, text = read_toml(file, what="effects file")
    return parse_effects(text, source=str(path), quick=quick)


def parse_effects(text: str, *, source: str, quick: bool = False) -> EffectsExperiment:
    """An effects study from the text of its file (see :func:`load_effects_experiment`)."""
    path = source
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: not valid TOML ({exc})") from exc
    source = str(path) + (" (--quick)" if quick else "")
    effects = data.pop("effects", {})
    if not isinstance(effects, Mapping):
        raise ConfigError(f"{path}: effects must be a table")
    effects = dict(effects)
    quick_table = effects.pop("quick", {})
    if not isinstance(quick_table, Mapping):
        raise ConfigError(f"{path}: effects.quick must be a table")
    if quick:
        data = merge_tables(data | {"effects": effects}, quick_table)
        effects = dict(data.pop("effects", {}))
    if "suites" in data:
        raise ConfigError(f"{source}: suites: an effects study has no suites (its designs make the cases); "
                          f"remove the [suites] table")
    spec = effects_spec(effects, source=source)
    data["suites"] = {"fixed": 1}  # unused: the designs replace the suites' draws
    exp = parse_experiment(data, source=source, text=text)
    if exp.variants[0] != BASELINE:
        raise ConfigError(f"{source}: variants: an effects study compares every fault with the baseline; "
                          f"list \"baseline\" first")
    return EffectsExperiment(experiment=exp, spec=spec, quick=quick, source=str(path))


def stage_design(eexp: EffectsExperiment, stage: str, *, factors: Sequence[str] | None = None) -> Design:
    """The design of a stage (``"morris"`` over the file's factors, ``"sobol"`` over ``factors``)."""
    spec = eexp.spec
    if stage not in STAGES:
        raise ConfigError(f"unknown stage {stage!r} (stages: {', '.join(STAGES)})")
    if stage == "sobol" and factors is None:
        raise ConfigError("the Sobol stage needs the factors screening kept")
    return study_design(eexp.experiment.parameter_space(), stage, seed=spec.seed, trajectories=spec.trajectories,
                        levels=spec.levels, base=spec.sobol_base,
                        factors=spec.factors if stage == "morris" else factors)


def design_cases(eexp: EffectsExperiment, design: Design) -> tuple[SuiteCase, ...]:
    """The design's points as test cases of run 1 and suite ``design.method``, each with its own seed."""
    root = eexp.experiment.seed
    return tuple(SuiteCase(run=1, suite=design.method, case=i, spec=spec,
                           seed=case_seed(root, 1, design.method, i))
                 for i, spec in enumerate(design.cases, start=1))


def effects_plan(eexp: EffectsExperiment) -> dict:
    """Design sizes and SLAM executions of both stages (the Sobol stage at its largest: every factor
    kept up to ``keep`` per response)."""
    spec, exp = eexp.spec, eexp.experiment
    d = len(spec.factors)
    n_resp = 1 + (len(exp.variants) - 1)  # difficulty and one effect per fault
    k_max = min(d, spec.keep * n_resp)
    morris = design_size("morris", n_factors=d, base=spec.trajectories)
    sobol = design_size("sobol", n_factors=k_max, base=spec.sobol_base) if spec.sobol_base else 0
    per_case = len(exp.variants) * exp.repetitions
    return {"factors": d, "morris_cases": morris, "sobol_cases_max": sobol, "kept_max": k_max,
            "variants": len(exp.variants), "repetitions": exp.repetitions,
            "executions_morris": morris * per_case, "executions_sobol_max": sobol * per_case}


def _check_resume(out: Path, eexp: EffectsExperiment) -> dict:
    path = out / EFFECTS_FILE
    if not path.exists():
        if any((out / stage).exists() for stage in STAGES):
            raise ResultsError(f"{out} holds stores but no {EFFECTS_FILE}: not an effects study's output; use "
                               f"another --out or --force-new")
        return {}
    saved = read_effects_json(out)
    now = eexp.to_json()
    changed = [k for k in ("effects", "quick", "experiment_hash") if saved.get(k) != now[k]]
    if changed:
        raise ResultsError(f"{out} holds an effects study with other settings (changed: {', '.join(changed)}); "
                           f"use another --out or --force-new")
    return saved


def run_effects(eexp: EffectsExperiment, out: str | Path, *, jobs: int = 2, backend: str = "loky", force_new: bool = False, progress: bool = True,
                batch_size: int | None = None) -> dict[str, RunSummary]:
    """Run (or resume) both stages (module docstring).

    Parameters
    ----------
    eexp : EffectsExperiment
    out : path
        Output directory: ``effects.json``, ``morris/`` and ``sobol/`` (each an ordinary store).
    jobs, backend, force_new, progress, batch_size
        As for :func:`faultlab.runner.run_experiment`.

    Returns
    -------
    dict
        Stage -> its RunSummary.

    Raises
    ------
    ResultsError
        ``out`` holds a study with other settings (without ``force_new``), or a stage's store is in use.
    """
    out = Path(out)
    if results_path(out).exists():  # another campaign's store: effects.json and the stages would sit beside it
        raise ResultsError(f"{out} holds the store of another campaign ({results_path(out)}), not an effects "
                           f"study; use another --out (--force-new moves only an effects study's stores aside)")
    saved = {} if force_new else _check_resume(out, eexp)
    session = {"started": time.time(), "load_start": os.getloadavg()[0], "jobs": jobs, "backend": backend,
               "cpus": os.cpu_count()}
    record = eexp.to_json() | {"kept": saved.get("kept"), "sessions": list(saved.get("sessions", []))}
    summaries: dict[str, RunSummary] = {}
    morris = stage_design(eexp, "morris")
    record["repaired"] = {"morris": morris.repaired}
    # effects.json is written once the stage's store has accepted the run: a refused run writes nothing
    summaries["morris"] = run_experiment(eexp.experiment, out / "morris", jobs=jobs, backend=backend,
                                         force_new=force_new, progress=progress, batch_size=batch_size,
                                         cases=design_cases(eexp, morris), on_start=lambda: _write_json(out, record))
    if eexp.spec.sobol_base:
        kept = screen_store(out)
        if saved.get("kept") is not None and tuple(saved["kept"]) != kept:
            raise ResultsError(f"{out}: screening now keeps {', '.join(kept)}, the Sobol stage already run kept "
                               f"{', '.join(saved['kept'])} (the Morris results changed); use --force-new")
        sobol = stage_design(eexp, "sobol", factors=kept)
        record |= {"kept": list(kept), "repaired": {"morris": morris.repaired, "sobol": sobol.repaired}}
        summaries["sobol"] = run_experiment(eexp.experiment, out / "sobol", jobs=jobs, backend=backend,
                                            force_new=force_new, progress=progress, batch_size=batch_size,
                                            cases=design_cases(eexp, sobol),
                                            on_start=lambda: _write_json(out, record))
    session |= {"finished": time.time(), "load_end": os.getloadavg()[0]}
    record["sessions"].append(session)
    _write_json(out, record)
    return summaries


def _write_json(out: Path, record: dict) -> None:
    out.mkdir(parents=True, exist_ok=True)
    tmp = out / (EFFECTS_FILE + ".tmp")
    tmp.write_text(json.dumps(record, indent=2))  # key order kept: class order of the space overrides
    tmp.replace(out / EFFECTS_FILE)

