"""Detection rates with confidence intervals, the paper's "by Suite" figure, false alarms.

Counting unit.  Every faulty *job* -- one (run, suite, case, SLAM repetition)
paired with its baseline -- is one Bernoulli trial.  With K = 1 (the paper's
protocol) that is one trial per test case, as in Table II's "Detected Faults"
column; with K > 1 a case contributes K trials (common random numbers: rep k
uses the same SLAM seed for every variant).  Trials of one case share the
scenario, so with K > 1 the binomial intervals treat clustered trials as
independent and are optimistic; :func:`faultlab.stats.oracle_detections` is the
per-case test that uses the K repetitions properly.

Crashes and timeouts are their own outcome classes.  Rates are given two ways:

* ``k, n, rate, ...`` -- failures **excluded**: ``k = detected``,
  ``n = detected + not_detected``;
* ``k_incl, n_incl, rate_incl, ...`` -- failures **counted as detections**
  (a crash or hang of the faulty SLAM where the baseline ran is an observable
  failure): ``k_incl = detected + crash + timeout``, ``n_incl = n_jobs -
  baseline_failed``.

Jobs whose baseline failed (``baseline_failed``) are in neither denominator.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from statsmodels.stats.proportion import proportion_confint

from faultlab.errors import ConfigError
from faultlab.stats.detection import DetectionRule, _check_columns, detects, outcomes, pair_with_baseline
from faultlab.inference.intervals import clopper_pearson, clustered_rate
from faultlab.vocabulary import BASELINE, DEFAULT_ALPHA, PAPER_FAULTS, SUITE_ORDER, Outcome, ordered

__all__ = ["proportion_ci", "detection_rates", "tabulate_rates", "by_suite", "tabulate_by_suite",
           "false_alarm_rate", "suspected_equivalent_faults", "find_identical_faults", "RATE_COLUMNS",
           "BY_SUITE_COLUMNS", "FALSE_ALARM_COLUMNS"]

_CI_METHODS = {"wilson": "wilson", "cp": "beta"}
_INTERVALS = ("wilson_low", "wilson_high", "cp_low", "cp_high")

#: Columns of :func:`tabulate_rates` (and :func:`detection_rates`).
RATE_COLUMNS: tuple[str, ...] = (
    ("suite", "fault", "n_cases", "n_reps", "n_jobs") + tuple(o.value for o in Outcome)
    + ("k", "n", "rate") + _INTERVALS + ("k_incl", "n_incl", "rate_incl") + tuple(f"{c}_incl" for c in _INTERVALS))
#: Columns of :func:`tabulate_by_suite` (and :func:`by_suite`).
BY_SUITE_COLUMNS: tuple[str, ...] = ("suite", "n_pairs", "detected_pairs", "rate") + _INTERVALS + ("missed",)
#: Columns of :func:`false_alarm_rate`.
FALSE_ALARM_COLUMNS: tuple[str, ...] = ("suite", "n_cases", "n_pairs", "flagged", "rate", "low", "high",
                                        "design_effect")


def proportion_ci(k, n, *, alpha: float = DEFAULT_ALPHA, method: str = "wilson") -> tuple[np.ndarray, np.ndarray]:
    """Two-sided ``1 - alpha`` confidence interval of a binomial proportion.

    Parameters
    ----------
    k, n : int or array_like of int, broadcastable
        Successes and trials: whole numbers (integers or integral floats) with ``0 <= k <= n``.
    alpha : float
        Significance level (0.05 gives 95 % intervals), in (0, 1).
    method : {"wilson", "cp"}
        Wilson score interval or Clopper-Pearson exact interval
        (statsmodels' ``proportion_confint`` methods ``"wilson"`` / ``"beta"``).

    Returns
    -------
    (low, high) : ndarrays (0-d for scalar input)
        NaN where ``n == 0``.

    Raises
    ------
    ConfigError
        Unknown ``method``, ``alpha`` outside (0, 1), or counts that are negative, not whole
        numbers (NaN included) or with ``k > n`` (the message names the first bad value).
    """
    def counts(name: str, value) -> np.ndarray:
        """``value`` as a float array of non-negative whole numbers, or one ConfigError naming the bad entry."""
        try:
            arr = np.asarray(value)
        except Exception:  # ragged input
            raise ConfigError(f"proportion_ci: {name} must be integer counts, got {value!r}") from None
        if arr.dtype == bool or not (np.issubdtype(arr.dtype, np.integer) or np.issubdtype(arr.dtype, np.floating)):
            raise ConfigError(f"proportion_ci: {name} must be integer counts, got {value!r}")
        arr = arr.astype(float)
        bad = ~np.isfinite(arr) | (arr != np.floor(arr))
        if bad.any():
            raise ConfigError(f"proportion_ci: {name} must be integer counts, got {name} = {float(arr[bad].flat[0])!r}")
        if (arr < 0).any():
            raise ConfigError(f"proportion_ci: {name} must be >= 0, got {name} = {arr[arr < 0].flat[0]:g}")
        return arr

    if not isinstance(method, str) or method not in _CI_METHODS:
        raise ConfigError(f"proportion_ci: method must be one of {sorted(_CI_METHODS)}, got {method!r}")
    if isinstance(alpha, bool) or not isinstance(alpha, (int, float, np.integer, np.floating)) \
            or not 0 < alpha < 1:
        raise ConfigError(f"proportion_ci: alpha must lie in (0, 1), got {alpha!r}")
    k = counts("k", k)
    n = counts("n", n)
    try:
        k, n = np.broadcast_arrays(k, n)
    except ValueError:
        raise ConfigError(f"proportion_ci: k and n must be broadcastable, got shapes {k.shape} and {n.shape}") \
            from None
    over = k > n
    if over.any():
        i = np.argwhere(over)[0]
        where = f" at index {tuple(int(j) for j in i)}" if k.ndim else ""
        raise ConfigError(f"proportion_ci: k must not exceed n, got k = {k[tuple(i)]:g} > n = {n[tuple(i)]:g}{where}")
    low = np.full(k.shape, np.nan)
    high = np.full(k.shape, np.nan)
    ok = n > 0
    if np.any(ok):
        if method == "cp":
            lo, hi = clopper_pearson(k[ok], n[ok], alpha=alpha)
        else:
            lo, hi = proportion_confint(k[ok], n[ok], alpha=alpha, method=_CI_METHODS[method])
        low[ok], high[ok] = lo, hi
    return low, high


def _rate_columns(k, n, *, alpha: float, suffix: str = "") -> dict:
    k = np.asarray(k, dtype=np.int64)
    n = np.asarray(n, dtype=np.int64)
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = np.where(n > 0, k / np.maximum(n, 1), np.nan)
    w_lo, w_hi = proportion_ci(k, n, alpha=alpha, method="wilson")
    c_lo, c_hi = proportion_ci(k, n, alpha=alpha, method="cp")
    return {f"k{suffix}": k, f"n{suffix}": n, f"rate{suffix}": rate,
            f"wilson_low{suffix}": w_lo, f"wilson_high{suffix}": w_hi,
            f"cp_low{suffix}": c_lo, f"cp_high{suffix}": c_hi}


def _sort(df: pd.DataFrame, cols: dict) -> pd.DataFrame:
    """Sort by categorical orders given as {column: preferred order}."""
    keys = []
    for col, pref in cols.items():
        order = ordered(df[col], pref)
        keys.append(df[col].map({v: i for i, v in enumerate(order)}).rename(f"_{col}"))
    idx = pd.concat(keys, axis=1).sort_values([k.name for k in keys], kind="stable").index
    return df.loc[idx].reset_index(drop=True)


def detection_rates(results: pd.DataFrame, *, rule: DetectionRule = DetectionRule(),
                    alpha: float = DEFAULT_ALPHA) -> pd.DataFrame:
    """Detection rate per (suite, fault) with Wilson and Clopper-Pearson intervals.

    Parameters
    ----------
    results : DataFrame
        The runner's results (:data:`faultlab.runner.RESULT_COLUMNS`).
    rule : DetectionRule
    alpha : float
        1 - confidence level of the intervals.

    Returns
    -------
    DataFrame
        :func:`tabulate_rates` of :func:`faultlab.stats.outcomes`.
    """
    return tabulate_rates(outcomes(results, rule=rule), alpha=alpha)


def tabulate_rates(pairs: pd.DataFrame, *, alpha: float = DEFAULT_ALPHA) -> pd.DataFrame:
    """Detection rate per (suite, fault) of classified pairs.

    Parameters
    ----------
    pairs : DataFrame
        Output of :func:`faultlab.stats.outcomes` (needs ``run, suite, case, rep,
        fault, outcome``).
    alpha : float
        1 - confidence level of the intervals.

    Returns
    -------
    DataFrame
        One row per (suite, fault), Table II order: ``suite, fault, n_cases``
        (distinct run x case), ``n_reps`` (distinct repetitions), ``n_jobs``,
        the outcome counts ``detected, not_detected, crash, timeout,
        baseline_failed``, then ``k, n, rate, wilson_low, wilson_high, cp_low,
        cp_high`` with failures excluded and the same with suffix ``_incl``
        with crash/timeout counted as detections (module docstring).
    """
    _check_columns(pairs, ("run", "suite", "case", "rep", "fault", "outcome"), where="tabulate_rates")
    oc = pairs
    cols = ["suite", "fault", "n_cases", "n_reps", "n_jobs"] + [o.value for o in Outcome]
    if oc.empty:
        return pd.DataFrame(columns=list(RATE_COLUMNS))
    counts = (pd.crosstab([oc["suite"], oc["fault"]], oc["outcome"])
              .reindex(columns=[o.value for o in Outcome], fill_value=0))
    g = oc.groupby(["suite", "fault"])
    extra = pd.DataFrame({"n_cases": g[["run", "case"]].apply(lambda d: len(d.drop_duplicates())),
                          "n_reps": g["rep"].nunique(), "n_jobs": g.size()})
    table = extra.join(counts).reset_index()
    d, nd = table[Outcome.DETECTED.value], table[Outcome.NOT_DETECTED.value]
    fails = table[Outcome.CRASH.value] + table[Outcome.TIMEOUT.value]
    excl = _rate_columns(d, d + nd, alpha=alpha)
    incl = _rate_columns(d + fails, table["n_jobs"] - table[Outcome.BASELINE_FAILED.value], alpha=alpha,
                         suffix="_incl")
    table = pd.concat([table[cols], pd.DataFrame(excl), pd.DataFrame(incl)], axis=1)[list(RATE_COLUMNS)]
    return _sort(table, {"suite": SUITE_ORDER, "fault": PAPER_FAULTS})


def suspected_equivalent_faults(results: pd.DataFrame) -> list[str]:
    """Faults whose every result equals the baseline's bit for bit.

    A fault whose RMS error is identical to the paired baseline's on every job
    where both finished (``status == "ok"``) never changed the SLAM's output in
    this campaign: it behaves as an *equivalent mutant* here, and its zero
    detection rate says nothing about the suites.  Reports flag such faults
    instead of counting them silently (``python -m faultlab faults --check``
    checks the faults themselves on a scenario built to exercise them).

    Parameters
    ----------
    results : DataFrame
        The runner's results.

    Returns
    -------
    list of str
        :func:`find_identical_faults` of :func:`faultlab.stats.pair_with_baseline`.
    """
    return find_identical_faults(pair_with_baseline(results))


def find_identical_faults(pairs: pd.DataFrame) -> list[str]:
    """Faults whose RMS equals the paired baseline's on every job where both finished.

    Parameters
    ----------
    pairs : DataFrame
        Output of :func:`faultlab.stats.pair_with_baseline` or
        :func:`faultlab.stats.outcomes`.

    Returns
    -------
    list of str
        Fault names, in Table II order; empty when every fault changed at least one result
        (see :func:`suspected_equivalent_faults`).
    """
    _check_columns(pairs, ("fault", "rms_mm", "status", "baseline_rms_mm", "baseline_status"),
                   where="find_identical_faults")
    both_ok = (pairs["status"] == "ok") & (pairs["baseline_status"] == "ok")
    pairs = pairs[both_ok]
    if pairs.empty:
        return []
    same = pairs["rms_mm"].to_numpy(dtype=float) == pairs["baseline_rms_mm"].to_numpy(dtype=float)
    identical = pd.Series(same, index=pairs.index).groupby(pairs["fault"]).all()
    return ordered(identical.index[identical.to_numpy()], PAPER_FAULTS)


def by_suite(results: pd.DataFrame, *, rule: DetectionRule = DetectionRule(), alpha: float = DEFAULT_ALPHA,
             failures_detect: bool = False) -> pd.DataFrame:
    """The paper's "by Suite" figure: share of fault x run pairs the suite detected.

    Parameters
    ----------
    results : DataFrame
    rule : DetectionRule
    alpha : float
    failures_detect : bool
        Count a crash/timeout of the faulty SLAM as a detection (default: no).

    Returns
    -------
    DataFrame
        :func:`tabulate_by_suite` of :func:`faultlab.stats.outcomes`.
    """
    return tabulate_by_suite(outcomes(results, rule=rule), alpha=alpha, failures_detect=failures_detect)


def tabulate_by_suite(pairs: pd.DataFrame, *, alpha: float = DEFAULT_ALPHA, failures_detect: bool = False) -> pd.DataFrame:
    """The "by Suite" figure of classified pairs.

    A (fault, run) pair counts as detected when at least one case (any
    repetition) of the suite in that run detected the fault (Table II, Sec.
    VII-D: "the percentage of faults that the test suite detected in total
    over the three runs").

    Parameters
    ----------
    pairs : DataFrame
        Output of :func:`faultlab.stats.outcomes` (needs ``run, suite, fault, outcome``).
    alpha : float
    failures_detect : bool
        Count a crash/timeout of the faulty SLAM as a detection (default: no).

    Returns
    -------
    DataFrame
        One row per suite: ``suite, n_pairs, detected_pairs, rate``, Wilson
        and Clopper-Pearson bounds (``wilson_low`` ...), and ``missed``: the
        undetected pairs as text, e.g. ``"naive_resampling (run 2)"``.
    """
    _check_columns(pairs, ("run", "suite", "fault", "outcome"), where="tabulate_by_suite")
    hits = {Outcome.DETECTED.value}
    if failures_detect:
        hits |= {Outcome.CRASH.value, Outcome.TIMEOUT.value}
    oc = pairs.assign(hit=pairs["outcome"].isin(hits))
    grouped = oc.groupby(["suite", "fault", "run"], as_index=False)["hit"].any()
    rows = []
    for suite in ordered(grouped["suite"], SUITE_ORDER):
        p = grouped[grouped["suite"] == suite]
        p = _sort(p, {"fault": PAPER_FAULTS, "run": ()})
        missed = "; ".join(f"{r.fault} (run {r.run})" for r in p.itertuples() if not r.hit)
        rows.append({"suite": suite, "n_pairs": len(p), "detected_pairs": int(p["hit"].sum()),
                     "missed": missed})
    table = pd.DataFrame(rows, columns=["suite", "n_pairs", "detected_pairs", "missed"])
    rc = _rate_columns(table["detected_pairs"], table["n_pairs"], alpha=alpha)
    for name in ("rate",) + _INTERVALS:
        table.insert(len(table.columns) - 1, name, rc[name])
    return table[list(BY_SUITE_COLUMNS)]


def false_alarm_rate(results: pd.DataFrame, *, rule: DetectionRule = DetectionRule(),
                     alpha: float = DEFAULT_ALPHA) -> pd.DataFrame:
    """How often the rule flags the *unmodified* SLAM against itself with another seed.

    For every case with at least two usable baseline repetitions, every
    ordered pair of repetitions (k, k'), k != k', is one trial: rep k plays
    "faulty", rep k' the baseline.  The share flagged by ``rule`` estimates the
    rule's false-alarm rate (seed noise alone).  Ordered pairs of one case are
    not independent, so the interval is clustered by case
    (:func:`faultlab.inference.intervals.clustered_rate`: Clopper-Pearson on the
    effective size from a cluster-robust variance).

    Parameters
    ----------
    results : DataFrame
        Needs ``run, suite, case, rep, variant, rms_mm, status``.
    rule : DetectionRule
    alpha : float

    Returns
    -------
    DataFrame
        One row per suite plus a final ``"all"`` row: ``suite, n_cases``
        (cases with >= 2 usable reps), ``n_pairs, flagged, rate``, the clustered
        interval ``low, high`` and the ``design_effect``.  Rates are NaN where no
        case has two reps.
    """
    _check_columns(results, ("run", "suite", "case", "rep", "variant", "rms_mm", "status"),
                   where="false_alarm_rate")
    base = results.loc[(results["variant"] == BASELINE) & (results["status"] == "ok")
                       & np.isfinite(results["rms_mm"].astype(float)), ["run", "suite", "case", "rep", "rms_mm"]]
    key = ["run", "suite", "case"]
    cross = base.merge(base, on=key, suffixes=("_a", "_b"))
    cross = cross[cross["rep_a"] != cross["rep_b"]]
    cross = cross.assign(flag=detects(cross["rms_mm_a"].to_numpy(float), cross["rms_mm_b"].to_numpy(float),
                                      rule=rule) if len(cross) else np.zeros(0, bool))
    suites = ordered(results["suite"], SUITE_ORDER)
    rows = []
    for suite in suites + ["all"]:
        c = cross if suite == "all" else cross[cross["suite"] == suite]
        cr = clustered_rate(c["flag"].to_numpy(bool),
                            (c["run"].astype(str) + "/" + c["suite"].astype(str) + "/" + c["case"].astype(str))
                            .to_numpy(), alpha=alpha)
        rows.append({"suite": suite, "n_cases": len(c[key].drop_duplicates()), "n_pairs": len(c),
                     "flagged": int(c["flag"].sum()), "rate": cr.rate, "low": cr.low, "high": cr.high,
                     "design_effect": cr.design_effect})
    table = pd.DataFrame(rows)
    return table[list(FALSE_ALARM_COLUMNS)]

