"""Accuracy of a SLAM: its map error over the cases of a campaign, with confidence intervals.

The cases are the independent units (the K repetitions of a case share its map and trace), so
each case contributes the mean of its repetitions' errors and the intervals are taken across
cases: a Student t interval for the mean, and one for the mean of the logarithms (the geometric
mean, an interval on the multiplicative scale that suits errors spread over orders of magnitude).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
from scipy import stats as _st

from faultlab.errors import ConfigError
from faultlab.vocabulary import DEFAULT_ALPHA

__all__ = ["ACCURACY_COLUMNS", "case_mean_accuracy"]

#: Columns of :func:`case_mean_accuracy`.
ACCURACY_COLUMNS: tuple[str, ...] = ("n_cases", "n_jobs", "mean_mm", "mean_low", "mean_high", "gmean_mm",
                                     "gmean_low", "gmean_high", "median_mm")


def case_mean_accuracy(errors: pd.DataFrame, *, value: str, case: list[str], alpha: float = DEFAULT_ALPHA) -> dict:
    """Mean and geometric mean over cases of the per-case mean error, with t intervals across cases.

    Parameters
    ----------
    errors : DataFrame
        One row per successful job: the ``case`` key columns and ``value`` (mm, finite).
    value : str
        The error column (``"rms_mm"`` or ``"emd_mm"``).
    case : list of str
        Columns that identify a case (e.g. ``["run", "suite", "case"]``).
    alpha : float
        1 - confidence level.

    Returns
    -------
    dict
        :data:`ACCURACY_COLUMNS`: cases and jobs counted, the mean with its interval, the
        geometric mean with its interval, the median of the per-case means (NaN where
        undefined: no case, or one case for the intervals; the geometric mean needs positive errors).
    """
    if not 0 < alpha < 1:
        raise ConfigError(f"case_mean_accuracy: alpha must lie in (0, 1), got {alpha!r}")
    x = errors[value].to_numpy(dtype=float)
    if not np.all(np.isfinite(x)):
        raise ConfigError(f"case_mean_accuracy: {value} has non-finite values; pass the successful jobs only")
    per_case = errors.groupby(case, sort=True)[value].mean().to_numpy(dtype=float)
    n = per_case.size
    out = dict.fromkeys(ACCURACY_COLUMNS, math.nan)
    out.update(n_cases=int(n), n_jobs=int(len(errors)))
    if n == 0:
        return out
    out["mean_mm"] = float(per_case.mean())
    out["median_mm"] = float(np.median(per_case))
    positive = bool(np.all(per_case > 0))
    if positive:
        out["gmean_mm"] = float(np.exp(np.log(per_case).mean()))
    if n < 2:
        return out
    q = _st.t.ppf(1 - alpha / 2, n - 1)
    half = q * per_case.std(ddof=1) / math.sqrt(n)
    out["mean_low"], out["mean_high"] = out["mean_mm"] - half, out["mean_mm"] + half
    if positive:
        logs = np.log(per_case)
        half = q * logs.std(ddof=1) / math.sqrt(n)
        out["gmean_low"], out["gmean_high"] = float(np.exp(logs.mean() - half)), float(np.exp(logs.mean() + half))
    return out
