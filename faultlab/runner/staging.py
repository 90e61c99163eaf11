"""Adaptive repetitions: run a campaign's repetitions in stages and stop decided (case, variant) pairs.

An experiment with an ``[adaptive]`` table (:class:`StagedDesign`) runs repetition ``r`` of a
(case, variant) only in the stage whose cumulative size first exceeds ``r``.  Stage 1 runs the
first ``stages[0]`` repetitions of every pair.  Before each later stage, the pairs looked at are
those still running; the rule of :mod:`faultlab.inference.sequential`
(:func:`~faultlab.inference.sequential.interim_look`) decides from their stored rows alone
whether each stops.  Jobs of the next stage are created only for pairs still running, and for
the baseline of every case with at least one such pair, repetition by repetition (common random
numbers pair repetition ``r`` of the baseline with repetition ``r`` of the variant).

Decisions depend only on stored rows of repetitions ``< stages[s-1]``, so killing and rerunning
a campaign reaches the same decisions and the same rows; the repetitions of a stage still missing
run as one :class:`~faultlab.runner.jobs.JobBatch` per pair, as without stages.  The stops are
recorded in the store's metadata under :data:`STOPS_KEY` (one entry per stopped pair: run,
suite, case, variant, the repetitions it used and why it stopped); a store without the key
(a fixed-K campaign, or one from before adaptive repetitions) used every repetition.
"""

from __future__ import annotations

from typing import Iterable, Mapping

import pandas as pd

from faultlab.inference.sequential import StagedDesign, interim_look
from faultlab.runner.store import usable_rows
from faultlab.vocabulary import BASELINE

__all__ = ["STOPS_KEY", "stage_jobs", "look_at_pairs", "look_before_stage", "record_stops"]

#: Store metadata key of the stopped pairs.
STOPS_KEY = "adaptive_stops"


def look_at_pairs(results: pd.DataFrame, *, design: StagedDesign, upto: int, metric: str) -> dict[tuple, str]:
    """The decision of every (run, suite, case, variant) from its repetitions ``< upto``.

    Parameters
    ----------
    results : DataFrame
        Stored rows (``run, suite, case, variant, rep, status`` and ``<metric>_mm``).
    design : StagedDesign
    upto : int
        Repetitions looked at: ``0 .. upto - 1``.
    metric : {"rms", "emd", "ate"}

    Returns
    -------
    dict
        ``(run, suite, case, variant) -> "continue"`` or the reason for stopping, for every
        variant but the baseline (which follows its case's variants); the A/A replica is looked at
        like a fault, its false alarms are per-case verdicts too.
    """
    col = f"{metric}_mm"
    df = results[results["rep"].to_numpy() < upto]
    df = df.assign(_usable=usable_rows(df, col))
    case_key = ["run", "suite", "case"]
    base_rows = df[df["variant"] == BASELINE]
    base = base_rows.set_index(case_key + ["rep"])
    base_all_ok = base_rows.groupby(case_key)["_usable"].agg(lambda u: bool(u.all()) and len(u) == upto)
    out = {}
    for key, g in df[df["variant"] != BASELINE].groupby(case_key + ["variant"], sort=True):
        b = base.reindex([(*key[:3], r) for r in g["rep"]])
        b_ok = b["_usable"].astype("boolean").fillna(False).to_numpy(bool)
        ok = g["_usable"].to_numpy(bool)
        baseline_failed = not bool(base_all_ok.get(key[:3], False))
        variant_failed = bool(len(g) < upto or not ok.all())
        both = ok & b_ok
        diffs = g[col].to_numpy(float)[both] - b[col].to_numpy(float)[both]
        out[key] = str(interim_look(diffs, design=design, baseline_failed=baseline_failed, variant_failed=variant_failed))
    return out


def look_before_stage(results: pd.DataFrame, *, design: StagedDesign, stage: int, metric: str,
                      running: set[tuple] | None) -> tuple[dict[tuple, str], set[tuple]]:
    """The interim look before ``stage``: decisions of the pairs still running, and those that go on.

    Parameters
    ----------
    results : DataFrame
        Stored rows; only repetitions ``< design.stages[stage - 1]`` are looked at.
    design : StagedDesign
    stage : int
        0-based stage the look precedes, ``1 <= stage < len(design.stages)``.
    metric : {"rms", "emd"}
    running : set of (run, suite, case, variant), optional
        Pairs still running after the previous look (``None`` before the first look: all); a
        pair stopped at an earlier look stays stopped.

    Returns
    -------
    (decisions, running) : (dict, set)
        ``(run, suite, case, variant) -> "continue"`` or the reason for stopping, for the pairs
        that were running; and the pairs that continue into ``stage``.
    """
    decisions = look_at_pairs(results, design=design, upto=design.stages[stage - 1], metric=metric)
    if running is not None:
        decisions = {k: d for k, d in decisions.items() if k in running}
    return decisions, {k for k, d in decisions.items() if d == "continue"}


def record_stops(decisions: Mapping[tuple, str], *, design: StagedDesign, stage: int,
                 previous: Iterable[Mapping] = ()) -> list[dict]:
    """The stopped pairs as :data:`STOPS_KEY` records them after the look before ``stage`` (1-based look).

    Parameters
    ----------
    decisions : mapping
        ``(run, suite, case, variant) -> "continue"`` or the reason for stopping
        (:func:`look_at_pairs`).
    design : StagedDesign
    stage : int
        The stage (0-based, ``>= 1``) the look precedes: a pair stopped there used
        ``design.stages[stage - 1]`` repetitions.
    previous : iterable of mapping
        Stops recorded at earlier looks (kept as they are).

    Returns
    -------
    list of dict
        One JSON-ready entry per stopped pair (``run, suite, case, variant, repetitions, reason``),
        sorted by pair.
    """
    previous = [dict(e) for e in previous]
    seen = {(e["run"], e["suite"], e["case"], e["variant"]) for e in previous}
    new = [{"run": int(k[0]), "suite": k[1], "case": int(k[2]), "variant": k[3],
            "repetitions": design.stages[stage - 1], "reason": d}
           for k, d in sorted(decisions.items()) if d != "continue" and k not in seen]
    return sorted(previous + new, key=lambda e: (e["run"], e["suite"], e["case"], e["variant"]))


def stage_jobs(specs: Iterable, *, design: StagedDesign, stage: int, running: set[tuple] | None) -> list:
    """Jobs of ``stage`` (0-based): its repetitions of the pairs still running and of their baselines.

    Parameters
    ----------
    specs : iterable of JobSpec
        All jobs of the campaign (every repetition up to ``K``).
    design : StagedDesign
    stage : int
    running : set of (run, suite, case, variant), optional
        Variants (the A/A replica included) still running (``None`` at stage 0: all).  A case's
        baseline runs while any of its variants does.
    """
    lo = design.stages[stage - 1] if stage > 0 else 0
    hi = design.stages[stage]
    cases = None if running is None else {k[:3] for k in running}
    keep = []
    for s in specs:
        k = s.key
        if not lo <= k.rep < hi:
            continue
        if running is not None:
            if k.variant == BASELINE:
                if (k.run, k.suite, k.case) not in cases:
                    continue
            elif (k.run, k.suite, k.case, k.variant) not in running:
                continue
        keep.append(s)
    return keep
