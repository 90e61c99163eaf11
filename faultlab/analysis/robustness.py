"""Robustness to sensor and hardware faults: how much each fault degrades each SLAM, and where.

:func:`robustness` reads one store per SLAM (the campaign :mod:`faultlab.campaigns.robustness`) and
computes, per (SLAM, sensor fault):

* ``degradation``: the paired effect over cases.  For case ``c`` the log ratio
  ``r_c = log(mean_k faulty_k / mean_k baseline_k)`` of the map errors over the repetitions ``k``
  where both jobs gave an error (the same SLAM seed in both: common random numbers).  The cases
  are the independent units: the effect is the geometric-mean ratio ``exp(mean_c r_c)`` with the
  Student-t confidence interval over cases (:func:`scipy.stats.ttest_1samp`, two-sided, level
  ``1 - alpha``), beside the per-case verdicts of the statistical rule
  (:func:`faultlab.stats.verdict.case_verdicts`: the exact two-sided paired sign-flip test over the
  K repetitions of each case at ``alpha``, family "case") and the failed faulty jobs;
* ``parameters``: a per-parameter view of which Table I parameters make the fault worse: for each
  numeric parameter alone, the least-squares slope of the per-repetition log ratio
  ``log(faulty_k / baseline_k)`` on the parameter (standardised over the cases: the change of the
  log ratio per standard deviation of the parameter), with its CI from standard errors clustered by
  case (:mod:`statsmodels`, ``cov_type="cluster"`` with the small-cluster correction and Student t
  on ``n_cases - 1`` degrees of freedom) and the two-sided p value of a permutation test over cases
  (:func:`scipy.stats.permutation_test`: the parameter values permuted across the cases' mean log
  ratios; exact below :data:`PERMUTATIONS` orderings), beside ``p_min``, the smallest p value that
  permutation test can attain (4 cases: 2/24): the cases are the unit, never the repetitions.  A positive slope
  means the fault degrades the SLAM more where the parameter is larger.  No multiplicity
  correction is applied across parameters: the view ranks, it does not test.

Map errors below :data:`FLOOR_MM` (1 mm, the resolution of the result tables) count as 1 mm in the
ratios: a noise-free case (Table I variance and bias drawn at zero) lets EKF-SLAM and GTSAM recover
the map to 1e-13 mm, and a ratio against that would measure floating-point round-off.

A fault that does not apply to a SLAM (a hardware limit without its option) has no rows; it is
listed in ``not_applicable`` with the store's reason.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from faultlab.faults.sensorfaults import BUILTIN_SENSOR_FAULTS
from faultlab.runner.store import SKIPPED_VARIANTS_KEY, load_metadata, load_results
from faultlab.seeds import study_seed_sequence
from faultlab.space.case import VALUE_KEYS
from faultlab.stats.verdict import EXACT, Verdict, case_verdicts
from faultlab.vocabulary import BASELINE, DEFAULT_ALPHA, JobStatus

__all__ = ["Robustness", "robustness", "case_log_ratios", "rep_log_ratios", "degradation", "parameter_effects",
           "DEGRADATION", "PARAMETERS", "NUMERIC_PARAMETERS", "FLOOR_MM"]

#: The Table I values regressed on (every numeric one; directionality is categorical).
NUMERIC_PARAMETERS: tuple[str, ...] = tuple(k for k in VALUE_KEYS if k != "directionality")
#: Columns of :attr:`Robustness.degradation`.
DEGRADATION: tuple[str, ...] = ("slam", "fault", "metric", "n_cases", "ratio", "ratio_low", "ratio_high",
                                "n_detected", "n_not_detected", "n_crash_detected", "n_cannot_judge",
                                "n_exact", "n_failed", "n_jobs")
#: Columns of :attr:`Robustness.parameters`.
PARAMETERS: tuple[str, ...] = ("slam", "fault", "parameter", "n_cases", "slope", "low", "high", "p", "p_min")
#: Monte Carlo permutations of the per-parameter test where the cases have more orderings than this.
PERMUTATIONS = 9999

_CASE = ["run", "suite", "case"]
#: Map errors below this (mm) count as this in the ratios (the resolution of the result tables).
FLOOR_MM = 1.0


def _paired(results: pd.DataFrame, metric: str) -> pd.DataFrame:
    """Faulty rows joined with the baseline of the same (case, rep); columns ``fault, value, base`` (mm, at
    least :data:`FLOOR_MM`; NaN for a failed job)."""
    col = f"{metric}_mm"
    ok = (results["status"] == JobStatus.OK.value) & np.isfinite(results[col])
    df = results.assign(value=np.maximum(results[col], FLOOR_MM).where(ok))
    base = df.loc[df["variant"] == BASELINE, _CASE + ["rep", "value"]].rename(columns={"value": "base"})
    faulty = df.loc[df["variant"] != BASELINE].rename(columns={"variant": "fault"})
    return faulty.merge(base, on=_CASE + ["rep"], how="left")


def rep_log_ratios(results: pd.DataFrame, *, metric: str = "rms") -> pd.DataFrame:
    """Per usable (case, fault, rep): ``log_ratio = log(faulty / baseline)``, with the case's Table I values."""
    pairs = _paired(results, metric)
    pairs = pairs.loc[pairs["value"].notna() & pairs["base"].notna()].copy()
    pairs["log_ratio"] = np.log(pairs["value"] / pairs["base"])
    keep = _CASE + ["fault", "rep", "log_ratio"] + [k for k in NUMERIC_PARAMETERS if k in pairs.columns]
    return pairs[keep].reset_index(drop=True)


