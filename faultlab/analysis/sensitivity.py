"""The regression view of an effects study: the response per standard deviation of each parameter.

**Regression** (:func:`regression_view`): ordinary least squares (statsmodels) of the
repetition-level response on the standardised parameter values, standard errors cluster-robust
by case (the repetitions of a case are not independent evidence), so a coefficient is "response
change per standard deviation of the parameter".  :func:`partial_dependence` bins the response
by one parameter.  The Morris and Sobol indices are :mod:`faultlab.inference.screening`.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np
import pandas as pd

from faultlab.errors import ResultsError
from faultlab.vocabulary import DEFAULT_ALPHA

__all__ = ["REGRESSION_COLUMNS", "regression_view", "design_columns", "partial_dependence"]

REGRESSION_COLUMNS: tuple[str, ...] = ("parameter", "column", "coef", "std_err", "low", "high", "p")


def design_columns(cases: pd.DataFrame, factors: Sequence[str]) -> pd.DataFrame:
    """One numeric column per factor from the case values: the value itself, the distance component
    of variance and bias (the design moves both components together), ``directionality`` as
    1 for ``loop``.

    Parameters
    ----------
    cases : DataFrame
        One row per case with the value columns (:data:`faultlab.space.case.VALUE_KEYS`).
    """
    cols = {}
    for f in factors:
        if f == "directionality":
            cols[f] = (cases["directionality"].astype(str) == "loop").astype(float)
        elif f in ("variance", "bias"):
            cols[f] = pd.to_numeric(cases[f"{f}_distance"], errors="coerce").astype(float)
        else:
            cols[f] = pd.to_numeric(cases[f], errors="coerce").astype(float)
    return pd.DataFrame(cols, index=cases.index)


def regression_view(reps: pd.DataFrame, cases: pd.DataFrame, *, factors: Sequence[str],
                    alpha: float = DEFAULT_ALPHA) -> pd.DataFrame:
    """OLS of a repetition-level response on the standardised parameters, cluster-robust by case.

    Parameters
    ----------
    reps : DataFrame
        ``run, suite, case, value``: one row per repetition of one response.
    cases : DataFrame
        ``run, suite, case`` and the value columns, one row per case.
    factors : sequence of str
    alpha : float
        1 - confidence level of the coefficient intervals.

    Returns
    -------
    DataFrame
        :data:`REGRESSION_COLUMNS`: per factor the coefficient per standard deviation of its
        column (:func:`design_columns`), its standard error, interval and p value (Student t with
        one degree of freedom less than the number of cases, as for cluster-robust errors); a factor
        that is constant over the cases has NaN numbers.
    """
    import statsmodels.api as sm

    key = ["run", "suite", "case"]
    X = design_columns(cases, factors)
    sd = X.std(ddof=0)
    varying = [f for f in factors if sd[f] > 0]
    Z = (X[varying] - X[varying].mean()) / sd[varying]
    frame = reps[key + ["value"]].merge(pd.concat([cases[key], Z], axis=1), on=key, how="inner")
    frame = frame[np.isfinite(frame["value"])]
    groups = frame.groupby(key, sort=False).ngroup().to_numpy()
    if len(np.unique(groups)) <= len(varying) + 1:
        raise ResultsError(f"regression_view: {len(np.unique(groups))} cases for {len(varying) + 1} coefficients")
    exog = sm.add_constant(frame[varying].to_numpy(), has_constant="add")
    res = sm.OLS(frame["value"].to_numpy(), exog).fit(cov_type="cluster", cov_kwds={"groups": groups}, use_t=True)
    ci = np.asarray(res.conf_int(alpha=alpha))
    rows = []
    for f in factors:
        col = f"{f}_distance" if f in ("variance", "bias") else f
        if f in varying:
            i = varying.index(f) + 1
            rows.append({"parameter": f, "column": col, "coef": res.params[i], "std_err": res.bse[i],
                         "low": ci[i, 0], "high": ci[i, 1], "p": res.pvalues[i]})
        else:
            rows.append({"parameter": f, "column": col, "coef": np.nan, "std_err": np.nan, "low": np.nan,
                         "high": np.nan, "p": np.nan})
    return pd.DataFrame(rows, columns=list(REGRESSION_COLUMNS))


def partial_dependence(values: pd.Series, response, std_err=None, *, bins: int = 5) -> pd.DataFrame:
    """Mean response over the design in bins of one parameter (others averaged over the design).

    Continuous values are cut at their quantiles into ``bins`` bins; a parameter with at most
    ``bins`` distinct values gets one bin per value.

    Returns
    -------
    DataFrame
        ``x`` (mean value in the bin), ``mean``, ``std_err`` (over the bin's cases; NaN where every
        case of the bin has the same value or the bin has one case), ``n``.
    """
    x = pd.Series(np.asarray(values), dtype=object if values.dtype == object else float)
    y = np.asarray(response, dtype=float)
    if x.dtype == object:
        x = (x.astype(str) == "loop").astype(float)
    x = x.astype(float)
    distinct = np.unique(x[np.isfinite(x)])
    if distinct.size <= bins:
        group = x
    else:
        group = pd.qcut(x, bins, duplicates="drop")
    frame = pd.DataFrame({"x": x, "y": y, "g": group})
    frame = frame[np.isfinite(frame["y"])]
    out = frame.groupby("g", observed=True).agg(x=("x", "mean"), mean=("y", "mean"),
                                                sd=("y", "std"), n=("y", "size")).reset_index(drop=True)
    out["std_err"] = (out["sd"] / np.sqrt(out["n"])).where(out["sd"] > 0)  # no zero-width interval
    return out[["x", "mean", "std_err", "n"]]
