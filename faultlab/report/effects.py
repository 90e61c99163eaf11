"""Report of an effects study: index tables (CSV and Markdown), Morris, Sobol and partial-dependence figures.

Rendered from one :class:`~faultlab.analysis.effects.EffectsAnalysis`:

* ``morris.png``: per response, ``mu*`` against ``sigma`` (Morris' plane: far right = influential,
  high = non-linear or interacting), every parameter labelled, ``mu*``'s bootstrap interval as a
  horizontal bar;
* ``sobol.png``: per response, first-order and total Sobol indices of the kept parameters as bars
  with their bootstrap intervals;
* ``partial.png``: per response, the mean response over the design in bins of each of its two top
  parameters;
* ``morris.csv``, ``sobol.csv``, ``regression.csv``, ``cases.csv``, ``partial.csv`` and
  ``effects.md`` (ranked tables, scale, cost and notes);
* ``weights_<fault>.csv``: class weights of an ``effect-guided`` suite aimed at that fault
  (``EffectsAnalysis.weights``, by :func:`~faultlab.analysis.effects.study_weights`), for ``faultlab generate --weights`` or a
  space file's ``[weights]``.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from faultlab.analysis.effects import EffectsAnalysis, analyse_effects
from faultlab.precision import write_csv
from faultlab.report.figures import PAGE_SIZE
from faultlab.report.mutation import markdown_table
from faultlab.runner.progress import format_duration
from faultlab.stats.responses import DIFFICULTY

__all__ = ["EFFECTS_TABLES", "summary_table", "morris_figure", "sobol_figure", "partial_figure", "effects_markdown",
           "write_effects_report", "response_label"]

#: Tables written as CSV.
EFFECTS_TABLES: tuple[str, ...] = ("morris", "sobol", "regression", "cases", "partial")


def response_label(response: str) -> str:
    """``difficulty`` -> "baseline difficulty: log error"; ``effect:f`` -> "f: log(faulty / baseline)"."""
    if response == DIFFICULTY:
        return "baseline difficulty: log map error"
    kind, _, fault = response.partition(":")
    return f"{fault}: log(faulty / baseline error)" if kind == "effect" else f"{fault}: detection probability"


def _grid(n: int) -> tuple[int, int]:
    ncols = min(3, max(1, n))
    return math.ceil(n / ncols), ncols


def _panels(items, figsize, *, empty: str):
    """A figure with one panel per item; with no items, one panel saying ``empty``."""
    nrows, ncols = _grid(len(items) or 1)
    fig = Figure(figsize=figsize, layout="constrained")
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax in axes[max(len(items), 1):]:
        ax.set_visible(False)
    if not items:
        axes[0].text(0.5, 0.5, empty, ha="center", va="center")
        axes[0].set_axis_off()
    return fig, axes


def morris_figure(analysis: EffectsAnalysis, *, figsize=PAGE_SIZE) -> Figure:
    """Morris' mu*-sigma plane, one panel per response."""
    m = analysis.morris
    responses = [r for r in analysis.responses if not m.empty and r in set(m["response"])]
    fig, axes = _panels(responses, figsize, empty="no Morris indices (see notes)")
    if not responses:
        return fig
    for ax, r in zip(axes, responses):
        t = m[m["response"] == r]
        ax.errorbar(t["mu_star"], t["sigma"], xerr=[t["mu_star"] - t["mu_star_low"], t["mu_star_high"] - t["mu_star"]],
                    fmt="o", ms=4, lw=0.8, capsize=2, color="tab:blue")
        top = t["mu_star"].max()
        for p, x, y in zip(t["parameter"], t["mu_star"], t["sigma"]):
            ax.annotate(p, (x, y), fontsize=6.5, xytext=(3, 2), textcoords="offset points",
                        color="black" if x >= 0.3 * top else "grey")
        lim = max(float(t["mu_star_high"].max()), float(t["sigma"].max())) * 1.1 or 1.0
        ax.plot([0, lim], [0, lim], ls=":", lw=0.7, color="grey")
        ax.set_xlim(0, lim)
        ax.set_ylim(0, lim)
        ax.set_title(response_label(r), fontsize=8.5)
        ax.set_xlabel("mu* (mean |elementary effect|)", fontsize=7.5)
        ax.set_ylabel("sigma", fontsize=7.5)
        ax.tick_params(labelsize=7)
    fig.suptitle("Morris screening: mu* with 95 % bootstrap interval against sigma (dotted: sigma = mu*)",
                 fontsize=10)
    return fig


