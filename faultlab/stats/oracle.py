"""A statistical test oracle over K SLAM repetitions (beyond the paper, cf. Sec. VII-A).

The paper's rule compares one faulty RMS with one baseline RMS and guards
against seed noise with fixed thresholds.  With K repetitions per case the
question "does the fault make the map worse on this case?" can be tested
directly: a one-sided Mann-Whitney U test of the K faulty RMS values against the
K baseline RMS values (alternative: faulty is stochastically greater), with the
Holm step-down correction over the whole family of (suite, run, case, fault)
tests of one call, so the family-wise error rate is at most ``alpha``.

Power limit: with K values per side and no ties the smallest attainable exact
one-sided p-value is ``1 / C(2K, K)`` (0.05 for K = 3, 0.0079 for K = 4,
0.0022 for K = 5, 0.00016 for K = 8); after Holm over m tests nothing can be
detected unless that is <= alpha / m.  The table reports it as ``p_min``.
Only jobs with status ``ok`` and a finite RMS enter the test; crashes and
timeouts are counted by :func:`faultlab.stats.detection_rates`.
"""

from __future__ import annotations

from math import comb

import numpy as np
import pandas as pd
from scipy.stats import mannwhitneyu
from statsmodels.stats.multitest import multipletests

from faultlab.errors import ConfigError
from faultlab.stats.detection import _check_columns
from faultlab.vocabulary import BASELINE
from faultlab.stats.rates import _sort
from faultlab.vocabulary import PAPER_FAULTS, SUITE_ORDER

__all__ = ["oracle_detections"]

_COLUMNS = ["suite", "run", "case", "fault", "n_faulty", "n_baseline", "median_faulty_mm",
            "median_baseline_mm", "u", "p", "p_min", "p_holm", "detected"]


def oracle_detections(results: pd.DataFrame, *, alpha: float = 0.05, method: str = "auto") -> pd.DataFrame:
    """Per (suite, run, case, fault): Mann-Whitney U of faulty vs baseline RMS, Holm-corrected.

    Parameters
    ----------
    results : DataFrame
        The runner's results; needs ``run, suite, case, rep, variant, rms_mm, status``.
    alpha : float
        Family-wise error rate of the Holm procedure.
    method : {"auto", "exact", "asymptotic"}
        Passed to :func:`scipy.stats.mannwhitneyu` (``"auto"``: exact for
        small samples without ties).

    Returns
    -------
    DataFrame
        One row per (suite, run, case, fault): ``n_faulty, n_baseline``
        (usable repetitions), medians (mm), ``u`` (the faulty sample's U
        statistic), ``p`` (one-sided, uncorrected), ``p_min`` (smallest
        attainable exact p for these sample sizes), ``p_holm`` and
        ``detected`` (Holm rejects at ``alpha``).  Rows with no usable
        repetition on one side have NaN statistics, are left out of the Holm
        family, and are not detected.
    """
    if not 0 < alpha < 1:
        raise ConfigError(f"oracle_detections: alpha must lie in (0, 1), got {alpha!r}")
    _check_columns(results, ("run", "suite", "case", "rep", "variant", "rms_mm", "status"),
                   where="oracle_detections")
    rms = results["rms_mm"].astype(float)
    ok = results[(results["status"] == "ok") & np.isfinite(rms)]
    key = ["suite", "run", "case"]
    base = {k: g["rms_mm"].to_numpy(float) for k, g in ok[ok["variant"] == BASELINE].groupby(key)}
    faulty_ok = {k: g["rms_mm"].to_numpy(float)
                 for k, g in ok[ok["variant"] != BASELINE].groupby(key + ["variant"])}
    combos = results.loc[results["variant"] != BASELINE, key + ["variant"]].drop_duplicates()
    rows = []
    empty = np.zeros(0)
    for suite, run, case, fault in combos.itertuples(index=False):
        x = faulty_ok.get((suite, run, case, fault), empty)
        y = base.get((suite, run, case), empty)
        row = {"suite": suite, "run": run, "case": case, "fault": fault, "n_faulty": x.size,
               "n_baseline": y.size, "median_faulty_mm": np.median(x) if x.size else np.nan,
               "median_baseline_mm": np.median(y) if y.size else np.nan, "u": np.nan, "p": np.nan,
               "p_min": np.nan}
        if x.size and y.size:
            res = mannwhitneyu(x, y, alternative="greater", method=method)
            row.update(u=float(res.statistic), p=float(res.pvalue), p_min=1.0 / comb(x.size + y.size, x.size))
        rows.append(row)
    table = pd.DataFrame(rows, columns=_COLUMNS[:-2])
    table["p_holm"] = np.nan
    table["detected"] = False
    tested = table["p"].notna().to_numpy()
    if tested.any():
        reject, p_holm, _, _ = multipletests(table.loc[tested, "p"].to_numpy(), alpha=alpha, method="holm")
        table.loc[tested, "p_holm"] = p_holm
        table.loc[tested, "detected"] = reject
    table["detected"] = table["detected"].astype(bool)
    if table.empty:
        return table
    return _sort(table, {"suite": SUITE_ORDER, "run": (), "case": (), "fault": PAPER_FAULTS})
