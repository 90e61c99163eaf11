"""Adaptive repetitions: run a campaign's repetitions in stages and stop decided (case, variant) pairs.

An experiment with an ``[adaptive]`` table (:class:`StagedDesign`) runs repetition ``r`` of a
(case, variant) only in the stage whose cumulative size first exceeds ``r``.  Stage 1 runs the
first ``stages[0]`` repetitions of every pair.  Before each later stage, the pairs looked at are
those still running; a *look* function (the rule of :mod:`faultlab.inference.sequential`, passed in
by the caller because statistics sit above the runner) decides from their stored rows alone
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

import numbers
from dataclasses import dataclass
from typing import Callable, Iterable, Mapping

import numpy as np
import pandas as pd

from faultlab.errors import ConfigError
from faultlab.vocabulary import BASELINE, JobStatus

__all__ = ["StagedDesign", "STOPS_KEY", "ALTERNATIVES", "LookRule", "stage_jobs", "look_at_pairs", "look_before_stage",
           "record_stops"]

#: Store metadata key of the stopped pairs.
STOPS_KEY = "adaptive_stops"
#: Sidedness of the per-case test, as scipy names it.
ALTERNATIVES = ("greater", "less", "two-sided")

#: ``look(differences, *, design, baseline_failed, variant_failed) -> str``: "continue" or the
#: reason for stopping (see :func:`faultlab.inference.sequential.interim_look`).
LookRule = Callable[..., str]


@dataclass(frozen=True)
class StagedDesign:
    """Stages, level, sidedness and futility bound of adaptive repetitions (``[adaptive]`` table).

    Attributes
    ----------
    stages : tuple of int
        Cumulative repetitions after each stage, strictly increasing, ``>= 1``; the last is the
        experiment's ``repetitions`` (``K``).
    level : float
        Level of each per-case test, in (0, 1).  Under Holm's procedure over a family of ``n``
        cases a case can be rejected at any threshold from ``alpha / n`` (first step) to
        ``alpha`` (last), so ``level = alpha`` keeps curtailment exact for every step;
        ``alpha / n`` curtails more but may stop a case a later Holm step would have rejected.
    alternative : {"greater", "less", "two-sided"}
        Sidedness of the per-case test.
    futility : float
        Non-binding futility bound in [level, 1]; 1 stops only pairs whose fixed-K test can no
        longer reject (:mod:`faultlab.inference.sequential` states the rule and its level).
    """

    stages: tuple[int, ...]
    level: float = 0.05
    alternative: str = "greater"
    futility: float = 0.5

    def __post_init__(self):
        stages = tuple(self.stages)
        if (not stages or any(isinstance(k, bool) or not isinstance(k, numbers.Integral) for k in stages)
                or stages[0] < 1 or any(b <= a for a, b in zip(stages, stages[1:]))):
            raise ConfigError(f"stages must be strictly increasing integers >= 1, got {list(self.stages)!r}")
        object.__setattr__(self, "stages", tuple(int(k) for k in stages))
        if isinstance(self.level, bool) or not isinstance(self.level, numbers.Real) or not 0 < self.level < 1:
            raise ConfigError(f"level must lie in (0, 1), got {self.level!r}")
        if self.alternative not in ALTERNATIVES:
            raise ConfigError(f"alternative must be one of {', '.join(map(repr, ALTERNATIVES))}, "
                              f"got {self.alternative!r}")
        if (isinstance(self.futility, bool) or not isinstance(self.futility, numbers.Real)
                or not self.level <= self.futility <= 1):
            raise ConfigError(f"futility must lie in [level, 1] = [{self.level:g}, 1], got {self.futility!r}")

    def smallest_interim_p(self, k: int) -> float:
        """The smallest p value the interim look's exact sign-flip test reaches on ``k`` pairs: ``2^-k``
        one-sided, ``min(1, 2^(1-k))`` two-sided (every difference of one sign).  The same as
        :func:`faultlab.inference.exact.min_p_value`, which the runner, below the statistics, cannot import
        (a test keeps them equal)."""
        return min(1.0, 2.0 ** (1 - k)) if self.alternative == "two-sided" else 2.0 ** -k

    @property
    def total(self) -> int:
        """``K``: the repetitions of a pair that never stops."""
        return self.stages[-1]

    def to_dict(self) -> dict:
        return {"stages": list(self.stages), "level": self.level, "alternative": self.alternative,
                "futility": self.futility}

    @classmethod
    def from_mapping(cls, table: Mapping, *, where: str) -> "StagedDesign":
        unknown = sorted(set(table) - {"stages", "level", "alternative", "futility"})
        if unknown:
            raise ConfigError(f"{where}: unknown key {unknown[0]!r} (keys: stages, level, alternative, futility)")
        if "stages" not in table or not isinstance(table["stages"], (list, tuple)):
            raise ConfigError(f"{where}: stages must be a list of cumulative repetitions, e.g. [5, 10]")
        try:
            design = cls(stages=tuple(table["stages"]), level=table.get("level", 0.05),
                         alternative=table.get("alternative", "greater"), futility=table.get("futility", 0.5))
        except ConfigError as exc:
            raise ConfigError(f"{where}: {exc}") from None
        first = design.stages[0]
        if len(design.stages) > 1 and design.smallest_interim_p(first) > design.futility:
            # a valid rule (it only loses power), but one that can detect nothing: a configuration mistake
            raise ConfigError(
                f"{where}: stages: a first stage of {first} repetitions stops every pair at the first look "
                f"whatever its data: the smallest {design.alternative} sign-flip p value of {first} pairs, "
                f"{design.smallest_interim_p(first):g}, exceeds futility = {design.futility:g}; start with more "
                f"repetitions or raise futility")
        return design


def _usable(frame: pd.DataFrame, col: str) -> np.ndarray:
    return ((frame["status"] == JobStatus.OK.value) & np.isfinite(frame[col].to_numpy(float))).to_numpy(bool)


def look_at_pairs(results: pd.DataFrame, *, design: StagedDesign, upto: int, metric: str,
                  look: LookRule) -> dict[tuple, str]:
    """The decision of every (run, suite, case, variant) from its repetitions ``< upto``.

    Parameters
    ----------
    results : DataFrame
        Stored rows (``run, suite, case, variant, rep, status`` and ``<metric>_mm``).
    design : StagedDesign
    upto : int
        Repetitions looked at: ``0 .. upto - 1``.
    metric : {"rms", "emd", "ate"}
    look : callable
        The rule (:func:`faultlab.inference.sequential.interim_look`).

    Returns
    -------
    dict
        ``(run, suite, case, variant) -> "continue"`` or the reason for stopping, for every
        variant but the baseline (which follows its case's variants); the A/A replica is looked at
        like a fault, its false alarms are per-case verdicts too.
    """
    col = f"{metric}_mm"
    df = results[results["rep"].to_numpy() < upto]
    df = df.assign(_usable=_usable(df, col))
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
        out[key] = str(look(diffs, design=design, baseline_failed=baseline_failed, variant_failed=variant_failed))
    return out


def look_before_stage(results: pd.DataFrame, *, design: StagedDesign, stage: int, metric: str, look: LookRule,
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
    look : callable
        The rule (:func:`faultlab.inference.sequential.interim_look`).
    running : set of (run, suite, case, variant), optional
        Pairs still running after the previous look (``None`` before the first look: all); a
        pair stopped at an earlier look stays stopped.

    Returns
    -------
    (decisions, running) : (dict, set)
        ``(run, suite, case, variant) -> "continue"`` or the reason for stopping, for the pairs
        that were running; and the pairs that continue into ``stage``.
    """
    decisions = look_at_pairs(results, design=design, upto=design.stages[stage - 1], metric=metric, look=look)
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
