"""Calibration of the detection rules from an A/A store: how often each flags the unmodified SLAM.

The store of :func:`faultlab.campaigns.calibrate.calibrate` holds the variants ``baseline`` and
``baseline_replica`` (the unmodified SLAM twice, independent SLAM seeds).  Every "detection" of
the replica is a false alarm, so the :class:`~faultlab.analysis.Analysis` table
``replica_false_alarms`` is the empirical false-alarm rate of each rule per suite, with an
interval clustered by case.  The statistical rule is calibrated when its rate is at most
``alpha``, i.e. the interval's lower bound lies below ``alpha`` (the data do not show a rate
above ``alpha``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from faultlab.analysis.result import Analysis, analyse
from faultlab.vocabulary import BASELINE, REPLICA

__all__ = ["Calibration", "assess_calibration"]


@dataclass(frozen=True)
class Calibration:
    """The false-alarm rates of an A/A store.

    Attributes
    ----------
    analysis : Analysis
        The store's analysis (its ``replica_false_alarms`` table is the calibration).
    repetitions : int
        K of the A/A campaign.
    calibrated : bool
        Whether the statistical rule's false-alarm rate is at most alpha in every suite (its
        interval's lower bound below alpha); False when nothing could be judged.
    """

    analysis: Analysis
    repetitions: int
    calibrated: bool

    @property
    def table(self) -> pd.DataFrame:
        """Per rule and suite: the empirical false-alarm rate with its clustered interval."""
        return self.analysis.replica_false_alarms

    def __str__(self) -> str:
        alpha = self.analysis.rule.alpha
        conf = round(100 * (1 - self.analysis.alpha))
        lines = [f"A/A false alarms ({REPLICA} vs {BASELINE}, K = {self.repetitions}; "
                 f"{conf} % interval clustered by case):"]
        for r in self.table.itertuples(index=False):
            unit = "repetition pairs" if r.rule == "paper" else "cases"
            rate = "n/a" if math.isnan(r.rate) else f"{100 * r.rate:.1f} % [{100 * r.low:.1f}, {100 * r.high:.1f}]"
            lines.append(f"  {r.rule:<11} {r.suite:<10} {r.flagged:>4}/{r.n_pairs:<5} {unit:<16} {rate}")
        verdict = "holds" if self.calibrated else "does NOT hold"
        lines.append(f"statistical rule: false-alarm rate <= alpha = {alpha:g} {verdict} "
                     f"(lower bound of every suite's interval below alpha)")
        return "\n".join(lines)


def assess_calibration(out: str | Path) -> Calibration:
    """The :class:`Calibration` of the A/A store in ``out`` (runs nothing)."""
    result = analyse(out, paper=False)
    stat = result.replica_false_alarms
    stat = stat[(stat["rule"] == "statistical") & (stat["n_pairs"] > 0)]
    calibrated = bool(len(stat)) and bool((stat["low"] < result.rule.alpha).all())
    return Calibration(analysis=result, repetitions=result.n_reps, calibrated=calibrated)