def sobol_figure(analysis: EffectsAnalysis, *, figsize=PAGE_SIZE) -> Figure:
    """First-order and total Sobol indices with their intervals, one panel per response."""
    s = analysis.sobol
    responses = [r for r in analysis.responses if not s.empty and r in set(s["response"])]
    fig, axes = _panels(responses, figsize, empty="no Sobol indices (see notes)")
    if not responses:
        return fig
    for ax, r in zip(axes, responses):
        t = s[s["response"] == r]
        y = np.arange(len(t))
        ax.barh(y - 0.2, t["ST"], height=0.4, color="tab:orange", label="total ST",
                xerr=[t["ST"] - t["ST_low"], t["ST_high"] - t["ST"]], error_kw={"lw": 0.8, "capsize": 2})
        ax.barh(y + 0.2, t["S1"], height=0.4, color="tab:blue", label="first order S1",
                xerr=[t["S1"] - t["S1_low"], t["S1_high"] - t["S1"]], error_kw={"lw": 0.8, "capsize": 2})
        ax.set_yticks(y, t["parameter"], fontsize=7)
        ax.invert_yaxis()
        ax.axvline(0, color="black", lw=0.6)
        share = float(t["noise_share"].iloc[0])
        ax.set_title(response_label(r) + (f"\nnoise is {share:.0%} of the variance: not informative"
                                          if share > 0.5 else ""), fontsize=8.5)
        ax.tick_params(labelsize=7)
        ax.set_xlabel("share of the response variance", fontsize=7.5)
    axes[0].legend(fontsize=7, loc="lower right")
    fig.suptitle("Sobol indices of the parameters screening kept (95 % bootstrap intervals; repetition noise "
                 "removed)", fontsize=10)
    return fig


def partial_figure(analysis: EffectsAnalysis, *, figsize=PAGE_SIZE) -> Figure:
    """Mean response in bins of each response's two top parameters (both stages' cases)."""
    p = analysis.partial
    pairs = [] if p.empty else list(dict.fromkeys(zip(p["response"], p["parameter"])))
    fig, axes = _panels(pairs, figsize, empty="no partial dependence (see notes)")
    if not pairs:
        return fig
    for ax, (r, par) in zip(axes, pairs):
        t = p[(p["response"] == r) & (p["parameter"] == par)]
        ax.errorbar(t["x"], t["mean"], yerr=1.96 * t["std_err"], fmt="o-", ms=4, lw=1, capsize=2)
        ax.set_title(response_label(r), fontsize=8)
        ax.set_xlabel(t["column"].iloc[0] + (" (1 = loop)" if par == "directionality" else ""), fontsize=7.5)
        ax.tick_params(labelsize=7)
    fig.suptitle("Partial dependence: mean response over the design cases in bins of a top parameter "
                 "(bars: 95 % normal interval over the bin's cases; none where they all agree)", fontsize=10)
    return fig


def _f(x: float, digits: int = 3) -> str:
    return "n/a" if x is None or not np.isfinite(x) else f"{x:.{digits}g}"


def _ci(x, lo, hi) -> str:
    return f"{_f(x)} [{_f(lo)}, {_f(hi)}]"


