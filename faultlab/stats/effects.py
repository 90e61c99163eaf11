"""Which scenario parameters make a fault detectable?  Logistic regression per fault.

Beyond the paper: Sec. VII-D argues that diverse parameter values let some cases
detect the naive resampling error; here that is measured.  For each fault, a
binomial GLM (logit link, statsmodels) regresses the detection outcome of every
judged job (``detected`` vs ``not_detected``; crashes, timeouts and failed
baselines are left out) on the scenario parameters:

* every numeric value column of the schema (:data:`faultlab.space.case.VALUE_KEYS`
  except ``directionality``), standardised to mean 0 / standard deviation 1 over
  the jobs of that fault, so an odds ratio is "per standard deviation";
* ``directionality`` as a 0/1 dummy ``directionality[loop]`` (reference: random).

Columns that are constant among those jobs are dropped (one note row each).
The model is not fitted, and a single ``(model)`` note row explains why, when
the outcome does not vary, when there are no more jobs than coefficients, when
the design is rank-deficient, or when the outcome is perfectly separated by the
parameters (statsmodels warns, the maximum-likelihood estimate does not exist
and the coefficients diverge).  With K > 1 repetitions the jobs of a case are
clustered; standard errors are then cluster-robust by case.
"""

from __future__ import annotations

import warnings
from typing import Sequence

import numpy as np
import pandas as pd
import statsmodels.api as sm
from scipy.stats import norm
from statsmodels.tools.sm_exceptions import ConvergenceWarning, PerfectSeparationWarning

from faultlab.errors import ConfigError, ResultsError
from faultlab.space.case import VALUE_KEYS
from faultlab.stats.detection import DetectionRule, outcomes
from faultlab.vocabulary import DEFAULT_ALPHA, PAPER_FAULTS, Outcome, ordered

__all__ = ["parameter_effects", "fit_effects", "format_effects", "validate_parameters", "NUMERIC_PARAMETERS",
           "EFFECT_COLUMNS"]

#: Numeric scenario value columns used as predictors.
NUMERIC_PARAMETERS: tuple[str, ...] = tuple(k for k in VALUE_KEYS if k != "directionality")
_DUMMY = "directionality[loop]"
#: Columns of :func:`fit_effects`.
EFFECT_COLUMNS: tuple[str, ...] = ("fault", "term", "n", "n_detected", "coef", "std_err", "p", "odds_ratio",
                                   "or_low", "or_high", "note")

try:  # statsmodels < 0.14 raised instead of warning
    from statsmodels.tools.sm_exceptions import PerfectSeparationError
except ImportError:  # pragma: no cover
    PerfectSeparationError = RuntimeError


def _note(fault, term, n, n_det, note) -> dict:
    return {"fault": fault, "term": term, "n": n, "n_detected": n_det, "coef": np.nan, "std_err": np.nan,
            "p": np.nan, "odds_ratio": np.nan, "or_low": np.nan, "or_high": np.nan, "note": note}


def _design(jobs: pd.DataFrame, parameters: tuple[str, ...]) -> tuple[pd.DataFrame, list[str]]:
    """Standardised predictors and the names of dropped constant columns."""
    cols, dropped = {}, []
    for name in NUMERIC_PARAMETERS:
        if name not in parameters or name not in jobs.columns:
            continue
        x = pd.to_numeric(jobs[name], errors="coerce").astype(float)
        if x.isna().any():
            raise ResultsError(f"parameter_effects: column {name} has missing or non-numeric values")
        sd = x.std(ddof=0)
        if not sd > 1e-12 * max(1.0, abs(x.mean())):
            dropped.append(name)
            continue
        cols[name] = (x - x.mean()) / sd
    if "directionality" in parameters and "directionality" in jobs.columns:
        d = (jobs["directionality"].astype(str) == "loop").astype(float)
        if d.nunique() < 2:
            dropped.append("directionality")
        else:
            cols[_DUMMY] = d
    return pd.DataFrame(cols, index=jobs.index), dropped


