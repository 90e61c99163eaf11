"""Calibration of the statistical rule on an A/A campaign: false-alarm rates that can fail a check.

The A/A control ``baseline_replica`` is the unmodified SLAM with SLAM seeds independent of the
baseline's, so every case on which the statistical rule flags it is a false alarm.  The case is
the unit (one verdict per case from its K repetitions; cases are drawn independently), so a rate
over cases has an exact Clopper-Pearson interval (:func:`faultlab.inference.intervals.clopper_pearson`).

Two rates (:func:`false_alarm_rates`):

``per_case``
    cases whose *unadjusted* p value is at most ``alpha`` / judged cases: the per-test level the
    rule promises (at most ``alpha``); the quantity the check judges.
``family_wise``
    cases flagged after Holm within the rule's multiplicity family (what a report of the
    campaign shows) / judged cases: much smaller than ``alpha`` by design, so it cannot check
    the level -- reported beside it, never instead of it.

The check (:func:`check_calibration`), on the ``per_case`` rate over all suites:

``miscalibrated``
    the interval's lower bound lies above ``alpha``: the rule rejects too often (the command fails);
``underpowered``
    not miscalibrated, but the interval's upper bound is at least ``2 alpha``: the campaign has too
    few cases to exclude a rate of twice the level (with no false alarm at all, ``n >= 36`` cases
    are needed at ``alpha = 0.05``);
``calibrated``
    the interval includes a value at most ``alpha`` and excludes ``2 alpha``;
``nothing_judged``
    no case could be judged.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
import pandas as pd

from faultlab.errors import ConfigError
from faultlab.inference.intervals import clopper_pearson
from faultlab.vocabulary import DEFAULT_ALPHA, SUITE_ORDER, ordered

__all__ = ["CalibrationStatus", "CalibrationCheck", "CALIBRATION_COLUMNS", "false_alarm_rates",
           "check_calibration"]

#: Columns of :func:`false_alarm_rates`.
CALIBRATION_COLUMNS: tuple[str, ...] = ("scope", "suite", "k", "n", "rate", "cp_low", "cp_high")


class CalibrationStatus(StrEnum):
    """Outcome of :func:`check_calibration`."""

    CALIBRATED = "calibrated"
    MISCALIBRATED = "miscalibrated"
    UNDERPOWERED = "underpowered"
    NOTHING_JUDGED = "nothing_judged"


@dataclass(frozen=True)
class CalibrationCheck:
    """The check's status, its one-line reason, and the rate it judged."""

    status: CalibrationStatus
    reason: str
    k: int
    n: int
    cp_low: float
    cp_high: float

    @property
    def failed(self) -> bool:
        """Whether the command must fail (miscalibrated, or nothing to judge)."""
        return self.status in (CalibrationStatus.MISCALIBRATED, CalibrationStatus.NOTHING_JUDGED)


def false_alarm_rates(verdicts: pd.DataFrame, *, alpha: float, ci_alpha: float = DEFAULT_ALPHA) -> pd.DataFrame:
    """Per-case and family-wise A/A false-alarm rates of the statistical rule, per suite and ``"all"``.

    Parameters
    ----------
    verdicts : DataFrame
        :func:`faultlab.stats.cases.rule_verdicts` rows of the A/A control (statistical rule):
        ``suite, p, p_holm``; rows without a p value (not judged) are left out.
    alpha : float
        The rule's level.
    ci_alpha : float
        1 - confidence level of the Clopper-Pearson intervals.

    Returns
    -------
    DataFrame
        :data:`CALIBRATION_COLUMNS`, scopes ``per_case`` then ``family_wise``.
    """
    if not 0 < alpha < 1:
        raise ConfigError(f"false_alarm_rates: alpha must lie in (0, 1), got {alpha!r}")
    v = verdicts[pd.to_numeric(verdicts["p"], errors="coerce").notna()]
    rows = []
    for scope, column in (("per_case", "p"), ("family_wise", "p_holm")):
        flagged = v[column].to_numpy(float) <= alpha
        for suite in ordered(v["suite"].unique(), SUITE_ORDER) + ["all"]:
            sel = np.ones(len(v), bool) if suite == "all" else (v["suite"] == suite).to_numpy()
            k, n = int(flagged[sel].sum()), int(sel.sum())
            lo, hi = clopper_pearson(k, n, alpha=ci_alpha)
            rows.append({"scope": scope, "suite": suite, "k": k, "n": n, "rate": k / n if n else math.nan,
                         "cp_low": lo, "cp_high": hi})
    return pd.DataFrame(rows, columns=list(CALIBRATION_COLUMNS))


def check_calibration(rates: pd.DataFrame, *, alpha: float) -> CalibrationCheck:
    """Judge the ``per_case`` rate over all suites against ``alpha`` (module docstring)."""
    row = rates[(rates["scope"] == "per_case") & (rates["suite"] == "all")]
    if row.empty or int(row["n"].iloc[0]) == 0:
        return CalibrationCheck(CalibrationStatus.NOTHING_JUDGED, "no case of the A/A control could be judged",
                                0, 0, math.nan, math.nan)
    r = row.iloc[0]
    k, n, lo, hi = int(r["k"]), int(r["n"]), float(r["cp_low"]), float(r["cp_high"])
    what = f"{k}/{n} cases flagged at alpha = {alpha:g} (unadjusted), Clopper-Pearson {100 * lo:.1f}-{100 * hi:.1f} %"
    if lo > alpha:
        return CalibrationCheck(CalibrationStatus.MISCALIBRATED,
                                f"miscalibrated: {what}; the lower bound exceeds alpha, the rule rejects too often",
                                k, n, lo, hi)
    if hi >= 2 * alpha:
        return CalibrationCheck(CalibrationStatus.UNDERPOWERED,
                                f"underpowered calibration: {what}; the upper bound does not exclude 2 alpha = "
                                f"{2 * alpha:g} -- run more cases", k, n, lo, hi)
    return CalibrationCheck(CalibrationStatus.CALIBRATED,
                            f"calibrated: {what}; includes a rate <= alpha and excludes 2 alpha", k, n, lo, hi)
