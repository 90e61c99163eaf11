"""An effects study's analysis: responses per case, Morris screening, Sobol indices, regression view.

Reads the stores of :func:`faultlab.campaigns.effects.run_effects` (runs nothing).  For every
response (:mod:`faultlab.stats.responses`: the baseline's difficulty, each fault's effect size,
each fault's detection probability) and stage, the design's response vector (one value per case,
in design order) goes to SALib's estimators (:mod:`faultlab.inference.screening`):

* ``morris``: ``mu*`` (bootstrap interval over trajectories), ``sigma``, ``mu`` for every factor;
  screening (:func:`faultlab.stats.screening.screen_store`) keeps the ``keep`` largest ``mu*`` of the difficulty and of every
  effect response (detection, a coarse 0-1 share, is reported but does not steer screening);
* ``sobol``: ``S1`` and ``ST`` with bootstrap intervals over the kept factors, corrected for the
  repetitions' noise (``noise_var`` = mean squared per-case standard error,
  :func:`~faultlab.inference.screening.sobol_indices`); ``noise`` = ``"yes"`` marks a parameter whose
  estimates cannot be variance shares (an index outside [0, 1] or ``S1 > ST``: :func:`incoherent_indices`);
* ``regression``: the cluster-robust OLS view over the cases of both stages.

A response that some case lacks (every repetition failed) or that does not vary is not estimated;
a note says so.  A study too small for an estimator (fewer than 2 Morris trajectories with a value,
a Sobol stage not run) says what size it needs.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

from faultlab.analysis.sensitivity import REGRESSION_COLUMNS, partial_dependence, regression_view
from faultlab.errors import FaultlabError, ResultsError
from faultlab.inference.screening import MORRIS_COLUMNS, SOBOL_COLUMNS, morris_indices, noise_floor, sobol_indices
from faultlab.runner.store import load_results, results_path
from faultlab.space.case import VALUE_KEYS
from faultlab.space.parameters import space_from_mapping
from faultlab.stats.responses import CASE_KEY, case_responses, rep_values
from faultlab.stats.screening import check_design, read_effects_json, response_seed, saved_design, stage_responses
from faultlab.vocabulary import DEFAULT_ALPHA, EFFECTS_STAGES

__all__ = ["EffectsAnalysis", "analyse_effects", "incoherent_indices", "study_weights", "campaign_effects", "CAMPAIGN_EFFECT_COLUMNS", "CASES_PER_COEFFICIENT"]


@dataclass(frozen=True)
class EffectsAnalysis:
    """Everything the effects report shows.

    Attributes
    ----------
    responses : tuple of str
    morris, sobol, regression : DataFrame
        Long tables with a ``response`` column (:data:`~faultlab.inference.screening.MORRIS_COLUMNS`, ...).
    cases : DataFrame
        One row per (stage, case): parameter values and every response with its standard error.
    partial : DataFrame
        Partial dependence of the top parameters: ``response, parameter, x, mean, std_err, n``.
    kept : tuple of str
    notes : tuple of str
    info : dict
        Scale and cost: settings, design sizes, executions, wall time per stage.
    weights : dict of str to DataFrame
        Per fault with an effect response (``effect:<fault>``): the class weights of an
        ``effect-guided`` suite aimed at it (:func:`study_weights` in the study's space).
    """

    responses: tuple[str, ...]
    morris: pd.DataFrame
    sobol: pd.DataFrame
    regression: pd.DataFrame
    cases: pd.DataFrame
    partial: pd.DataFrame
    kept: tuple[str, ...] = ()
    notes: tuple[str, ...] = ()
    info: dict = field(default_factory=dict)
    weights: dict = field(default_factory=dict)


def analyse_effects(out: str | Path) -> EffectsAnalysis:
    """Analyse an effects study's output directory (module docstring).

    Parameters
    ----------
    out : path
        Output directory of ``faultlab effects run``.

    Raises
    ------
    ResultsError
        Not an effects study, the Morris stage unfinished.
    """
    out = Path(out)
    saved = read_effects_json(out)
    spec = saved["effects"]
    notes: list[str] = []
    exp = saved.get("experiment") or {}
    info = {"settings": spec, "quick": saved.get("quick", False), "stages": {},
            "experiment": {"slam": ", ".join(f"{k} = {v}" for k, v in (exp.get("slam") or {}).items()),
                           "n_steps": exp.get("n_steps"), "repetitions": exp.get("repetitions"),
                           "variants": list(exp.get("variants", [])), "space": saved.get("space") or {}},
            "load": _load(saved.get("sessions", []))}
    morris_rows, sobol_rows, reg_rows, case_frames, pd_rows = [], [], [], [], []
    responses: list[str] = []
    kept = tuple(saved.get("kept") or ())
    for stage in EFFECTS_STAGES:
        store = out / stage
        if not results_path(store).exists() or (stage == "sobol" and not kept):
            if stage == "sobol" and spec.get("sobol_base"):
                notes.append(f"Sobol stage not run yet: needs {spec['sobol_base']} x (k + 2) cases for the k kept "
                             f"factors; run `faultlab effects run` to finish it")
            continue
        design = saved_design(saved, stage)
        check_design(store, design)
        wide, reps, cases, meta = stage_responses(store)
        stored = load_results(store)
        info["stages"][stage] = {"cases": design.n_points, "factors": list(design.factors),
                                 "executions": int(len(stored)),
                                 "slam_time_s": float(pd.to_numeric(stored["runtime_s"], errors="coerce").sum()),
                                 "wall_time_s": float(meta.get("wall_time_s") or 0.0),
                                 "repaired": design.repaired}
        names = [c for c in wide.columns if not c.startswith("se:") and c not in CASE_KEY]
        responses += [r for r in names if r not in responses]
        frame = cases.merge(wide, on=list(CASE_KEY))
        frame.insert(0, "stage", stage)
        case_frames.append(frame)
        for r in names:
            y = wide[r].to_numpy(dtype=float)
            if not np.isfinite(y).all():
                notes.append(f"{stage}, {r}: {int((~np.isfinite(y)).sum())} of {y.size} cases have no value "
                             f"(every repetition failed): not estimated")
                continue
            if not np.ptp(y) > 0:
                notes.append(f"{stage}, {r}: the response does not vary over the design: not estimated")
                continue
            try:
                if stage == "morris":
                    t = morris_indices(design.unit, y, factors=design.factors, levels=design.levels,
                                       seed=response_seed(spec, stage, r), resamples=int(spec["resamples"]))
                    morris_rows.append(pd.DataFrame(t.as_dict()).assign(response=r))
                else:
                    nv = float(np.nanmean(wide[f"se:{r}"].to_numpy(dtype=float) ** 2))
                    t = sobol_indices(y, factors=design.factors, seed=response_seed(spec, stage, r),
                                      resamples=int(spec["resamples"]), noise_var=nv if np.isfinite(nv) else None)
                    t = pd.DataFrame(t.as_dict())
                    sobol_rows.append(t.assign(response=r, noise_floor=noise_floor(y, wide[f"se:{r}"]),
                                               noise=incoherent_indices(t)))
            except FaultlabError as exc:
                notes.append(f"{stage}, {r}: {exc}")
        for r in names:
            rr = reps[reps["response"] == r]
            if rr.empty:
                continue
            need = CASES_PER_COEFFICIENT * (len(design.factors) + 1)
            if len(cases) < need:
                notes.append(f"{stage}, {r}, regression: {len(cases)} cases for {len(design.factors) + 1} "
                             f"coefficients, fewer than the {need} it needs; not fitted")
                continue
            try:
                reg_rows.append(regression_view(rr, cases, factors=design.factors).assign(response=r, stage=stage))
            except FaultlabError as exc:
                notes.append(f"{stage}, {r}, regression: {exc}")
    if not case_frames:
        raise ResultsError(f"{out}: the Morris stage has no results yet; run `faultlab effects run`")
    morris = _concat(morris_rows, MORRIS_COLUMNS)
    sobol = _concat(sobol_rows, SOBOL_COLUMNS + ("noise_floor", "noise"))
    all_cases = pd.concat(case_frames, ignore_index=True)
    # partial dependence of the two top parameters of every response (Sobol ST if there, else mu*)
    for r in responses:
        src = sobol[sobol["response"] == r] if not sobol.empty else sobol
        top = list(src["parameter"].head(2)) if len(src) else \
            (list(morris[morris["response"] == r]["parameter"].head(2)) if not morris.empty else [])
        for p in top:
            col = "directionality" if p == "directionality" else (f"{p}_distance" if p in ("variance", "bias") else p)
            part = partial_dependence(all_cases[col], all_cases[r])
            pd_rows.append(part.assign(response=r, parameter=p, column=col))
    info["executions"] = sum(s["executions"] for s in info["stages"].values())
    info["wall_time_s"] = sum(s["wall_time_s"] for s in info["stages"].values())
    info["slam_time_s"] = sum(s["slam_time_s"] for s in info["stages"].values())
    analysis = EffectsAnalysis(responses=tuple(responses), morris=morris, sobol=sobol,
                               regression=_concat(reg_rows, REGRESSION_COLUMNS + ("stage",)), cases=all_cases,
                               partial=_concat(pd_rows, ("x", "mean", "std_err", "n", "parameter", "column")),
                               kept=kept, notes=tuple(notes), info=info)
    overrides = info["experiment"]["space"]
    space = space_from_mapping(overrides, source="the study's [space]") if overrides else None
    weights = {r.partition(":")[2]: study_weights(analysis, r, space=space)
               for r in analysis.responses if r.startswith("effect:")}
    return replace(analysis, weights=weights)


def _load(sessions: list) -> dict:
    loads = [x for s in sessions for x in (s.get("load_start"), s.get("load_end")) if x is not None]
    if not loads:
        return {}
    return {"min": min(loads), "max": max(loads), "cpus": sessions[-1].get("cpus"), "sessions": len(sessions)}


def incoherent_indices(t: pd.DataFrame) -> np.ndarray:
    """``"yes"`` where a parameter's Sobol estimates cannot be variance shares (``S1`` or ``ST`` outside
    [0, 1], or ``S1 > ST``): estimation noise at this base sample size, not a property of the SLAM; else ``""``."""
    s1, st = t["S1"].to_numpy(float), t["ST"].to_numpy(float)
    with np.errstate(invalid="ignore"):
        bad = (s1 < 0) | (s1 > 1) | (st < 0) | (st > 1) | (s1 > st)
    return np.where(bad, "yes", "")


def _concat(frames: list[pd.DataFrame], columns: Sequence[str] = ()) -> pd.DataFrame:
    """The frames with ``response`` first; an empty table keeps its columns (``columns``)."""
    if not frames:
        return pd.DataFrame(columns=["response", *columns])
    out = pd.concat(frames, ignore_index=True)
    return out[["response"] + [c for c in out.columns if c != "response"]]


def study_weights(analysis: EffectsAnalysis, response: str, *, space=None, floor: float = 0.05) -> pd.DataFrame:
    """Class weights for an ``effect-guided`` suite from an effects study (documented rule).

    1. The *influential* parameters of ``response``: those whose total Sobol index is clear of 0
       (interval above 0); for a study without a Sobol stage, those whose Morris ``mu*`` interval
       is clear of 0.  A response the Sobol stage did not estimate (repetition noise at least its
       variance over the design, or no variation) has no influential parameter.
    2. For every class of an influential parameter, the response's mean over the study's cases in
       that class (both stages), on the ratio scale: ``exp(mean)`` for the log responses
       (difficulty, effect size: the geometric-mean error, or faulty/baseline error ratio, of the
       class), the mean share for a detection response.  A class without study cases gets its
       parameter's mean.
    3. These strengths are normalised within the parameter and mixed with a floor
       (:func:`faultlab.space.settings.weights_from_effects` with them as ``odds_ratio``): a class
       that makes the fault show more is drawn more often, none is left out.
    4. Every other parameter is not listed: the suite gives its classes equal weights.

    Parameters
    ----------
    analysis : EffectsAnalysis
    response : str
        E.g. ``"effect:naive_resampling"``.
    space : ParameterSpace, optional
        The study's space (class names); default Table I.
    floor : float
        Smallest share of a class (see ``weights_from_effects``).

    Returns
    -------
    DataFrame
        ``parameter, class, weight`` (a ``--weights`` CSV of ``faultlab generate``, or ``[weights]``).

    Raises
    ------
    ResultsError
        An unknown response.
    """
    from faultlab.space import table1_space, weights_from_effects, weights_frame

    if response not in analysis.responses:
        raise ResultsError(f"study_weights: no response {response!r} in this study (responses: "
                           f"{', '.join(analysis.responses)})")
    space = space or table1_space()
    if not analysis.sobol.empty:
        s = analysis.sobol[analysis.sobol["response"] == response]
        influential = list(s.loc[s["ST_low"] > 0, "parameter"])
    else:
        m = analysis.morris[analysis.morris["response"] == response] if not analysis.morris.empty else analysis.morris
        influential = list(m.loc[m["mu_star_low"] > 0, "parameter"]) if len(m) else []
    rows = []
    cases = analysis.cases
    for p in influential:
        par = space[p]
        cls = pd.to_numeric(cases[f"class_{p}"], errors="coerce")
        y = pd.to_numeric(cases[response], errors="coerce")
        means = y.groupby(cls).mean()
        fill = float(y.mean())
        for i, name in enumerate(par.class_names):
            v = float(means.get(i, fill))
            v = fill if not np.isfinite(v) else v
            strength = v if response.startswith("detection:") else float(np.exp(v))
            rows.append({"parameter": p, "class": name, "odds_ratio": max(strength, 1e-12)})
    if not rows:
        return weights_frame({})
    return weights_from_effects(pd.DataFrame(rows), floor=floor)


#: Cases per regression coefficient below which a campaign is called too small for the regression view
#: (the usual rule of thumb for linear models: about 10 observations per estimated coefficient).
CASES_PER_COEFFICIENT = 10
#: Columns of :func:`campaign_effects`.
CAMPAIGN_EFFECT_COLUMNS: tuple[str, ...] = ("response", "term", "n_cases", "estimate", "low", "high", "p", "note")


def campaign_effects(results: pd.DataFrame, *, metric: str = "rms", rule=None, alpha: float = DEFAULT_ALPHA) -> pd.DataFrame:
    """The continuous effect analysis of an ordinary campaign (suites drawn for coverage, not a design).

    Per response (difficulty, each fault's effect size; :mod:`faultlab.stats.responses`):

    * ``(mean over cases)``: the mean of the per-case values with its t interval over cases (the
      cases are the independent units);
    * one row per parameter: the cluster-robust regression coefficient per standard deviation
      (:func:`~faultlab.inference.screening.regression_view`) when the campaign has at least
      :data:`CASES_PER_COEFFICIENT` cases per coefficient; otherwise one ``(size)`` row saying how
      many cases it would need, and that a designed study (``faultlab effects run``) is the way to
      rank parameters (with fewer cases the cluster-robust errors are far too small to trust).

    Returns
    -------
    DataFrame
        :data:`CAMPAIGN_EFFECT_COLUMNS`.
    """
    from statsmodels.stats.weightstats import DescrStatsW

    from faultlab.metrics.detection import DetectionRule
    from faultlab.space.case import PARAMETER_NAMES

    rule = rule or DetectionRule()
    key = list(CASE_KEY)
    long = case_responses(results, metric=metric, rule=rule, detection=False)
    reps = rep_values(results, metric=metric)
    cols = key + [c for c in results.columns if c in VALUE_KEYS]
    cases = results.drop_duplicates(key)[cols].reset_index(drop=True)
    X = cases[[c for c in cases.columns if c in VALUE_KEYS]]
    column = {p: f"{p}_distance" if p in ("variance", "bias") else p for p in PARAMETER_NAMES}
    varying = [p for p in PARAMETER_NAMES if column[p] in X.columns and X[column[p]].nunique() > 1]
    n_coef = len(varying) + 1
    need = CASES_PER_COEFFICIENT * n_coef
    rows = []
    for r in dict.fromkeys(long["response"]):
        v = long.loc[long["response"] == r, "value"].to_numpy(dtype=float)
        v = v[np.isfinite(v)]
        n = int(v.size)
        if n >= 2 and not np.ptp(v) > 0:
            rows.append({"response": r, "term": "(mean over cases)", "n_cases": n, "estimate": float(v.mean()),
                         "low": np.nan, "high": np.nan, "p": np.nan,
                         "note": "every case has the same value: no interval"})
        elif n >= 2:
            lo, hi = DescrStatsW(v).tconfint_mean(alpha=alpha)
            p = float(DescrStatsW(v).ttest_mean(0.0)[1])
            rows.append({"response": r, "term": "(mean over cases)", "n_cases": n, "estimate": float(v.mean()),
                         "low": float(lo), "high": float(hi), "p": p, "note": "t interval over cases"})
        else:
            rows.append({"response": r, "term": "(mean over cases)", "n_cases": n, "estimate": np.nan,
                         "low": np.nan, "high": np.nan, "p": np.nan, "note": "fewer than 2 cases with a value"})
        size_note = (f"{n} cases for {n_coef} coefficients ({len(varying)} varying parameters + intercept): the "
                     f"regression view needs about {need} cases ({CASES_PER_COEFFICIENT} per coefficient) to say "
                     f"which parameter matters; a designed study ranks them with far fewer SLAM runs "
                     f"(faultlab effects run)")
        if not varying:
            rows.append({"response": r, "term": "(size)", "n_cases": n, "estimate": np.nan, "low": np.nan,
                         "high": np.nan, "p": np.nan, "note": f"not fitted: no parameter varies among the {n} cases"})
            continue
        if n < need:
            rows.append({"response": r, "term": "(size)", "n_cases": n, "estimate": np.nan, "low": np.nan,
                         "high": np.nan, "p": np.nan, "note": "not fitted: " + size_note})
            continue
        try:
            reg = regression_view(reps[reps["response"] == r], cases, factors=varying, alpha=alpha)
        except FaultlabError as exc:
            rows.append({"response": r, "term": "(size)", "n_cases": n, "estimate": np.nan, "low": np.nan,
                         "high": np.nan, "p": np.nan, "note": f"not fitted: {exc}"})
            continue
        for t in reg.itertuples():
            ok = t.std_err > 0  # residuals cancelling within every case give no interval
            rows.append({"response": r, "term": t.parameter, "n_cases": n, "estimate": t.coef if ok else np.nan,
                         "low": t.low if ok else np.nan, "high": t.high if ok else np.nan,
                         "p": t.p if ok else np.nan,
                         "note": "per SD, cluster-robust by case" if ok else "not fitted: zero standard error"})
    return pd.DataFrame(rows, columns=list(CAMPAIGN_EFFECT_COLUMNS))