def case_log_ratios(results: pd.DataFrame, *, metric: str = "rms") -> pd.DataFrame:
    """Per (case, fault): ``log_ratio = log(mean faulty / mean baseline)`` over the usable pairs, ``n_pairs``."""
    pairs = _paired(results, metric)
    pairs = pairs.loc[pairs["value"].notna() & pairs["base"].notna()]
    g = pairs.groupby(_CASE + ["fault"], sort=True)
    out = g.agg(value=("value", "mean"), base=("base", "mean"), n_pairs=("value", "size")).reset_index()
    out["log_ratio"] = np.log(out["value"] / out["base"])
    return out[_CASE + ["fault", "log_ratio", "n_pairs"]]


def degradation(log_ratios: np.ndarray, *, alpha: float = DEFAULT_ALPHA) -> tuple[float, float, float]:
    """Geometric-mean ratio ``exp(mean)`` of per-case log ratios and its Student-t CI (NaN bounds below 2 cases)."""
    x = np.asarray(log_ratios, dtype=float)
    x = x[np.isfinite(x)]
    if x.size == 0:
        return math.nan, math.nan, math.nan
    mean = float(np.mean(x))
    if x.size < 2 or np.ptp(x) == 0:
        return math.exp(mean), math.nan, math.nan
    ci = stats.ttest_1samp(x, 0.0).confidence_interval(confidence_level=1 - alpha)
    return math.exp(mean), math.exp(ci.low), math.exp(ci.high)


def _slope_statistic(y: np.ndarray):
    """Least-squares slope of ``y`` on each permuted ``x`` (along ``axis``), for the permutation test."""
    yc = y - y.mean()

    def statistic(x, axis=-1):
        xc = x - x.mean(axis=axis, keepdims=True)
        return (xc * yc).sum(axis=axis) / (xc * xc).sum(axis=axis)
    return statistic


def parameter_effects(reps: pd.DataFrame, *, alpha: float = DEFAULT_ALPHA,
                      rng: np.random.Generator | None = None) -> pd.DataFrame:
    """Per numeric Table I parameter: slope of the log ratio on the standardised parameter, clustered by case.

    Parameters
    ----------
    reps : DataFrame
        Rows of :func:`rep_log_ratios` for one (SLAM, fault).

    Returns
    -------
    DataFrame
        ``parameter, n_cases, slope, low, high, p, p_min``; NaN where the parameter does not vary
        over the cases or there are fewer than 3 cases.  ``rng`` draws the permutations where they
        are not enumerated (more than :data:`PERMUTATIONS` orderings of the cases).
    """
    import statsmodels.api as sm

    rows = []
    groups = reps.groupby(_CASE, sort=True).ngroup().to_numpy()
    n_cases = int(groups.max() + 1) if groups.size else 0
    for name in NUMERIC_PARAMETERS:
        row = dict(parameter=name, n_cases=n_cases, slope=math.nan, low=math.nan, high=math.nan, p=math.nan,
                   p_min=math.nan)
        if name in reps.columns and n_cases >= 3:
            x = reps[name].to_numpy(dtype=float)
            sd = np.std(x)
            if np.ptp(x) > 1e-9 * max(1.0, float(np.max(np.abs(x)))):
                design = np.column_stack([np.ones_like(x), (x - x.mean()) / sd])
                y = reps["log_ratio"].to_numpy(dtype=float)
                fit = sm.OLS(y, design).fit(cov_type="cluster", cov_kwds={"groups": groups}, use_t=True)
                low, high = fit.conf_int(alpha=alpha)[1]
                x_case = np.bincount(groups, weights=design[:, 1]) / np.bincount(groups)
                y_case = np.bincount(groups, weights=y) / np.bincount(groups)
                orderings = math.factorial(n_cases)
                test = stats.permutation_test((x_case,), _slope_statistic(y_case), permutation_type="pairings",
                                              vectorized=True, n_resamples=PERMUTATIONS, alternative="two-sided",
                                              rng=rng)
                p_min = min(1.0, 2.0 / (orderings if orderings <= PERMUTATIONS else PERMUTATIONS + 1))
                row.update(slope=float(fit.params[1]), low=float(low), high=float(high), p=float(test.pvalue),
                           p_min=p_min)
        rows.append(row)
    return pd.DataFrame(rows, columns=list(PARAMETERS[2:]))