def _fit_one(fault: str, jobs: pd.DataFrame, alpha: float, parameters: tuple[str, ...]) -> list[dict]:
    y = (jobs["outcome"] == Outcome.DETECTED.value).astype(float)
    n, n_det = len(y), int(y.sum())
    X, dropped = _design(jobs, parameters)
    rows = [_note(fault, name, n, n_det, "constant in these jobs; dropped") for name in dropped]
    if n_det in (0, n):
        what = "no" if n_det == 0 else "every"
        return rows + [_note(fault, "(model)", n, n_det,
                             f"not fitted: {what} judged job detected the fault (outcome does not vary)")]
    if X.shape[1] == 0:
        return rows + [_note(fault, "(model)", n, n_det, "not fitted: no parameter varies")]
    exog = sm.add_constant(X.to_numpy(), has_constant="add")
    if n <= exog.shape[1]:
        return rows + [_note(fault, "(model)", n, n_det,
                             f"not fitted: {n} jobs for {exog.shape[1]} coefficients")]
    rank = np.linalg.matrix_rank(exog)
    if rank < exog.shape[1]:
        return rows + [_note(fault, "(model)", n, n_det,
                             f"not fitted: design is rank-deficient (rank {rank} < {exog.shape[1]} "
                             f"coefficients; parameters are collinear in these jobs)")]
    case_ids = jobs.groupby(["run", "suite", "case"]).ngroup().to_numpy()
    clustered = len(np.unique(case_ids)) < n
    fit_kw = {"cov_type": "cluster", "cov_kwds": {"groups": case_ids}} if clustered else {}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            res = sm.GLM(y.to_numpy(), exog, family=sm.families.Binomial()).fit(**fit_kw)
        except (PerfectSeparationError, np.linalg.LinAlgError, ValueError) as exc:
            return rows + [_note(fault, "(model)", n, n_det, f"not fitted: {type(exc).__name__}: {exc}")]
    kinds = {type(w.message) for w in caught}
    if any(issubclass(k, PerfectSeparationWarning) for k in kinds):
        return rows + [_note(fault, "(model)", n, n_det,
                             "not fitted: perfect separation (the parameters predict detection exactly; "
                             "the odds ratios are infinite/undefined)")]
    if not res.converged or any(issubclass(k, ConvergenceWarning) for k in kinds):
        return rows + [_note(fault, "(model)", n, n_det, "not fitted: the GLM did not converge")]
    z = norm.ppf(1 - alpha / 2)
    params, bse, pvals = np.asarray(res.params), np.asarray(res.bse), np.asarray(res.pvalues)
    cov = "cluster-robust by case" if clustered else ""
    with np.errstate(over="ignore"):  # a huge log odds ratio (near separation) is an infinite ratio
        for i, name in enumerate(X.columns, start=1):
            rows.append({"fault": fault, "term": name, "n": n, "n_detected": n_det, "coef": params[i],
                         "std_err": bse[i], "p": pvals[i], "odds_ratio": np.exp(params[i]),
                         "or_low": np.exp(params[i] - z * bse[i]), "or_high": np.exp(params[i] + z * bse[i]),
                         "note": cov})
    return rows


def parameter_effects(results: pd.DataFrame, *, rule: DetectionRule = DetectionRule(),
                      alpha: float = DEFAULT_ALPHA, parameters: Sequence[str] | None = None) -> pd.DataFrame:
    """Per fault, odds ratios of detection per standard deviation of each scenario parameter.

    Parameters
    ----------
    results : DataFrame
        The runner's results with the scenario value columns (:data:`faultlab.runner.RESULT_COLUMNS`).
    rule : DetectionRule
        Decides ``detected`` for each job.
    alpha : float
        1 - confidence level of the odds-ratio intervals (Wald, log scale).
    parameters : sequence of str, optional
        Restrict the predictors to these value columns (names of
        :data:`NUMERIC_PARAMETERS` and/or ``"directionality"``); default all.
        Fewer predictors help when there are few jobs per fault (the paper's
        protocol has 45 per fault for 13 predictors).

    Returns
    -------
    DataFrame
        :func:`fit_effects` of :func:`faultlab.stats.outcomes`.

    Raises
    ------
    ResultsError
        If the results have none of the parameter columns.
    ConfigError
        If ``parameters`` names an unknown parameter.
    """
    parameters = validate_parameters(parameters)
    _check_parameter_columns(results)
    return fit_effects(outcomes(results, rule=rule), alpha=alpha, parameters=parameters)


