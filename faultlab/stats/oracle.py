"""A statistical test oracle over K SLAM repetitions (beyond the paper, cf. Sec. VII-A).

The paper's rule compares one faulty RMS with one baseline RMS and guards
against seed noise with fixed thresholds.  With K repetitions per case the
question "does the fault make the map worse on this case?" can be tested
directly: a one-sided Mann-Whitney U test of the K faulty RMS values against the
K baseline RMS values (alternative: faulty is stochastically greater), with the
Holm step-down correction over the whole family of (suite, run, case, fault)
tests of one call, so the family-wise error rate is at most ``alpha``.

p values (``method``):

``"exact"`` (default)
    The exact permutation p value: the share of all ``C(n + m, n)`` ways to split
    the pooled values into a "faulty" sample of size n and a "baseline" sample of
    size m whose U is at least the observed one.  Without ties this is SciPy's
    exact null distribution of U (``mannwhitneyu(method="exact")``, any size).
    With ties (equal values anywhere in the pooled sample -- under common random
    numbers a fault that does not change a repetition reproduces the baseline's
    RMS bit for bit) SciPy's exact distribution does not apply, and the splits
    are enumerated by SciPy's permutation machinery
    (``mannwhitneyu(method=PermutationMethod(n_resamples=inf))``, ties scored
    1/2 in U); enumeration is limited to :data:`MAX_TIED_SPLITS` splits (n = m = 9).
    Beyond it (ties and more repetitions), :data:`MONTE_CARLO_SPLITS` random
    splits from a generator seeded per (suite, run, case, fault)
    (``SeedSequence(ORACLE_SEED)`` and the names' :func:`~faultlab.seeds.stable_code`)
    give the p value ``(hits + 1) / (splits + 1)`` with its Monte Carlo standard
    error in ``p_mc_se`` (0 where enumerated): ties never switch the oracle off.
    Either way the p value is never below the exact floor ``1 / C(n + m, n)``.
``"asymptotic"``
    SciPy's normal approximation with tie and continuity corrections, explicit
    and for large samples only: it can fall below the exact floor.

Power limit: with K values per side the smallest attainable exact one-sided
p value is ``1 / C(2K, K)``:

===  =========  ===========
K    C(2K, K)   min p
===  =========  ===========
3    20         0.05
4    70         0.0143
5    252        0.00397
6    924        0.00108
7    3432       0.000291
8    12870      7.77e-05
10   184756     5.41e-06
===  =========  ===========

After Holm over m tests nothing can be detected unless that is <= alpha / m.
The table reports it as ``p_min``.  Only jobs with status ``ok`` and a finite
RMS enter the test; crashes and timeouts are counted by
:func:`faultlab.stats.detection_rates`.
"""

from __future__ import annotations

from math import comb

import numpy as np
import pandas as pd
from scipy.stats import PermutationMethod, mannwhitneyu, rankdata

from faultlab.errors import ConfigError
from faultlab.seeds import stable_code
from faultlab.stats.detection import _check_columns
from faultlab.inference.multiplicity import holm
from faultlab.vocabulary import BASELINE, DEFAULT_ALPHA
from faultlab.stats.rates import _sort
from faultlab.vocabulary import PAPER_FAULTS, SUITE_ORDER

__all__ = ["oracle_detections", "mann_whitney_p", "MAX_TIED_SPLITS", "MONTE_CARLO_SPLITS", "ORACLE_SEED",
           "ORACLE_METHODS"]

#: Largest number of splits C(n + m, n) enumerated for an exact p value with ties (n = m = 9).
MAX_TIED_SPLITS = 50_000
#: Random splits of the Monte Carlo p value beyond :data:`MAX_TIED_SPLITS` (standard error <= 0.0036).
MONTE_CARLO_SPLITS = 19_999
#: Entropy of the oracle's Monte Carlo generators.
ORACLE_SEED = 20261126

#: The p-value methods of :func:`oracle_detections` (module docstring).
ORACLE_METHODS = ("exact", "asymptotic")

_COLUMNS = ["suite", "run", "case", "fault", "n_faulty", "n_baseline", "median_faulty_mm",
            "median_baseline_mm", "u", "p", "p_mc_se", "p_min", "p_holm", "detected"]


