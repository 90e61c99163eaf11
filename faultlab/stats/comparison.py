"""Suite comparisons per fault: Fisher's exact test with effect sizes (beyond Sec. VII-D).

The paper compares suites by eye ("the behavior of both suites is similar",
Sec. VII-D).  Here every pair of suites is compared per fault on the 2 x 2
table of detected / not-detected jobs:

* ``p`` -- two-sided Fisher exact test (:func:`scipy.stats.fisher_exact`);
  ``p_holm`` -- Holm-adjusted over all rows of the returned table;
* ``risk_difference`` -- rate_a - rate_b with Newcombe's hybrid score
  interval (statsmodels ``confint_proportions_2indep(method="newcomb")``);
* ``odds_ratio`` -- (k_a / (n_a - k_a)) / (k_b / (n_b - k_b)) with a Woolf
  (log-scale normal) interval.  When any cell is zero the sample odds ratio is
  0 or infinite, so the Haldane-Anscombe correction is applied: 0.5 is added to
  every cell of that table (``haldane`` is True on such rows) for the estimate
  and its interval.
"""

from __future__ import annotations

from itertools import combinations

import numpy as np
import pandas as pd
from scipy.stats import fisher_exact, norm
from statsmodels.stats.proportion import confint_proportions_2indep

from faultlab.stats.detection import DetectionRule, _check_columns
from faultlab.inference.multiplicity import holm
from faultlab.stats.rates import detection_rates
from faultlab.vocabulary import DEFAULT_ALPHA, PAPER_FAULTS, SUITE_ORDER, ordered

__all__ = ["compare_suites", "compare_suite_rates", "odds_ratio", "COMPARISON_COLUMNS"]

#: Columns of :func:`compare_suite_rates`.
COMPARISON_COLUMNS = _COLUMNS = ["fault", "suite_a", "suite_b", "k_a", "n_a", "k_b", "n_b", "rate_a", "rate_b",
            "risk_difference", "rd_low", "rd_high", "odds_ratio", "or_low", "or_high", "haldane",
            "p", "p_holm"]


def odds_ratio(k_a: int, n_a: int, k_b: int, n_b: int, *, alpha: float = DEFAULT_ALPHA) -> tuple[float, float, float, bool]:
    """Odds ratio of two proportions with a Woolf interval; Haldane-corrected on zero cells.

    Returns
    -------
    (odds_ratio, low, high, corrected)
    """
    cells = np.array([k_a, n_a - k_a, k_b, n_b - k_b], dtype=float)
    corrected = bool(np.any(cells == 0))
    if corrected:
        cells = cells + 0.5
    a, b, c, d = cells
    log_or = np.log(a * d / (b * c))
    se = np.sqrt(np.sum(1.0 / cells))
    z = norm.ppf(1 - alpha / 2)
    return float(np.exp(log_or)), float(np.exp(log_or - z * se)), float(np.exp(log_or + z * se)), corrected


def compare_suites(results: pd.DataFrame, *, rule: DetectionRule = DetectionRule(), alpha: float = DEFAULT_ALPHA,
                   failures_detect: bool = False) -> pd.DataFrame:
    """Per fault, Fisher's exact test for every pair of suites.

    Parameters
    ----------
    results : DataFrame
        The runner's results.
    rule : DetectionRule
    alpha : float
        For the intervals and the Holm adjustment.
    failures_detect : bool
        Use the counts with crash/timeout counted as detections (``k_incl``,
        ``n_incl`` of :func:`detection_rates`) instead of excluding them.

    Returns
    -------
    DataFrame
        :func:`compare_suite_rates` of :func:`faultlab.stats.detection_rates`.
    """
    return compare_suite_rates(detection_rates(results, rule=rule, alpha=alpha), alpha=alpha,
                               failures_detect=failures_detect)


def compare_suite_rates(rates: pd.DataFrame, *, alpha: float = DEFAULT_ALPHA, failures_detect: bool = False) -> pd.DataFrame:
    """Per fault, Fisher's exact test for every pair of suites of a detection-rate table.

    Parameters
    ----------
    rates : DataFrame
        Output of :func:`faultlab.stats.detection_rates` or :func:`faultlab.stats.tabulate_rates`
        (needs ``suite, fault, k, n`` and, with ``failures_detect``, ``k_incl, n_incl``).
    alpha : float
        For the intervals and the Holm adjustment.
    failures_detect : bool
        Use the counts with crash/timeout counted as detections instead of excluding them.

    Returns
    -------
    DataFrame
        One row per (fault, suite pair) in Table II order: counts, rates,
        ``risk_difference`` with ``rd_low, rd_high``, ``odds_ratio`` with
        ``or_low, or_high`` and ``haldane``, Fisher ``p`` and ``p_holm``
        (module docstring).  Pairs where a suite has no usable job are left out.
    """
    sfx = "_incl" if failures_detect else ""
    _check_columns(rates, ("suite", "fault", "k" + sfx, "n" + sfx), where="compare_suite_rates")
    rows = []
    for fault in ordered(rates["fault"], PAPER_FAULTS):
        r = rates[rates["fault"] == fault].set_index("suite")
        for sa, sb in combinations(ordered(r.index, SUITE_ORDER), 2):
            k_a, n_a = int(r.at[sa, "k" + sfx]), int(r.at[sa, "n" + sfx])
            k_b, n_b = int(r.at[sb, "k" + sfx]), int(r.at[sb, "n" + sfx])
            if n_a == 0 or n_b == 0:
                continue
            p = fisher_exact([[k_a, n_a - k_a], [k_b, n_b - k_b]], alternative="two-sided").pvalue
            rd_lo, rd_hi = confint_proportions_2indep(k_a, n_a, k_b, n_b, method="newcomb", compare="diff",
                                                      alpha=alpha)
            orr, or_lo, or_hi, corr = odds_ratio(k_a, n_a, k_b, n_b, alpha=alpha)
            rows.append({"fault": fault, "suite_a": sa, "suite_b": sb, "k_a": k_a, "n_a": n_a, "k_b": k_b,
                         "n_b": n_b, "rate_a": k_a / n_a, "rate_b": k_b / n_b,
                         "risk_difference": k_a / n_a - k_b / n_b, "rd_low": float(rd_lo),
                         "rd_high": float(rd_hi), "odds_ratio": orr, "or_low": or_lo, "or_high": or_hi,
                         "haldane": corr, "p": float(p)})
    table = pd.DataFrame(rows, columns=_COLUMNS[:-1])
    table["p_holm"] = holm(table["p"].to_numpy())[1] if len(table) else []
    return table
