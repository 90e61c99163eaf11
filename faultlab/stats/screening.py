"""An effects study's stored stages read back: its record, each stage's design and responses, screening.

:func:`faultlab.campaigns.effects.run_effects` writes ``OUT/effects.json`` and one store per stage
(``morris``, ``sobol``).  The campaign screens the finished Morris stage before it runs the Sobol
stage (:func:`screen_store`), and the analysis (:mod:`faultlab.analysis.effects`) estimates every
index; both read the stages with the functions here, so the campaign and its analysis rebuild the
same design and the same responses.  Screening keeps, for the difficulty and every effect response
(detection, a coarse 0-1 share, does not steer it), the ``keep`` factors with the largest Morris
``mu*`` (:func:`faultlab.inference.screening.screen`).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

from faultlab.errors import FaultlabError, ResultsError
from faultlab.inference.screening import morris_indices, screen
from faultlab.runner.store import load_metadata, load_results, load_sessions
from faultlab.seeds import stable_code
from faultlab.space.case import VALUE_KEYS
from faultlab.space.design import Design, study_design
from faultlab.space.parameters import space_from_mapping, table1_space
from faultlab.stats.metadata import read_rule
from faultlab.stats.responses import CASE_KEY, DIFFICULTY, case_responses, rep_values
from faultlab.vocabulary import EFFECTS_FILE

__all__ = ["screening_responses", "stage_responses", "read_effects_json", "saved_design", "check_design",
           "screen_store", "response_seed"]


def screening_responses(responses: Sequence[str]) -> list[str]:
    """The responses that steer screening: the difficulty and the effect sizes."""
    return [r for r in responses if r == DIFFICULTY or r.startswith("effect:")]


def stage_responses(store: str | Path) -> tuple[pd.DataFrame, pd.DataFrame, pd.DataFrame, dict]:
    """Case responses (wide: one column per response, std errors ``se:<response>``), repetition values,
    the cases' parameter values and the store metadata of one stage."""
    meta = load_metadata(store)
    results = load_results(store)
    rule, _ = read_rule(meta)
    metric = str(meta.get("metric", "rms"))
    long = case_responses(results, metric=metric, rule=rule)
    key = list(CASE_KEY)
    wide = long.pivot_table(index=key, columns="response", values="value", sort=False, dropna=False)
    se = long.pivot_table(index=key, columns="response", values="std_err", sort=False, dropna=False)
    se.columns = [f"se:{c}" for c in se.columns]
    order = list(dict.fromkeys(long["response"]))
    wide = wide[order].join(se).reset_index().sort_values("case", kind="mergesort").reset_index(drop=True)
    cols = key + [c for c in results.columns if c in VALUE_KEYS or c.startswith("class_") or c == "n_landmarks"]
    cases = results.drop_duplicates(key).sort_values("case", kind="mergesort")[cols].reset_index(drop=True)
    return wide, rep_values(results, metric=metric), cases, meta


def read_effects_json(out: str | Path) -> dict:
    """``OUT/effects.json``, written by :func:`faultlab.campaigns.effects.run_effects` (ResultsError if
    missing or damaged)."""
    path = Path(out) / EFFECTS_FILE
    try:
        saved = json.loads(path.read_text())
    except FileNotFoundError:
        raise ResultsError(f"{out}: not an effects study output (no {EFFECTS_FILE}); run `faultlab effects run`"
                           ) from None
    except (OSError, ValueError) as exc:
        raise ResultsError(f"{path}: cannot be read ({exc})") from exc
    if not isinstance(saved, dict) or not isinstance(saved.get("effects"), dict):
        raise ResultsError(f"{path}: not an effects study record (no 'effects' settings)")
    return saved


def saved_design(saved: dict, stage: str) -> Design:
    """The design of ``stage`` rebuilt from the study's record (the same call the campaign made)."""
    s = saved["effects"]
    try:
        space = space_from_mapping(saved["space"], source=f"{EFFECTS_FILE} [space]") if saved.get("space") \
            else table1_space()
        factors = s["factors"] if stage == "morris" else saved.get("kept")
        return study_design(space, stage, seed=int(s["seed"]), trajectories=int(s["trajectories"]),
                            levels=int(s["levels"]), base=int(s["sobol_base"]), factors=factors)
    except (KeyError, TypeError, ValueError, FaultlabError) as exc:
        raise ResultsError(f"{EFFECTS_FILE}: cannot rebuild the {stage} design from the study's record ({exc})"
                           ) from exc


def check_design(store: Path, design: Design) -> None:
    """The store holds every case of the design, and its last run ended: every job of every case is in it.

    Counting cases is not enough: a run killed after each case had one of its jobs stored holds
    every case, but not every variant and repetition of them.
    """
    sessions = load_sessions(store)
    if not sessions or sessions[-1]["state"] != "complete":
        state = sessions[-1]["state"] if sessions else "never run"
        raise ResultsError(f"{store}: its last run is {state} (the run is unfinished: rerun "
                           "`faultlab effects run` to resume)")
    results = load_results(store)
    got = results.drop_duplicates(list(CASE_KEY)).sort_values("case", kind="mergesort")
    if len(got) != design.n_points:
        raise ResultsError(f"{store}: {len(got)} cases stored, the {design.method} design has {design.n_points} "
                           f"(the run is unfinished: rerun `faultlab effects run` to resume)")


def screen_store(out: str | Path) -> tuple[str, ...]:
    """The factors screening keeps from a study's finished Morris store (module docstring)."""
    out = Path(out)
    saved = read_effects_json(out)
    design = saved_design(saved, "morris")
    store = out / "morris"
    check_design(store, design)
    wide, _, _, _ = stage_responses(store)
    spec = saved["effects"]
    tables = []
    for r in screening_responses([c for c in wide.columns if not c.startswith("se:") and c not in CASE_KEY]):
        y = wide[r].to_numpy(dtype=float)
        if not np.isfinite(y).all() or not np.ptp(y) > 0:
            continue
        tables.append(morris_indices(design.unit, y, factors=design.factors, levels=design.levels,
                                     seed=response_seed(spec, "morris", r), resamples=int(spec["resamples"])))
    if not tables:
        raise ResultsError(f"{store}: no response varies over the Morris design; nothing to screen")
    return screen(tables, keep=int(spec["keep"]))


def response_seed(spec: dict, stage: str, response: str) -> int:
    return int(np.random.SeedSequence(int(spec["seed"]), spawn_key=(stable_code(stage), stable_code(response)))
               .generate_state(1, np.uint32)[0])