@dataclass(frozen=True)
class Robustness:
    """The robustness tables (see the module docstring).

    Attributes
    ----------
    alpha : float
        Level of the per-case tests; 1 - confidence of every interval.
    degradation : DataFrame
        Columns :data:`DEGRADATION`, one row per (SLAM, sensor fault) run.
    parameters : DataFrame
        Columns :data:`PARAMETERS`, one row per (SLAM, sensor fault, numeric parameter).
    not_applicable : DataFrame
        ``slam, fault, reason``: sensor faults skipped for a SLAM.
    protocol : dict
        Per SLAM: cases, K, steps, particles (where it has them), wall time of its sessions (s) and
        ``job_time_s``, the sum of its jobs' SLAM run times (s, wall clock per job: CPU time where the machine is not shared).
    """

    alpha: float
    degradation: pd.DataFrame
    parameters: pd.DataFrame
    not_applicable: pd.DataFrame
    protocol: dict


def _protocol(md: dict) -> dict:
    """What a store's metadata says about the scale of its run."""
    exp = md.get("experiment") or {}
    slam = dict(exp.get("slam") or {})
    return {"slam": slam.get("name", ""), "cases": sum(int(n) for _, n in (exp.get("suites") or ())),
            "repetitions": exp.get("repetitions"), "steps": exp.get("n_steps"), "particles": slam.get("particles"),
            "wall_time_s": md.get("wall_time_s"), "metric": str(md.get("metric") or exp.get("metric") or "rms"),
            "job_time_s": None}


def robustness(stores: Mapping[str, str | Path], *, alpha: float = DEFAULT_ALPHA) -> Robustness:
    """Analyse the robustness campaign's stores (label -> store directory)."""
    sensor = {f.name for f in BUILTIN_SENSOR_FAULTS}
    deg, par, skipped, protocol = [], [], [], {}
    for label, store in stores.items():
        store = Path(store)
        results = load_results(store)
        md = load_metadata(store)
        proto = _protocol(md)
        proto["job_time_s"] = float(results["runtime_s"].sum())
        protocol[label] = proto
        metric = proto["metric"]
        verdicts = case_verdicts(results, alpha=alpha, metric=metric)
        cases = case_log_ratios(results, metric=metric)
        reps = rep_log_ratios(results, metric=metric)
        for fault in [v for v in results["variant"].unique() if v != BASELINE]:
            if fault not in sensor and "/" not in fault:
                continue
            v = verdicts.loc[verdicts["fault"] == fault, "verdict"]
            n_exact = int((verdicts.loc[verdicts["fault"] == fault, "test"] == EXACT).sum())
            jobs = results.loc[results["variant"] == fault]
            ratio, low, high = degradation(cases.loc[cases["fault"] == fault, "log_ratio"], alpha=alpha)
            deg.append(dict(slam=label, fault=fault, metric=metric,
                            n_cases=int((cases["fault"] == fault).sum()), ratio=ratio, ratio_low=low,
                            ratio_high=high, n_detected=int((v == Verdict.DETECTED).sum()),
                            n_not_detected=int((v == Verdict.NOT_DETECTED).sum()),
                            n_crash_detected=int((v == Verdict.CRASH_DETECTED).sum()),
                            n_cannot_judge=int((v == Verdict.CANNOT_JUDGE).sum()), n_exact=n_exact,
                            n_failed=int((jobs["status"] != JobStatus.OK.value).sum()), n_jobs=int(len(jobs))))
            effects = parameter_effects(reps.loc[reps["fault"] == fault], alpha=alpha, rng=np.random.default_rng(
                study_seed_sequence(0, "robustness", label, fault)))
            par.append(effects.assign(slam=label, fault=fault))
        for item in md.get(SKIPPED_VARIANTS_KEY) or ():
            skipped.append(dict(slam=label, fault=item.get("fault", "?"), reason=item.get("reason", "")))
    parameters = (pd.concat(par, ignore_index=True)[list(PARAMETERS)] if par
                  else pd.DataFrame(columns=list(PARAMETERS)))
    return Robustness(alpha=alpha, degradation=pd.DataFrame(deg, columns=list(DEGRADATION)),
                      parameters=parameters,
                      not_applicable=pd.DataFrame(skipped, columns=["slam", "fault", "reason"]),
                      protocol=protocol)