def _morris_cell(mu_star, lo, hi, sigma) -> str:
    # every elementary effect exactly 0 (mu* = sigma = 0): a bootstrap over them has no width to show
    if mu_star == 0 and sigma == 0:
        return "0 (every elementary effect 0)"
    return _ci(mu_star, lo, hi)


def _morris_md(t: pd.DataFrame) -> str:
    show = pd.DataFrame({"rank": t["rank"], "parameter": t["parameter"],
                         "mu* [95 % CI]": [_morris_cell(a, b, c, d) for a, b, c, d in
                                           zip(t["mu_star"], t["mu_star_low"], t["mu_star_high"], t["sigma"])],
                         "sigma": [_f(x) for x in t["sigma"]], "mu": [_f(x) for x in t["mu"]]})
    return markdown_table(show)


def _sobol_md(t: pd.DataFrame) -> str:
    show = pd.DataFrame({"rank": t["rank"], "parameter": t["parameter"],
                         "ST [95 % CI]": [_ci(a, b, c) for a, b, c in zip(t["ST"], t["ST_low"], t["ST_high"])],
                         "S1 [95 % CI]": [_ci(a, b, c) for a, b, c in zip(t["S1"], t["S1_low"], t["S1_high"])],
                         "clear of 0": ["yes" if lo > 0 else "no" for lo in t["ST_low"]]}
                        | ({"noise": ["yes: not a variance share" if n == "yes" else "" for n in t["noise"]]}
                           if "noise" in t.columns else {}))
    return markdown_table(show)


def _scale_text(analysis: EffectsAnalysis) -> str:
    info = analysis.info
    s = info.get("settings", {})
    exp = info.get("experiment", {})
    lines = [f"Scale{' (--quick)' if info.get('quick') else ''}: Morris {s.get('trajectories')} trajectories x "
             f"{s.get('levels')} levels over {len(s.get('factors', []))} parameters; screening keeps the "
             f"{s.get('keep')} largest mu* per response; Sobol base N = {s.get('sobol_base')}; "
             f"{s.get('resamples')} bootstrap replicates."]
    if exp:
        lines.append(f"SLAM: {exp.get('slam')}; {exp.get('n_steps')} steps, K = {exp.get('repetitions')} "
                     f"repetitions per case (common random numbers), variants {', '.join(exp.get('variants', []))}.")
    space = exp.get("space") or {}
    if space:
        parts = []
        for name, table in space.items():
            classes = table.get("classes") if isinstance(table, dict) else None
            if isinstance(classes, dict):
                parts.append(f"{name} " + ", ".join(f"{c} = {v}" for c, v in classes.items()))
        lines.append("Parameter space: Table I with these classes replaced: " + "; ".join(parts) + ".")
    for stage, st in info.get("stages", {}).items():
        lines.append(f"- {stage}: {st['cases']} cases over {len(st['factors'])} parameters, {st['executions']} "
                     f"SLAM executions, wall time {format_duration(st['wall_time_s'])}, SLAM time "
                     f"{format_duration(st.get('slam_time_s', float('nan')))}"
                     + (f", {st['repaired']} points repaired by constraints" if st.get("repaired") else "") + ".")
    load = info.get("load")
    if load:
        lines.append(f"Machine load (1-minute average, sampled at the start and end of each session): "
                     f"{load['min']:.1f}-{load['max']:.1f} on {load.get('cpus', '?')} cores.")
    return "\n".join(lines)