def validate_parameters(parameters: Sequence[str] | None) -> tuple[str, ...]:
    """The predictors named by ``parameters`` (None: all of them), checked.

    Raises
    ------
    ConfigError
        An unknown parameter, or none.
    """
    allowed = NUMERIC_PARAMETERS + ("directionality",)
    if parameters is None:
        return allowed
    parameters = tuple(parameters)
    unknown = [p for p in parameters if p not in allowed]
    if unknown or not parameters:
        raise ConfigError(f"parameter_effects: unknown parameter {unknown[0] if unknown else '(none given)'!r}; "
                          f"choose from {', '.join(allowed)}")
    return parameters


def _check_parameter_columns(frame: pd.DataFrame) -> None:
    if not any(c in frame.columns for c in NUMERIC_PARAMETERS + ("directionality",)):
        raise ResultsError("parameter_effects: results have no scenario parameter columns "
                           f"(expected e.g. {', '.join(NUMERIC_PARAMETERS[:3])})")


def fit_effects(pairs: pd.DataFrame, *, alpha: float = DEFAULT_ALPHA,
                parameters: Sequence[str] | None = None) -> pd.DataFrame:
    """Per fault, the logistic regression of detection on the scenario parameters (module docstring).

    Parameters
    ----------
    pairs : DataFrame
        Output of :func:`faultlab.stats.outcomes`, with the faulty jobs' scenario value columns.
    alpha : float
        1 - confidence level of the odds-ratio intervals (Wald, log scale).
    parameters : sequence of str, optional
        As for :func:`parameter_effects`.

    Returns
    -------
    DataFrame
        Columns :data:`EFFECT_COLUMNS`: ``fault, term, n, n_detected, coef, std_err, p, odds_ratio,
        or_low, or_high, note``.  One row per fitted term (intercept omitted);
        note rows (NaN numbers) for dropped constant columns and for a model
        that could not be fitted (``term == "(model)"``, reason in ``note``).

    Raises
    ------
    ResultsError
        If the pairs have none of the parameter columns.
    ConfigError
        If ``parameters`` names an unknown parameter.
    """
    parameters = validate_parameters(parameters)
    _check_parameter_columns(pairs)
    judged = pairs[pairs["outcome"].isin([Outcome.DETECTED.value, Outcome.NOT_DETECTED.value])]
    rows = []
    for fault in ordered(pairs["fault"], PAPER_FAULTS):
        jobs = judged[judged["fault"] == fault]
        if jobs.empty:
            rows.append(_note(fault, "(model)", 0, 0, "not fitted: no judged job (all failed)"))
            continue
        rows.extend(_fit_one(fault, jobs, alpha, parameters))
    return pd.DataFrame(rows, columns=list(EFFECT_COLUMNS))


def format_effects(table: pd.DataFrame) -> str:
    """Plain-text rendering of :func:`parameter_effects` for the terminal."""
    if table.empty:
        return "no faulty jobs in these results"
    out = []
    for fault, t in table.groupby("fault", sort=False):
        n, k = int(t["n"].iloc[0]), int(t["n_detected"].iloc[0])
        out.append(f"{fault}: {k} of {n} judged jobs detected")
        fitted = t[t["coef"].notna()]
        if len(fitted):
            show = fitted[["term", "odds_ratio", "or_low", "or_high", "p"]].rename(
                columns={"odds_ratio": "OR/SD", "or_low": "CI low", "or_high": "CI high"})
            out.append(show.to_string(index=False, float_format=lambda v: f"{v:.3g}"))
        for r in t[t["coef"].isna()].itertuples():
            out.append(f"  {r.term}: {r.note}")
        notes = set(fitted["note"]) - {""}
        out.extend(f"  ({note})" for note in sorted(notes))
        out.append("")
    return "\n".join(out).rstrip() + "\n"
