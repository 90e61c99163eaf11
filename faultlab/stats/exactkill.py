"""Kills of a deterministic SLAM, judged exactly: one run per case and variant, no test.

A deterministic SLAM gives the same estimate every time it runs a case, so repetitions carry no
information and a test over them would be meaningless.  A case kills a mutant when the mutant's
run fails and the baseline's does not (an exception, a non-finite map: ``crash``; past the time
limit: ``timeout``), or when both ran and the judged map error differs (any difference, compared
as stored, in float64).  A case whose baseline failed cannot judge.  The kill on a case depends on
that case alone, so a suite's kill (some case kills) is monotone in its cases: adding a case
never un-kills a mutant.

:func:`exact_kills` returns the columns of :func:`faultlab.stats.killmatrix.suite_kills` that a
mutation analysis reads; ``p``, ``mde_mm`` and the equivalence test are not defined here (NaN),
and ``identical`` is false (an exact survivor is a survivor, not an observed equivalent: the
campaign compares map errors, not whole estimates).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from faultlab.mutation.outcome import MutantOutcome
from faultlab.vocabulary import BASELINE, JobStatus

__all__ = ["exact_kills", "EXACT_COLUMNS"]

EXACT_COLUMNS = ["run", "suite", "case", "fault", "verdict", "reason", "kill", "stopped", "direction", "n_reps",
                 "median_diff_mm", "ratio", "p", "mde_mm", "p_equivalence", "margin_mm", "identical"]


def exact_kills(results: pd.DataFrame, *, metric: str = "rms") -> pd.DataFrame:
    """Per (run, suite, case, mutant variant): whether the case kills it, judged exactly (module docstring).

    ``results`` holds one row per (run, suite, case, variant) (repetition 0; further repetitions
    of a deterministic SLAM are ignored).  Columns :data:`EXACT_COLUMNS`: ``kill`` is ``killed``,
    ``crash``, ``timeout`` or ``""``; ``median_diff_mm`` the mutant's error minus the baseline's.
    """
    col = f"{metric}_mm"
    first = results[results["rep"] == 0] if "rep" in results else results
    keys = ["run", "suite", "case"]
    base = first[first["variant"] == BASELINE].set_index(keys)
    rows = []
    for r in first[first["variant"] != BASELINE].itertuples(index=False):
        key = (r.run, r.suite, r.case)
        row = dict(run=r.run, suite=r.suite, case=r.case, fault=r.variant, kill="", stopped="", direction="",
                   n_reps=1, median_diff_mm=math.nan, ratio=math.nan, p=math.nan, mde_mm=math.nan,
                   p_equivalence=math.nan, margin_mm=math.nan, identical=False)
        b = base.loc[key] if key in base.index else None
        b_ok = b is not None and str(b["status"]) == JobStatus.OK.value and np.isfinite(b[col])
        m_status = str(r.status)
        if not b_ok:
            rows.append(row | dict(verdict="cannot_judge", reason="baseline failed or missing"))
            continue
        if m_status != JobStatus.OK.value or not np.isfinite(getattr(r, col)):
            kill = MutantOutcome.TIMEOUT.value if m_status == JobStatus.TIMEOUT.value else MutantOutcome.CRASH.value
            rows.append(row | dict(verdict="crash_detected", reason=str(r.error) or "non-finite map", kill=kill))
            continue
        diff = float(getattr(r, col)) - float(b[col])
        ratio = float(getattr(r, col)) / float(b[col]) if float(b[col]) != 0 else math.nan
        if diff != 0.0:
            rows.append(row | dict(verdict="detected", reason="map error differs (exact)", kill=MutantOutcome.KILLED.value,
                                   direction="worse" if diff > 0 else "better", median_diff_mm=diff, ratio=ratio))
        else:
            rows.append(row | dict(verdict="not_detected", reason="map error identical to the baseline's",
                                   median_diff_mm=0.0, ratio=ratio))
    return pd.DataFrame(rows, columns=EXACT_COLUMNS)
