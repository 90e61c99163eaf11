"""The outcome of each faulty job under the paper's detection rule (Sec. VII-A).

The rule itself (:class:`~faultlab.metrics.detection.DetectionRule`, :func:`detects`) is
part of a campaign's configuration and lives in :mod:`faultlab.metrics.detection`.

Outcome classes (:class:`Outcome`) of one faulty job paired with its baseline
(same run, suite, case and SLAM repetition):

``baseline_failed``
    The baseline job has no usable RMS (it crashed, timed out, mapped nothing,
    or is missing from the results), so the case cannot judge the fault.  This
    takes precedence over everything else.
``crash``
    The faulty job raised, returned a malformed estimate, or finished ``ok``
    without mapping a single landmark (RMS NaN): it produced no usable map.
``timeout``
    The faulty job exceeded its wall-clock limit.
``detected`` / ``not_detected``
    Both jobs produced an RMS; the rule decides.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from faultlab.errors import ResultsError
from faultlab.metrics.detection import DetectionRule, detects
from faultlab.vocabulary import BASELINE, Outcome

__all__ = ["DetectionRule", "detects", "pair_with_baseline", "classify", "outcomes", "KEY_COLUMNS",
           "OUTCOME_COLUMNS"]

#: Columns identifying one SLAM execution apart from the variant.
KEY_COLUMNS = ("run", "suite", "case", "rep")
#: Leading columns of :func:`outcomes` (every other column of the faulty job's row follows).
OUTCOME_COLUMNS = KEY_COLUMNS + ("fault", "rms_mm", "status", "baseline_rms_mm", "baseline_status", "outcome")
_REQUIRED = KEY_COLUMNS + ("variant", "rms_mm", "status")


def _check_columns(results: pd.DataFrame, required, *, where: str) -> None:
    if not isinstance(results, pd.DataFrame):
        raise ResultsError(f"{where}: results must be a pandas DataFrame, got {type(results).__name__}")
    missing = [c for c in required if c not in results.columns]
    if missing:
        raise ResultsError(f"{where}: results lack column(s) {', '.join(missing)}")


def pair_with_baseline(results: pd.DataFrame) -> pd.DataFrame:
    """Join every faulty row with the baseline row of the same (run, suite, case, rep).

    Parameters
    ----------
    results : DataFrame
        The runner's results (one row per job, :data:`faultlab.runner.RESULT_COLUMNS`); needs
        at least ``run, suite, case, rep, variant, rms_mm, status``.

    Returns
    -------
    DataFrame
        One row per faulty job: ``run, suite, case, rep, fault, rms_mm,
        status, baseline_rms_mm, baseline_status``, followed by every other
        column of the faulty row (scenario parameters, classes, ...).  A
        missing baseline row gives ``baseline_rms_mm`` NaN and
        ``baseline_status`` ``"missing"``.

    Raises
    ------
    ResultsError
        Missing columns, or a job that appears twice (names its key).
    """
    _check_columns(results, _REQUIRED, where="pair_with_baseline")
    key = list(KEY_COLUMNS)
    dup = results.duplicated(key + ["variant"], keep=False)
    if dup.any():
        row = results.loc[dup, key + ["variant"]].iloc[0]
        raise ResultsError("pair_with_baseline: job " + ", ".join(f"{k}={row[k]}" for k in row.index)
                           + " appears more than once")
    is_base = results["variant"] == BASELINE
    base = results.loc[is_base, key + ["rms_mm", "status"]].rename(
        columns={"rms_mm": "baseline_rms_mm", "status": "baseline_status"})
    faulty = results.loc[~is_base].rename(columns={"variant": "fault"})
    pairs = faulty.merge(base, on=key, how="left", validate="many_to_one")
    pairs["baseline_status"] = pairs["baseline_status"].fillna("missing")
    first = key + ["fault", "rms_mm", "status", "baseline_rms_mm", "baseline_status"]
    rest = [c for c in pairs.columns if c not in first]
    return pairs[first + rest].reset_index(drop=True)


def classify(pairs: pd.DataFrame, *, rule: DetectionRule = DetectionRule()) -> pd.Series:
    """Outcome of every paired faulty job (see the module docstring).

    Parameters
    ----------
    pairs : DataFrame
        Output of :func:`pair_with_baseline`.
    rule : DetectionRule

    Returns
    -------
    Series of str (:class:`Outcome` values), index of ``pairs``.
    """
    _check_columns(pairs, ("rms_mm", "status", "baseline_rms_mm", "baseline_status"), where="classify")
    f = pairs["rms_mm"].to_numpy(dtype=float)
    b = pairs["baseline_rms_mm"].to_numpy(dtype=float)
    status = pairs["status"].astype(str).to_numpy()
    base_ok = (pairs["baseline_status"].astype(str).to_numpy() == "ok") & np.isfinite(b)
    unknown = sorted(set(status) - {"ok", "crash", "timeout"})
    if unknown:
        raise ResultsError(f"classify: unknown status {unknown[0]!r} (expected ok, crash or timeout)")
    out = np.where(detects(f, b, rule=rule), Outcome.DETECTED.value, Outcome.NOT_DETECTED.value).astype(object)
    out[(status == "crash") | ((status == "ok") & ~np.isfinite(f))] = Outcome.CRASH.value
    out[status == "timeout"] = Outcome.TIMEOUT.value
    out[~base_ok] = Outcome.BASELINE_FAILED.value
    return pd.Series(out, index=pairs.index, name="outcome", dtype=object)


def outcomes(results: pd.DataFrame, *, rule: DetectionRule = DetectionRule()) -> pd.DataFrame:
    """:func:`pair_with_baseline` plus an ``outcome`` column (:func:`classify`)."""
    pairs = pair_with_baseline(results)
    pairs.insert(pairs.columns.get_loc("baseline_status") + 1, "outcome", classify(pairs, rule=rule))
    return pairs
