"""Staged repetitions: when a (case, variant) may stop before its ``K`` paired repetitions.

The per-case verdict (:mod:`faultlab.stats.verdict`) is an exact sign-flip test of the ``K``
paired differences ``d_r = faulty_r - baseline_r`` with the mean as statistic.  A staged design
runs the repetitions in stages of cumulative sizes ``k_1 < k_2 < ... < k_S = K`` and, after each
stage but the last, *looks* at the ``k`` differences in hand.  This module decides, from those
alone, whether the pair may stop.

What can and cannot be decided early
------------------------------------
Write ``p_ge(d)`` for the share of the ``2^k`` sign patterns ``s`` of ``d`` with
``sum(s d) >= sum(d)`` (the one-sided "greater" p value) and ``p_le(d) = p_ge(-d)``.  Let
``f = K - k`` pairs remain.

* **Rejection is never determined early** (no efficacy curtailment).  Whatever the first ``k``
  differences, a remaining difference of large negative value drives the final one-sided p value
  to at least 1/2; the mean has no bound on what one future pair contributes.
* **Non-rejection can be** (futility curtailment).  The patterns that leave the ``f`` future signs
  ``+`` and give the first ``k`` a sum at least the observed one have a total sum at least the
  observed total *whatever the future values*, so the final p value satisfies
  ``P_ge >= p_ge(d) 2^-f`` (and this bound is attained when the future values are positive and
  large).  Likewise ``P_le >= p_le(d) 2^-f``.  For the two-sided test, both
  ``min(1, 2 min(P_ge, P_le))`` and the ``|mean|`` statistic's p value are at least
  ``min(1, 2 min(p_ge(d), p_le(d)) 2^-f)``: when the final sum is ``>= 0``, the patterns with future signs
  ``+`` and first-part sum ``>= sum(d)`` and their negations with future signs ``-`` and
  first-part sum ``<= -sum(d)`` (disjoint, equally many) all have ``|sum|`` at least the
  observed one; symmetrically when it is negative.  :func:`smallest_final_p` returns this bound.
  If it exceeds the per-case level, the fixed-``K`` test cannot reject: stopping changes no test
  decision, and the level is exactly the fixed-``K`` test's.

Because of ``2^-f``, curtailment acts only late (with ``K = 10`` after 5 pairs it needs
``p > 32 level``: never at level 0.05).  The design therefore adds a **non-binding futility
bound** ``gamma``: the pair stops at an interim look when the interim p value in the tested
direction (``p_ge``, ``p_le``, or ``min(1, 2 min(p_ge, p_le))`` two-sided) exceeds ``gamma``.

The rule and its level
----------------------
At an interim look with ``k < K`` usable pairs, **stop** if

1. ``smallest_final_p(d, K) > level`` (curtailment: the final decision is already "not
   rejected"), or
2. the interim p value in the tested direction exceeds ``gamma`` (futility);

otherwise **continue**.  After the last stage the fixed-``K`` test decides at ``level``.  The
rule only ever stops *without* rejecting, so its rejection region is a subset of the fixed-``K``
test's: under the null (each ``d_r`` symmetric about 0 given ``|d_r|``) its level, conditional
on the magnitudes and hence overall, is at most the fixed-``K`` level, itself at most ``level``
-- whatever ``gamma``, the stages and the sidedness.  (``tests/stats/test_sequential.py`` checks
this by enumerating all ``2^K`` sign patterns of drawn magnitudes.)  With ``gamma = 1`` only
curtailment stops and every decision equals the fixed-``K`` one.  A futility stop can turn a
would-be rejection into a non-rejection (a power loss, never a level increase): it needs an
interim p above ``gamma`` followed by ``f`` future differences strong enough to bring the final
p value to ``level``.  Measured by simulation (4000 draws, ``SeedSequence(2026)``) for ``K = 10``,
stages (5, 10), level 0.05, one-sided, ``gamma = 0.5``, differences ``N(delta, 1)``:

=======  ===========  ============  ====================  ===========================
delta    power fixed  power staged  pairs stopped at 5   rejections lost by stopping
=======  ===========  ============  ====================  ===========================
0        0.052        0.051         50 %                  0.05 %
0.3      0.215        0.213         26 %                  0.13 %
0.6      0.557        0.554         8.8 %                 0.25 %
1.0      0.892        0.891         1.3 %                 0.15 %
=======  ===========  ============  ====================  ===========================

(``gamma = 0.3`` stops 72 % of null pairs but loses 3.4 % power at ``delta = 0.6``.)

Outside the test: the per-case verdict also says ``cannot_judge`` when the baseline fails in any
repetition (determined as soon as it happens: such a pair stops) and ``crash_detected`` when the
faulty variant fails with the baseline intact (not determined: a later baseline failure would
turn it into ``cannot_judge``, so such a pair continues).  A pair stopped for futility forgoes
observing a crash of the faulty variant in its later repetitions; :mod:`faultlab.runner.staging`
records every stop so that reports can say how many repetitions each pair used.
"""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass
from enum import StrEnum
from typing import Mapping

import numpy as np

from faultlab.errors import ConfigError
from faultlab.inference.exact import MAX_EXACT_PAIRS, check_alternative, min_p_value, sign_flip_pvalues
from faultlab.vocabulary import DEFAULT_ALPHA

