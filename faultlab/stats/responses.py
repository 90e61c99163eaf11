"""Continuous responses per test case for effect studies, from repetitions with common random numbers.

A binary detected / not detected outcome over a few cases is 0 or 1 almost everywhere for the
paper's faults, so it cannot say which parameter matters.  An effect study uses continuous
responses, one value per case (the unit of evidence), each with its uncertainty from the case's
``K`` SLAM repetitions:

``difficulty``
    The baseline's difficulty: the mean over repetitions of ``log(e_b)``, ``e_b`` the baseline's
    map error (mm, the campaign's metric).
``effect:<fault>``
    The fault's effect size: the mean over repetitions of ``log(e_f / e_b)``, the faulty and the
    baseline error of the *same* repetition (same SLAM seed: common random numbers), so the SLAM's
    own noise largely cancels.  ``log 2`` means the fault doubles the error.
``detection:<fault>``
    The share of the case's judged repetitions in which the campaign's detection rule detects the
    fault (:func:`faultlab.stats.outcomes`; a crash of the faulty SLAM counts as detected, a
    timeout is left out, as it measures the machine's load as much as the fault): a secondary,
    coarser response.

The per-case uncertainty is the standard error of the mean over repetitions
(``sd / sqrt(K)``, ``ddof = 1``; NaN for ``K = 1``).  A repetition whose baseline failed (crash,
timeout, no map) is left out of every response of the case.  A faulty repetition that crashed or
timed out has no error to compare: its log ratio is set to the largest finite log ratio of that
fault over the whole study (a failure counts as at least as bad as the worst map seen), and
:data:`RESPONSE_COLUMNS` ``n_failed`` counts such repetitions.  A case with no usable repetition
has NaN responses.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from faultlab.errors import ResultsError
from faultlab.metrics.detection import DetectionRule
from faultlab.stats.detection import outcomes
from faultlab.vocabulary import BASELINE, JobStatus, Outcome

__all__ = ["case_responses", "rep_values", "DIFFICULTY", "effect_response", "detection_response", "RESPONSE_COLUMNS",
           "CASE_KEY"]

#: Name of the baseline difficulty response.
DIFFICULTY = "difficulty"
#: Columns identifying a case.
CASE_KEY: tuple[str, ...] = ("run", "suite", "case")
#: Columns of :func:`case_responses` (after the case key).
RESPONSE_COLUMNS: tuple[str, ...] = ("response", "value", "std_err", "n_reps", "n_failed")


def effect_response(fault: str) -> str:
    """Name of a fault's effect-size response."""
    return f"effect:{fault}"


def detection_response(fault: str) -> str:
    """Name of a fault's detection-probability response."""
    return f"detection:{fault}"


def _summary(group: pd.Series) -> tuple[float, float, int]:
    x = group.to_numpy(dtype=float)
    x = x[np.isfinite(x)]
    n = x.size
    if n == 0:
        return np.nan, np.nan, 0
    return float(x.mean()), float(x.std(ddof=1) / np.sqrt(n)) if n > 1 else np.nan, n


def rep_values(results: pd.DataFrame, *, metric: str = "rms") -> pd.DataFrame:
    """The difficulty and effect responses of every repetition (before averaging over a case).

    Returns
    -------
    DataFrame
        Columns ``run, suite, case, rep, response, value, failed``: ``log(e_b)`` for
        ``difficulty``, ``log(e_f / e_b)`` for ``effect:<fault>`` (a failed faulty repetition set to
        the fault's largest finite log ratio, ``failed`` True); repetitions whose baseline failed
        are left out.

    Raises
    ------
    ResultsError
        Missing columns or no baseline rows.
    """
    col = f"{metric}_mm"
    need = list(CASE_KEY) + ["variant", "rep", "status", col]
    missing = [c for c in need if c not in results.columns]
    if missing:
        raise ResultsError(f"case_responses: results lack column(s) {', '.join(missing)}")
    key = list(CASE_KEY) + ["rep"]
    base = results[results["variant"] == BASELINE]
    if base.empty:
        raise ResultsError("case_responses: no baseline rows (an effect study needs the baseline variant)")
    err = pd.to_numeric(base[col], errors="coerce")
    ok = (base["status"] == JobStatus.OK.value) & np.isfinite(err) & (err > 0)
    base = base.loc[ok, key].assign(log_b=np.log(err[ok].to_numpy(dtype=float)))
    frames = [base.assign(response=DIFFICULTY, value=base["log_b"], failed=False)]
    for fault in [v for v in pd.unique(results["variant"]) if v != BASELINE]:
        m = results[results["variant"] == fault][key + ["status", col]].merge(base, on=key, how="inner")
        e = pd.to_numeric(m[col], errors="coerce").to_numpy(dtype=float)
        good = (m["status"] == JobStatus.OK.value).to_numpy() & np.isfinite(e) & (e > 0)
        ratio = np.full(len(m), np.nan)
        ratio[good] = np.log(e[good]) - m["log_b"].to_numpy()[good]
        worst = np.max(ratio[good]) if good.any() else np.nan
        ratio[~good] = worst
        frames.append(m[key].assign(response=effect_response(fault), value=ratio, failed=~good))
    out = pd.concat(frames, ignore_index=True)
    return out[key + ["response", "value", "failed"]]


