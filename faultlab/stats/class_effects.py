"""Which equivalence classes make a fault detectable: logistic regression on the case verdicts.

Beyond the paper (Sec. VII-D).  Per fault, the **case** is the unit (its verdict by the campaign's
rule, :func:`faultlab.stats.cases.rule_verdicts`; cannot-judge cases are left out), and each
scenario parameter enters through its **equivalence classes** (Table I), as indicators with the
first class of the parameter space as reference.  The rotation error is a signed discrete
parameter (multiples of 2 pi, Table I): a -2 pi and a +2 pi offset are the same fault symptom, so
it enters as its magnitude ``|value|`` (indicators of the distinct magnitudes, reference 0).
Classes no judged case falls in, and parameters with a single observed class, are left out.

Fit: maximum likelihood (statsmodels ``Logit``) unless the data are separated (a linear
combination of the predictors splits detected from missed cases; ``firthmodels.detect_separation``,
a linear program), where the maximum-likelihood estimate does not exist; then Firth's penalised
likelihood (``firthmodels.FirthLogisticRegression``, Jeffreys-prior penalty, finite estimates).
``method`` says which.

Tests: one likelihood-ratio test per parameter (all its indicators jointly: twice the difference
of the (penalised) log-likelihoods of the full model and the model refitted without the
parameter, chi-squared with as many degrees of freedom as indicators -- the "nested" comparison
of penalised fits), Holm-adjusted over the parameters of one fault (the family: a fault).

Events per predictor: ``epv = min(detected, missed) / indicators``.  Below :data:`MIN_EPV` (10)
estimates and tests are unreliable (Peduzzi et al. 1996); the model is then not fitted and one
``(model)`` row says so, with the counts.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pandas as pd
from scipy.stats import chi2

from faultlab.inference.multiplicity import holm
from faultlab.stats.verdict import Verdict

__all__ = ["CLASS_EFFECT_COLUMNS", "MIN_EPV", "SIGNED_DISCRETE", "class_design", "fit_class_effects"]

#: Fewest events per predictor for a fit.
MIN_EPV = 10.0
#: Signed discrete parameters entered by magnitude.
SIGNED_DISCRETE: tuple[str, ...] = ("rotation_error",)

CLASS_EFFECT_COLUMNS: tuple[str, ...] = (
    "fault", "parameter", "term", "n", "n_detected", "epv", "method", "coef", "std_err", "odds_ratio", "lr_chi2",
    "df", "p", "p_holm", "note")


def class_design(cases: pd.DataFrame, parameters) -> tuple[pd.DataFrame, dict[str, list[str]]]:
    """Indicator columns of the parameters' classes (reference: the smallest class index / magnitude).

    Parameters
    ----------
    cases : DataFrame
        One row per case with ``class_<parameter>`` (class index) and, for signed discrete
        parameters, the value column.
    parameters : sequence of str

    Returns
    -------
    (design, terms) : (DataFrame, dict)
        0/1 indicator columns named ``parameter[level]``; ``terms[parameter]`` lists its columns.
    """
    cols: dict[str, np.ndarray] = {}
    terms: dict[str, list[str]] = {}
    for p in parameters:
        if p in SIGNED_DISCRETE:
            level = np.round(np.abs(cases[p].to_numpy(float)) / (2 * math.pi)).astype(int)
            names = {lv: f"|{p}|[{lv}x2pi]" for lv in np.unique(level)}
        else:
            level = cases[f"class_{p}"].to_numpy(int)
            names = {lv: f"{p}[class {lv}]" for lv in np.unique(level)}
        levels = sorted(names)
        if len(levels) < 2:
            continue
        terms[p] = []
        for lv in levels[1:]:
            cols[names[lv]] = (level == lv).astype(float)
            terms[p].append(names[lv])
    return pd.DataFrame(cols, index=cases.index), terms


def _fit(X: np.ndarray, y: np.ndarray, firth: bool) -> tuple[np.ndarray, np.ndarray, float]:
    """(coefficients with intercept first, standard errors, (penalised) log-likelihood)."""
    if firth:
        from firthmodels import FirthLogisticRegression

        m = FirthLogisticRegression(max_iter=200).fit(X, y) if X.shape[1] else None
        if m is None:  # intercept only: Firth's estimate is logit((k + 1/2) / (n + 1))
            k, n = y.sum(), len(y)
            b0 = math.log((k + 0.5) / (n - k + 0.5))
            pr = 1 / (1 + math.exp(-b0))
            ll = k * math.log(pr) + (n - k) * math.log(1 - pr) + 0.5 * math.log(n * pr * (1 - pr))
            return np.array([b0]), np.array([math.nan]), ll
        coef = np.r_[m.intercept_, m.coef_]
        bse = np.asarray(m.bse_, float)
        bse = np.r_[bse[-1], bse[:-1]]  # firthmodels puts the intercept last
        return coef, bse, float(m.loglik_)
    import statsmodels.api as sm

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        r = sm.Logit(y, sm.add_constant(X, has_constant="add")).fit(disp=0, maxiter=200)
    return np.asarray(r.params), np.asarray(r.bse), float(r.llf)


def _separated(X: np.ndarray, y: np.ndarray) -> bool:
    from firthmodels import detect_separation

    return bool(detect_separation(X, y).separation)


def fit_class_effects(verdicts: pd.DataFrame, cases: pd.DataFrame, parameters) -> pd.DataFrame:
    """Per fault: class-indicator logistic regression of the case verdicts (module docstring).

    Parameters
    ----------
    verdicts : DataFrame
        :func:`faultlab.stats.cases.rule_verdicts` (``suite, run, case, fault, verdict``).
    cases : DataFrame
        The campaign's cases (``run, suite, case``, values and ``class_<parameter>``).
    parameters : sequence of str
        Scenario parameters (Table I names).

    Returns
    -------
    DataFrame
        :data:`CLASS_EFFECT_COLUMNS`: one row per indicator (``term``), each carrying its
        parameter's joint LR test (``lr_chi2, df, p, p_holm``); a ``(model)`` note row per
        fault where nothing is fitted, saying why.
    """
    rows = []
    key = ["suite", "run", "case"]
    judged = verdicts[verdicts["verdict"] != Verdict.CANNOT_JUDGE.value]
    for fault in sorted(judged["fault"].unique()):
        v = judged[judged["fault"] == fault].merge(cases, on=key, how="inner")
        y = v["verdict"].isin([Verdict.DETECTED.value, Verdict.CRASH_DETECTED.value]).to_numpy(float)
        n, k = len(y), int(y.sum())
        design, terms = class_design(v, parameters)
        n_pred = design.shape[1]
        base = {"fault": fault, "n": n, "n_detected": k, "coef": math.nan, "std_err": math.nan,
                "odds_ratio": math.nan, "lr_chi2": math.nan, "df": 0, "p": math.nan, "p_holm": math.nan}
        epv = min(k, n - k) / n_pred if n_pred else math.nan
        if n_pred == 0 or k in (0, n) or epv < MIN_EPV:
            why = ("no parameter varies among the judged cases" if n_pred == 0 else
                   f"the outcome does not vary ({k} of {n} cases detected)" if k in (0, n) else
                   f"too few data: {min(k, n - k)} events (the rarer of {k} detected / {n - k} missed cases) "
                   f"for {n_pred} class indicators is {epv:.2g} events per predictor, below {MIN_EPV:g}; "
                   f"estimates and tests would be unreliable")
            rows.append({**base, "parameter": "", "term": "(model)", "epv": epv, "method": "", "note": why})
            continue
        X = design.to_numpy(float)
        firth = _separated(X, y)
        method = "firth" if firth else "ml"
        coef, bse, ll = _fit(X, y, firth)
        names = list(design.columns)
        stats = {}
        for p, cols in terms.items():
            keep = [i for i, c in enumerate(names) if c not in cols]
            _, _, ll0 = _fit(X[:, keep], y, firth)
            lr = max(0.0, 2 * (ll - ll0))
            stats[p] = (lr, len(cols), float(chi2.sf(lr, len(cols))))
        params = list(terms)
        adjusted = dict(zip(params, holm([stats[p][2] for p in params])[1]))
        for p in params:
            for c in terms[p]:
                i = names.index(c) + 1
                rows.append({**base, "parameter": p, "term": c, "epv": epv, "method": method, "coef": coef[i],
                             "std_err": bse[i], "odds_ratio": math.exp(coef[i]), "lr_chi2": stats[p][0],
                             "df": stats[p][1], "p": stats[p][2], "p_holm": float(adjusted[p]),
                             "note": "separation: Firth's penalised likelihood" if firth else ""})
    return pd.DataFrame(rows, columns=list(CLASS_EFFECT_COLUMNS))