__all__ = ["StagedDesign", "Look", "interim_p", "smallest_final_p", "interim_look"]


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
    level: float = DEFAULT_ALPHA
    alternative: str = "two-sided"
    futility: float = 0.5

    def __post_init__(self):
        stages = tuple(self.stages)
        if (not stages or any(isinstance(k, bool) or not isinstance(k, numbers.Integral) for k in stages)
                or stages[0] < 1 or any(b <= a for a, b in zip(stages, stages[1:]))):
            raise ConfigError(f"stages must be strictly increasing integers >= 1, got {list(self.stages)!r}")
        object.__setattr__(self, "stages", tuple(int(k) for k in stages))
        if isinstance(self.level, bool) or not isinstance(self.level, numbers.Real) or not 0 < self.level < 1:
            raise ConfigError(f"level must lie in (0, 1), got {self.level!r}")
        check_alternative(self.alternative, "adaptive")
        if (isinstance(self.futility, bool) or not isinstance(self.futility, numbers.Real)
                or not self.level <= self.futility <= 1):
            raise ConfigError(f"futility must lie in [level, 1] = [{self.level:g}, 1], got {self.futility!r}")

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
            design = cls(stages=tuple(table["stages"]), level=table.get("level", DEFAULT_ALPHA),
                         alternative=table.get("alternative", "two-sided"), futility=table.get("futility", 0.5))
        except ConfigError as exc:
            raise ConfigError(f"{where}: {exc}") from None
        first = design.stages[0]
        if len(design.stages) > 1 and min_p_value(first, alternative=design.alternative) > design.futility:
            # a valid rule (it only loses power), but one that can detect nothing: a configuration mistake
            raise ConfigError(
                f"{where}: stages: a first stage of {first} repetitions stops every pair at the first look "
                f"whatever its data: the smallest {design.alternative} sign-flip p value of {first} pairs, "
                f"{min_p_value(first, alternative=design.alternative):g}, exceeds futility = {design.futility:g}; start with more "
                f"repetitions or raise futility")
        return design


class Look(StrEnum):
    """What an interim look decides for one (case, variant)."""

    CONTINUE = "continue"
    BASELINE_FAILED = "baseline_failed"   #: verdict cannot_judge, whatever follows
    CURTAILED = "curtailed"               #: the fixed-K test can no longer reject
    FUTILE = "futile"                     #: interim p value above the futility bound


def _one_sided(differences) -> tuple[float, float]:
    d = np.asarray(differences, dtype=float).ravel()
    if d.size == 0:
        return 1.0, 1.0
    return float(sign_flip_pvalues(d)), float(sign_flip_pvalues(-d))


def interim_p(differences, *, alternative: str = "greater") -> float:
    """Exact sign-flip p value of the differences in hand, in the tested direction.

    Parameters
    ----------
    differences : array_like, shape (k,)
        Paired differences (variant - baseline), finite; ``k = 0`` gives 1.
    alternative : {"greater", "less", "two-sided"}
        Two-sided: ``min(1, 2 min(p_ge, p_le))``.

    Returns
    -------
    float
    """
    check_alternative(alternative, "interim_p")
    ge, le = _one_sided(differences)
    if alternative == "greater":
        return ge
    if alternative == "less":
        return le
    return min(1.0, 2.0 * min(ge, le))


def smallest_final_p(differences, *, total: int, alternative: str = "greater") -> float:
    """Smallest p value the test on ``total`` pairs can reach, whatever the remaining differences.

    Parameters
    ----------
    differences : array_like, shape (k,)
        The first ``k <= total`` paired differences.
    total : int
        ``K``, the pairs of the final test.
    alternative : {"greater", "less", "two-sided"}

    Returns
    -------
    float
        ``p_ge 2^-f`` ("greater"), ``p_le 2^-f`` ("less") or ``min(1, 2 min(p_ge, p_le) 2^-f)``
        ("two-sided"), ``f = total - k`` (derivation in the module docstring); the bound is
        attained by large future differences in the favoured direction.
    """
    d = np.asarray(differences, dtype=float).ravel()
    if isinstance(total, bool) or not isinstance(total, numbers.Integral) or not d.size <= total:
        raise ConfigError(f"smallest_final_p: total must be an integer >= {d.size} (the pairs in hand), "
                          f"got {total!r}")
    shrink = math.ldexp(1.0, -(int(total) - d.size))
    if alternative == "two-sided":
        ge, le = _one_sided(d)
        return min(1.0, 2.0 * min(ge, le) * shrink)
    return interim_p(d, alternative=alternative) * shrink


def interim_look(differences, *, design: StagedDesign, baseline_failed: bool = False,
                 variant_failed: bool = False) -> Look:
    """The rule of the module docstring at one interim look of one (case, variant).

    Parameters
    ----------
    differences : array_like, shape (k,)
        Usable paired differences so far, ``k < design.total``.
    design : StagedDesign
        Stages, per-case level, sidedness and futility bound.
    baseline_failed : bool
        The baseline failed in a repetition looked at (the verdict is ``cannot_judge``).
    variant_failed : bool
        The variant failed in a repetition looked at while the baseline did not (the verdict is
        ``crash_detected`` unless a later baseline failure makes it ``cannot_judge``).

    Returns
    -------
    Look
    """
    if design.total > MAX_EXACT_PAIRS:
        raise ConfigError(f"interim_look: the exact test is limited to {MAX_EXACT_PAIRS} pairs, got "
                          f"K = {design.total}")
    if baseline_failed:
        return Look.BASELINE_FAILED
    if variant_failed:
        return Look.CONTINUE
    if smallest_final_p(differences, total=design.total, alternative=design.alternative) > design.level:
        return Look.CURTAILED
    if design.futility < 1 and interim_p(differences, alternative=design.alternative) > design.futility:
        return Look.FUTILE
    return Look.CONTINUE