def summary_table(analysis: EffectsAnalysis) -> pd.DataFrame:
    """Per response: the parameters with a total Sobol index clear of 0 (with the index) and Morris' top three."""
    rows = []
    for r in analysis.responses:
        s = analysis.sobol[analysis.sobol["response"] == r] if not analysis.sobol.empty else analysis.sobol
        m = analysis.morris[analysis.morris["response"] == r] if not analysis.morris.empty else analysis.morris
        clear = s[s["ST_low"] > 0] if len(s) else s
        noisy = len(s) and float(s["noise_share"].iloc[0]) > 0.5
        rows.append({"response": response_label(r),
                     "Sobol ST clear of 0": ("(noise-dominated) " if noisy else "")
                     + (", ".join(f"{p} {_f(v, 2)}" for p, v in zip(clear["parameter"], clear["ST"]))
                        if len(clear) else ("none" if len(s) else "not estimated")),
                     "Morris top 3 (mu*)": ", ".join(f"{p} {_f(v, 2)}" for p, v in
                                                     zip(m["parameter"].head(3), m["mu_star"].head(3)))
                     if len(m) else "not estimated"})
    return pd.DataFrame(rows, columns=["response", "Sobol ST clear of 0", "Morris top 3 (mu*)"])


def effects_markdown(analysis: EffectsAnalysis) -> str:
    """The study as Markdown: scale and cost, then per response the ranked Sobol and Morris tables."""
    out = ["# Effects study: which parameters make the map hard, and which make each fault show", "",
           _scale_text(analysis), "",
           f"Parameters kept by screening: {', '.join(analysis.kept) or '(Sobol stage not run)'}.", "",
           "Responses per case (one value per test case, the unit of evidence): the baseline's difficulty "
           "(mean log map error over the K repetitions), each fault's effect size (mean over repetitions of "
           "log(faulty / baseline error), paired by SLAM seed) and its detection probability. Figures: "
           "`morris.png` (mu*-sigma), `sobol.png` (S1/ST bars), `partial.png` (partial dependence).", ""]
    out += ["## Summary", "", markdown_table(summary_table(analysis)),
            "Parameters whose total Sobol index is clear of 0 (95 % interval above 0), and Morris' three largest "
            "mu*; a response whose repetition noise exceeds half its variance is marked.", ""]
    for r in analysis.responses:
        out += [f"## {response_label(r)}", ""]
        s = analysis.sobol[analysis.sobol["response"] == r] if not analysis.sobol.empty else pd.DataFrame()
        m = analysis.morris[analysis.morris["response"] == r] if not analysis.morris.empty else pd.DataFrame()
        if len(s):
            share = float(s["noise_share"].iloc[0])
            out += [f"Sobol indices (noise share of the variance removed: {_f(share, 2)}):", ""]
            if share > 0.5:
                out += [f"Repetition noise is {_f(share, 2)} of this response's variance over the design: the "
                        f"indices below are not informative (more repetitions per case would be).", ""]
            out += [_sobol_md(s)]
        if len(m):
            out += ["Morris screening:", "", _morris_md(m)]
        if not len(s) and not len(m):
            out += ["Not estimated (see the notes).", ""]
    if analysis.notes:
        out += ["## Notes", ""] + [f"- {n}" for n in analysis.notes] + [""]
    out += ["The regression view (`regression.csv`): per response and stage, OLS of the repetition-level "
            "response on the standardised parameter values (variance and bias by their distance component), "
            "standard errors cluster-robust by case.", ""]
    return "\n".join(out)


def write_effects_report(results: str | Path, reports: str | Path) -> list[Path]:
    """Analyse the effects study in ``results`` and write its tables, ``effects.md`` and figures to ``reports``."""
    analysis = analyse_effects(results)
    out = Path(reports)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in EFFECTS_TABLES:
        path = out / f"{name}.csv"
        write_csv(getattr(analysis, name), path)
        paths.append(path)
    (out / "effects.md").write_text(effects_markdown(analysis))
    paths.append(out / "effects.md")
    for fault, weights in analysis.weights.items():
        path = out / f"weights_{fault}.csv"
        write_csv(weights, path)
        paths.append(path)
    for name, make in (("morris", morris_figure), ("sobol", sobol_figure), ("partial", partial_figure)):
        fig = make(analysis)
        fig.savefig(out / f"{name}.png", dpi=110)
        paths.append(out / f"{name}.png")
    return paths