def case_responses(results: pd.DataFrame, *, metric: str = "rms", rule: DetectionRule = DetectionRule(),
                   detection: bool = True) -> pd.DataFrame:
    """Every response of every case (module docstring), long format.

    Parameters
    ----------
    results : DataFrame
        The runner's results (one row per job) with ``run, suite, case, variant, rep, status`` and
        ``<metric>_mm``.
    metric : {"rms", "emd"}
        The map error compared.
    rule : DetectionRule
        Decides detection for the ``detection:<fault>`` responses.
    detection : bool
        Include the detection responses.

    Returns
    -------
    DataFrame
        Columns ``run, suite, case`` and :data:`RESPONSE_COLUMNS`, one row per (case, response);
        responses in the order difficulty, then per fault (results order) effect and detection.

    Raises
    ------
    ResultsError
        Missing columns or no baseline rows.
    """
    key = list(CASE_KEY)
    reps = rep_values(results, metric=metric)
    cases = results[key].drop_duplicates().sort_values(key, kind="mergesort").reset_index(drop=True)
    frames = []
    faults = [v for v in pd.unique(results["variant"]) if v != BASELINE]
    for name in [DIFFICULTY] + [effect_response(f) for f in faults]:
        r = reps[reps["response"] == name]
        s = r.groupby(key, sort=False)["value"].apply(_summary)
        nf = r.groupby(key, sort=False)["failed"].sum()
        frames.append(_frame(cases, s, name, failed=None if name == DIFFICULTY else nf))
    if detection:
        for fault in faults:
            o = outcomes(results[results["variant"].isin([BASELINE, fault])], rule=rule)
            o = o[o["outcome"].isin([Outcome.DETECTED.value, Outcome.NOT_DETECTED.value, Outcome.CRASH.value])]
            det = o.assign(hit=(o["outcome"] != Outcome.NOT_DETECTED.value).astype(float))
            s = det.groupby(key, sort=False)["hit"].apply(_summary)
            frames.append(_frame(cases, s, detection_response(fault), failed=None))
    order = {n: i for i, n in enumerate([DIFFICULTY] + [g(f) for f in faults
                                                        for g in (effect_response, detection_response)])}
    out = pd.concat(frames, ignore_index=True)
    out = out.sort_values(["response", *key], key=lambda c: c.map(order) if c.name == "response" else c,
                          kind="mergesort")
    return out.reset_index(drop=True)


def _frame(cases: pd.DataFrame, summary: pd.Series, name: str, *, failed) -> pd.DataFrame:
    idx = pd.MultiIndex.from_frame(cases)
    s = summary.reindex(idx)
    out = cases.copy()
    out["response"] = name
    out["value"] = [t[0] if isinstance(t, tuple) else np.nan for t in s]
    out["std_err"] = [t[1] if isinstance(t, tuple) else np.nan for t in s]
    out["n_reps"] = [t[2] if isinstance(t, tuple) else 0 for t in s]
    out["n_failed"] = 0 if failed is None else failed.reindex(idx).fillna(0).astype(int).to_numpy()
    return out
