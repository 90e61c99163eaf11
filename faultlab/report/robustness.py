"""The robustness report: renders a :class:`faultlab.analysis.robustness.Robustness`.

Writes the tables (``degradation.csv``, ``parameters.csv``, ``not_applicable.csv``,
``protocol.json``), two figures (``degradation.png``: the geometric-mean ratio faulty/baseline per
SLAM and sensor fault with its interval over cases; ``parameters.png``: per SLAM, the slope of the
log ratio on each standardised Table I parameter) and ``README.md``.  Every number comes from the
analysis; nothing is computed here.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from faultlab.analysis.robustness import FLOOR_MM, Robustness
from faultlab.precision import write_csv

__all__ = ["degradation_figure", "parameter_figure", "robustness_markdown", "write_robustness_report"]


def _num(x, fmt: str = ".2f") -> str:
    return "–" if x is None or not math.isfinite(float(x)) else format(float(x), fmt)


def _minutes(seconds) -> str:
    return "–" if seconds is None or not math.isfinite(float(seconds)) else f"{float(seconds) / 60:.1f} min"


def degradation_figure(r: Robustness, *, figsize=(10.0, 5.5)) -> Figure:
    """Geometric-mean ratio faulty/baseline (log scale) per fault, one marker per SLAM, with its interval."""
    fig = Figure(figsize=figsize, layout="constrained")
    ax = fig.add_subplot()
    d = r.degradation
    faults = list(dict.fromkeys(d["fault"]))
    slams = list(dict.fromkeys(d["slam"]))
    width = 0.8 / max(len(slams), 1)
    for i, slam in enumerate(slams):
        rows = d[d["slam"] == slam].set_index("fault")
        y = np.array([faults.index(f) for f in rows.index]) + (i - (len(slams) - 1) / 2) * width
        ratio = rows["ratio"].to_numpy(float)
        low = np.where(np.isfinite(rows["ratio_low"]), rows["ratio_low"], ratio)
        high = np.where(np.isfinite(rows["ratio_high"]), rows["ratio_high"], ratio)
        ax.errorbar(ratio, y, xerr=[ratio - low, high - ratio], fmt="o", ms=4, capsize=2, label=slam)
    ax.axvline(1.0, color="0.5", lw=0.8)
    ax.set_xscale("log")
    ax.set_yticks(range(len(faults)), faults)
    ax.invert_yaxis()
    ax.set_xlabel(f"map error faulty / baseline (geometric mean over cases, {100 * (1 - r.alpha):.0f} % t interval)")
    ax.legend(loc="best", fontsize="small")
    return fig


def parameter_figure(r: Robustness, *, figsize=(12.0, 5.0)) -> Figure:
    """Per SLAM a heat map: slope of the log ratio per standard deviation of each parameter (fault x parameter)."""
    p = r.parameters
    slams = list(dict.fromkeys(p["slam"]))
    fig = Figure(figsize=figsize, layout="constrained")
    axes = fig.subplots(1, max(len(slams), 1), sharey=True, squeeze=False)[0]
    values = p["slope"].to_numpy(float)
    lim = float(np.nanmax(np.abs(values))) if np.isfinite(values).any() else 1.0
    image = None
    for ax, slam in zip(axes, slams):
        table = p[p["slam"] == slam].pivot(index="fault", columns="parameter", values="slope")
        table = table.reindex(index=list(dict.fromkeys(p.loc[p["slam"] == slam, "fault"])),
                              columns=list(dict.fromkeys(p["parameter"])))
        image = ax.imshow(table.to_numpy(float), cmap="RdBu_r", vmin=-lim, vmax=lim, aspect="auto")
        ax.set_title(slam)
        ax.set_xticks(range(table.shape[1]), table.columns, rotation=90, fontsize="small")
        ax.set_yticks(range(table.shape[0]), table.index, fontsize="small")
    if image is not None:
        fig.colorbar(image, ax=list(axes), label="slope of log(faulty/baseline) per SD of the parameter")
    return fig


def _floor(r) -> str:
    """The smallest attainable permutation p of the per-parameter slopes, and the cases it comes from."""
    p = r.parameters.dropna(subset=["p_min"])
    if p.empty:
        return ""
    lo, hi = float(p["p_min"].min()), float(p["p_min"].max())
    cases = sorted(set(int(n) for n in p["n_cases"]))
    text = f"{lo:.2g}" if lo == hi else f"{lo:.2g}-{hi:.2g}"
    return f": {text} with {'/'.join(map(str, cases))} cases"


def robustness_markdown(r: Robustness) -> str:
    """The report page (Markdown)."""
    conf = f"{100 * (1 - r.alpha):.0f} %"
    lines = ["# Robustness to sensor and hardware faults", "",
             "Each sensor fault perturbs the stream a SLAM is fed (never the ground truth, never the scoring; "
             "`faultlab faults` lists them with their parameters); the SLAM's own random stream is the "
             "baseline's (common random numbers), so each repetition is a paired comparison.", "",
             "| SLAM | name | cases | K | active steps | particles | campaign wall time | summed job time |",
             "|---|---|--:|--:|--:|--:|--:|--:|"]
    for label, pr in r.protocol.items():
        lines.append(f"| {label} | {pr['slam']} | {pr['cases']} | {pr['repetitions']} | {pr['steps']} | "
                     f"{pr['particles'] if pr['particles'] is not None else '–'} | {_minutes(pr['wall_time_s'])} | "
                     f"{_minutes(pr['job_time_s'])} |")
    lines += ["", "## Degradation", "",
              f"Per case the log ratio of the mean map errors faulty/baseline over the repetitions where both "
              f"gave an error (errors below {FLOOR_MM:g} mm count as {FLOOR_MM:g} mm: a noise-free case lets "
              f"EKF-SLAM and GTSAM reach round-off level); over the cases (the independent units) the geometric-mean ratio with a {conf} "
              f"Student t interval (a ratio of 1 is no degradation).  Verdicts per case: the exact two-sided "
              f"paired sign-flip test (a change either way) of the K differences faulty - baseline at alpha = {r.alpha:g}, family "
              f"\"case\" (`faultlab.stats.verdict`; a case with fewer than the pairs the test needs cannot be "
              f"judged); a case whose repetitions are bit-identical for the baseline and the faulty SLAM alike (a "
              f"deterministic SLAM fed the same perturbation every time) is judged by its exact difference instead "
              f"(\"judged exactly\"), never by a test over copies of one execution.", "",
              "![degradation](degradation.png)", "",
              "| SLAM | fault | metric | cases | ratio | interval | detected | not detected | crash | cannot judge "
              "| judged exactly | failed jobs |",
              "|---|---|---|--:|--:|---|--:|--:|--:|--:|--:|--:|"]
    for d in r.degradation.itertuples(index=False):
        lines.append(f"| {d.slam} | {d.fault} | {d.metric.upper()} | {d.n_cases} | {_num(d.ratio)} | "
                     f"[{_num(d.ratio_low)}, {_num(d.ratio_high)}] | {d.n_detected} | {d.n_not_detected} | "
                     f"{d.n_crash_detected} | {d.n_cannot_judge} | {d.n_exact} | {d.n_failed}/{d.n_jobs} |")
    lines += ["", "## Which Table I parameters make it worse", "",
              "For each numeric Table I parameter alone: the least-squares slope of the per-repetition log ratio "
              "on the parameter standardised over the cases; its interval from standard errors clustered by "
              "case (statsmodels, small-cluster correction, Student t on cases - 1 degrees of freedom), its p "
              "value from a permutation test over the cases (the parameter's values permuted across the cases' "
              "mean log ratios: the case is the unit, not the repetition), which cannot go below its smallest "
              f"attainable p (`p_min` in `parameters.csv`{_floor(r)}).  Positive: the fault hurts more where the "
              f"parameter is larger.  {conf} intervals, no correction across parameters: a ranking, not a test.  With few cases (few clusters) "
              "the cluster-robust errors are unreliable; read only the larger campaign.", "",
              "![parameters](parameters.png)", "",
              "Strongest parameter per SLAM and fault (largest |slope|):", "",
              "| SLAM | fault | parameter | slope | interval | p (permutation over cases) |", "|---|---|---|--:|---|--:|"]
    p = r.parameters.dropna(subset=["slope"])
    if not p.empty:
        top = p.loc[p.groupby(["slam", "fault"], sort=False)["slope"].apply(lambda s: s.abs().idxmax())]
        for t in top.itertuples(index=False):
            lines.append(f"| {t.slam} | {t.fault} | {t.parameter} | {_num(t.slope)} | [{_num(t.low)}, "
                         f"{_num(t.high)}] | {_num(t.p, '.3f')} |")
    lines += ["", "## Not applicable", ""]
    if r.not_applicable.empty:
        lines.append("Every sensor fault applied to every SLAM.")
    else:
        lines += ["| SLAM | fault | reason |", "|---|---|---|"]
        lines += [f"| {n.slam} | {n.fault} | {n.reason} |" for n in r.not_applicable.itertuples(index=False)]
    lines += ["", "Tables: `degradation.csv`, `parameters.csv`, `not_applicable.csv`, `protocol.json`.", ""]
    return "\n".join(lines)


def write_robustness_report(r: Robustness, out: str | Path, *, intro: str = "") -> Path:
    """Write the tables, both figures and ``README.md`` (``intro`` above the generated page) to ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    write_csv(r.degradation, out / "degradation.csv")
    write_csv(r.parameters, out / "parameters.csv")
    write_csv(r.not_applicable, out / "not_applicable.csv")
    (out / "protocol.json").write_text(json.dumps(r.protocol, indent=1, sort_keys=True) + "\n")
    degradation_figure(r).savefig(out / "degradation.png", dpi=130)
    parameter_figure(r).savefig(out / "parameters.png", dpi=130)
    page = robustness_markdown(r)
    (out / "README.md").write_text((intro.rstrip() + "\n\n" if intro else "") + page)
    return out / "README.md"