def mann_whitney_p(x, y, *, method: str = "exact", rng: np.random.Generator | None = None) -> tuple[float, float]:
    """One-sided Mann-Whitney U test of ``x`` (faulty) greater than ``y`` (baseline).

    Parameters
    ----------
    x, y : array_like, shapes (n,) and (m,)
        Finite values, n, m >= 1.
    method : {"exact", "asymptotic"}
        See the module docstring.
    rng : numpy.random.Generator, optional
        Draws :data:`MONTE_CARLO_SPLITS` random splits when ties need more than
        :data:`MAX_TIED_SPLITS` (its standard error: ``sqrt(p (1 - p) / splits)``).

    Returns
    -------
    (u, p) : floats
        U of ``x`` (pairs with x > y, ties counted 1/2) and the one-sided p value.

    Raises
    ------
    ConfigError
        Unknown ``method``, or ties needing more than :data:`MAX_TIED_SPLITS` splits
        without an ``rng``.
    """
    if method not in ORACLE_METHODS:
        raise ConfigError(f"oracle: method must be one of {list(ORACLE_METHODS)}, got {method!r}")
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if method == "asymptotic":
        res = mannwhitneyu(x, y, alternative="greater", method="asymptotic")
    elif np.unique(np.concatenate([x, y])).size == x.size + y.size:
        res = mannwhitneyu(x, y, alternative="greater", method="exact")
    else:
        splits = comb(x.size + y.size, x.size)
        if min(x.size, y.size) == 1:
            return _single_value_split_p(x, y)
        if splits > MAX_TIED_SPLITS:
            if rng is None:
                raise ConfigError(f"oracle: the exact p value with tied values enumerates C({x.size + y.size}, "
                                  f"{x.size}) = {splits} splits, more than {MAX_TIED_SPLITS}; pass an rng for a "
                                  f"Monte Carlo p value")
            res = mannwhitneyu(x, y, alternative="greater",
                               method=PermutationMethod(n_resamples=MONTE_CARLO_SPLITS, random_state=rng))
        else:
            res = mannwhitneyu(x, y, alternative="greater", method=PermutationMethod(n_resamples=np.inf))
    return float(res.statistic), float(res.pvalue)


def _single_value_split_p(x: np.ndarray, y: np.ndarray) -> tuple[float, float]:
    """Exact permutation p with ties when one sample has a single value (SciPy's machinery needs two).

    There are only ``n + m`` splits: the single value is any one of the pooled values ``v``, and
    its U against the others is ``midrank(v) - 1`` (midranks of the pooled sample).  With one
    faulty value, p is the share of pooled values whose midrank is at least its midrank; with one
    baseline value ``U_x = n m - U_y``, so p is the share whose midrank is at most the baseline's.
    """
    ranks = rankdata(np.concatenate([x, y]))
    u = float(sum((a > b) + 0.5 * (a == b) for a in x for b in y))
    if x.size == 1:
        p = np.mean(ranks >= ranks[0])
    else:
        p = np.mean(ranks <= ranks[-1])
    return u, float(p)


def oracle_detections(results: pd.DataFrame, *, alpha: float = DEFAULT_ALPHA, method: str = "exact") -> pd.DataFrame:
    """Per (suite, run, case, fault): Mann-Whitney U of faulty vs baseline RMS, Holm-corrected.

    Parameters
    ----------
    results : DataFrame
        The runner's results; needs ``run, suite, case, rep, variant, rms_mm, status``.
    alpha : float
        Family-wise error rate of the Holm procedure.
    method : {"exact", "asymptotic"}
        How the p values are computed (module docstring): exact permutation p
        values (default; ties handled exactly), or SciPy's normal approximation
        (explicit, for large samples).

    Returns
    -------
    DataFrame
        One row per (suite, run, case, fault): ``n_faulty, n_baseline``
        (usable repetitions), medians (mm), ``u`` (the faulty sample's U
        statistic), ``p`` (one-sided, uncorrected), ``p_mc_se`` (Monte Carlo
        standard error of ``p``; 0 when enumerated), ``p_min`` (smallest
        attainable exact p for these sample sizes), ``p_holm`` and
        ``detected`` (Holm rejects at ``alpha``).  Rows with no usable
        repetition on one side have NaN statistics, are left out of the Holm
        family, and are not detected.

    Raises
    ------
    ConfigError
        ``alpha`` outside (0, 1) or an unknown ``method``.
    """
    if not 0 < alpha < 1:
        raise ConfigError(f"oracle_detections: alpha must lie in (0, 1), got {alpha!r}")
    if method not in ORACLE_METHODS:
        raise ConfigError(f"oracle_detections: method must be one of {list(ORACLE_METHODS)}, got {method!r}")
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
               "p_mc_se": np.nan, "p_min": np.nan}
        if x.size and y.size:
            splits = comb(x.size + y.size, x.size)
            random = (method == "exact" and splits > MAX_TIED_SPLITS and min(x.size, y.size) > 1
                      and np.unique(np.concatenate([x, y])).size < x.size + y.size)
            rng = np.random.default_rng(np.random.SeedSequence(
                ORACLE_SEED, spawn_key=(stable_code(str(suite)), int(run), int(case), stable_code(str(fault)))))
            u, p = mann_whitney_p(x, y, method=method, rng=rng)
            row.update(u=u, p=p, p_min=1.0 / splits,
                       p_mc_se=float(np.sqrt(p * (1 - p) / MONTE_CARLO_SPLITS)) if random else 0.0)
        rows.append(row)
    table = pd.DataFrame(rows, columns=_COLUMNS[:-2])
    table["p_holm"] = np.nan
    table["detected"] = False
    tested = table["p"].notna().to_numpy()
    if tested.any():
        reject, p_holm = holm(table.loc[tested, "p"].to_numpy(), alpha=alpha)
        table.loc[tested, "p_holm"] = p_holm
        table.loc[tested, "detected"] = reject
    table["detected"] = table["detected"].astype(bool)
    if table.empty:
        return table
    return _sort(table, {"suite": SUITE_ORDER, "run": (), "case": (), "fault": PAPER_FAULTS})
