"""The cross-SLAM report: renders a :class:`faultlab.analysis.slams.SlamComparison`.

Writes the comparison's tables (CSV + ``protocol.json``), one figure (``slams.png``: baseline
map error per SLAM with its interval, detection rate per SLAM and fault with its interval) and a
Markdown page (``README.md``).  Every number comes from the comparison; nothing is computed here.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from faultlab.analysis.slams import SlamComparison
from faultlab.report.tables import format_pct, verdict_text
from faultlab.vocabulary import DEFAULT_ALPHA, POWER_TEXT

__all__ = ["slam_figure", "slam_markdown", "write_slam_report"]


def _mm(x: float) -> str:
    return "–" if x is None or not math.isfinite(x) else f"{x:,.0f}"


def _shift(x: float) -> str:
    """A detectable shift in mm: "none" when the decision could detect no shift at all, "any" when the
    baseline's repetitions do not vary (a deterministic SLAM: every change of the error is detected)."""
    return "none" if x == math.inf else "any" if x == 0 else _mm(x)


def _factor(ratio: float, low: float, high: float) -> str:
    """A geometric-mean error factor with its interval (none where the test could not give one)."""
    if not math.isfinite(ratio):
        return "–"
    if math.isfinite(low) and math.isfinite(high):
        return f"{ratio:.3g} [{low:.3g}, {high:.3g}]"
    return f"{ratio:.3g} (no interval)"


def _minutes(seconds) -> str:
    if seconds is None or not math.isfinite(float(seconds)):
        return "–"
    return f"{float(seconds) / 60:.1f} min"


def _interval_pct(low: float, high: float) -> str:
    if not (math.isfinite(low) and math.isfinite(high)):
        return "–"
    return f"[{format_pct(low)}, {format_pct(high)}]"


def slam_figure(c: SlamComparison, *, figsize=(11.0, 4.8)) -> Figure:
    """Left: geometric-mean baseline map error per SLAM (log scale, t interval over cases).  Right: case
    detection rate per SLAM and fault (Clopper-Pearson interval)."""
    fig = Figure(figsize=figsize, layout="constrained")
    ax1, ax2 = fig.subplots(1, 2, width_ratios=(1, 1.6))
    acc = c.accuracy
    y = np.arange(len(acc))
    g = acc["gmean_mm"].to_numpy(dtype=float)
    lo = g - acc["gmean_low"].to_numpy(dtype=float)
    hi = acc["gmean_high"].to_numpy(dtype=float) - g
    colours = ["tab:blue" if m == "rms" else "tab:orange" for m in acc["metric"]]
    ax1.barh(y, g, color=colours, xerr=np.vstack([np.nan_to_num(lo), np.nan_to_num(hi)]), capsize=3)
    ax1.set_yticks(y, [f"{s} ({m.upper()})" for s, m in zip(acc["slam"], acc["metric"])])
    ax1.invert_yaxis()
    ax1.set_xscale("log")
    ax1.set_xlabel("baseline map error, mm (geometric mean over cases)")
    sens = c.sensitivity
    faults = list(dict.fromkeys(sens["fault"]))
    slams = list(acc["slam"])
    width = 0.8 / max(1, len(slams))
    for i, slam in enumerate(slams):
        rows = sens[sens["slam"] == slam].set_index("fault")
        x = np.arange(len(faults)) + (i - (len(slams) - 1) / 2) * width
        r = np.array([rows["rate"].get(f, np.nan) for f in faults], dtype=float)
        low = np.array([rows["cp_low"].get(f, np.nan) for f in faults], dtype=float)
        high = np.array([rows["cp_high"].get(f, np.nan) for f in faults], dtype=float)
        ax2.bar(x, np.nan_to_num(r), width, label=slam,
                yerr=np.vstack([np.nan_to_num(r - low), np.nan_to_num(high - r)]), capsize=2)
        for xi, ri in zip(x, r):
            if not math.isfinite(ri):
                ax2.text(xi, 0.02, "n/a", rotation=90, ha="center", va="bottom", fontsize=7)
    ax2.set_xticks(np.arange(len(faults)), [f.replace("_", " ") for f in faults])
    ax2.set_ylim(0, 1.05)
    ax2.set_ylabel("cases detected (statistical rule)")
    ax2.legend(fontsize=7, ncols=3, loc="upper center", bbox_to_anchor=(0.5, -0.1))
    return fig


def slam_markdown(c: SlamComparison, *, figure: str = "slams.png") -> str:
    """The report page (Markdown)."""
    conf = f"{100 * (1 - c.alpha):.0f} %"
    first = next(iter(c.protocol.values()), {})
    rule = first.get("rule") or {}
    lines = ["# The SLAMs under one protocol", "",
             f"Protocol: {first.get('description', '')}.  Every SLAM ran the same cases (suites "
             f"{', '.join(f'{k} {n}' for k, n in first.get('suites') or [])}, {first.get('n_steps')} active "
             f"steps), the same SLAM seeds per repetition (K = {first.get('repetitions')}) and the same faults; "
             f"only the `[slam]` table differs (`protocol.json`).  Intervals are {conf}.  Campaign wall time: "
             + ", ".join(f"{label} {_minutes(p.get('wall_time_s'))}" for label, p in c.protocol.items()) + ".", "",
             f"![baseline error and detection rates]({figure})", "",
             "## Baseline accuracy", "",
             "Map error of the fault-free SLAM: each case contributes the mean of its K repetitions; mean and "
             "geometric mean over the cases with Student t intervals across cases (cases are the independent "
             "units).  SLAMs with landmark ids are scored by the Kabsch-aligned RMS, the unknown-association "
             "FastSLAMs (no ids, so no correspondences) by the earth mover's distance against the whole "
             "ground-truth map, which also charges unmapped and spurious landmarks: the two columns are not "
             "comparable across metrics.", "",
             "| SLAM | association | metric | cases | jobs | mean, mm | interval | geometric mean, mm | interval "
             "| median, mm | failed | median run time, s |",
             "|---|---|---|--:|--:|--:|---|--:|---|--:|--:|--:|"]
    for r in c.accuracy.itertuples(index=False):
        lines.append(f"| {r.slam} | {r.association} | {r.metric.upper()} | {r.n_cases} | {r.n_jobs} | "
                     f"{_mm(r.mean_mm)} | [{_mm(r.mean_low)}, {_mm(r.mean_high)}] | {_mm(r.gmean_mm)} | "
                     f"[{_mm(r.gmean_low)}, {_mm(r.gmean_high)}] | {_mm(r.median_mm)} | {r.n_failed} | "
                     f"{r.runtime_median_s:.2f} |")
    lines += ["", "## Fault sensitivity", "",
              f"Per SLAM and fault: the cases on which the campaign's rule (`{rule.get('rule', 'paper')}`) detects "
              f"the fault, among the cases it could judge, with Clopper-Pearson intervals.  The statistical rule "
              f"is an exact {'two-sided' if rule.get('direction') == 'either' else 'one-sided'} sign-flip test of "
              f"the K paired differences faulty - baseline (repetition r "
              f"of both uses the same SLAM seed) at alpha = {rule.get('alpha', DEFAULT_ALPHA):g}, multiplicity family "
              f"`{rule.get('family', 'fault')}` (`faultlab.stats.verdict`).  Beside it, the share of single "
              f"repetitions the paper's rule flags (faulty error > baseline + {rule.get('abs_mm', 250):g} mm and "
              f">= {100 * rule.get('rel', 0.25):.0f} % more; Wilson intervals): a shift smaller than that can "
              f"still be detected by the test, and a rare large one can be flagged without a detection.  Both "
              f"in the SLAM's metric.  Detectable shift: per judged case, the smallest shift of the error its "
              f"decision detects with {POWER_TEXT} power at the level it was judged at (median over the cases, and their "
              f"range; \"any\" where the baseline's repetitions do not vary, as for a deterministic SLAM): a fault "
              f"not detected on a case may still shift it by less.  A deterministic SLAM (every repetition of a "
              f"case bit-identical, for the baseline and the faulty variant alike: EKF-SLAM and iSAM2) is judged "
              f"exactly: its K repetitions are copies of one execution, so each case is judged by its difference "
              f"(detected when the faulty error differs at all; no test over the copies, no multiplicity), and "
              f"the cases are the unit (\"judged\": sign-flip over the repetitions, or exact).  Campaign level: the "
              f"fault's effect over all its cases, the geometric-mean error factor faulty / baseline with the "
              f"interval of the exact sign-flip test over the cases' mean log ratios (the case is the unit), "
              f"alpha = {rule.get('alpha', DEFAULT_ALPHA):g}, Holm over the SLAM's faults; where too few cases "
              f"let no outcome of that test reach alpha, the verdict says \"cannot judge\" with the smallest "
              f"attainable p, never \"no change\".", "",
              "| SLAM | fault | metric | judged | cases detected | rate, % | interval, % | not judged | detectable "
              "shift, mm (median [range]) | repetitions flagged | rate, % | interval, % | campaign level: error "
              "factor | verdict |",
              "|---|---|---|---|--:|--:|---|--:|---|--:|--:|---|---|---|"]
    for r in c.sensitivity.itertuples(index=False):
        other = "paper's thresholds" if r.rule == "paper" else "sign-flip"
        judged = ("exact" if r.n_exact == r.n and r.n else other if r.n_exact == 0
                  else f"exact {r.n_exact}, {other} {r.n - r.n_exact}")
        lines.append(f"| {r.slam} | {r.fault} | {r.metric.upper()} | {judged} | {r.k}/{r.n} | "
                     f"{format_pct(r.rate)} | "
                     f"{_interval_pct(r.cp_low, r.cp_high)} | {r.n_cannot_judge} | "
                     f"{_shift(r.mde_median_mm)} [{_shift(r.mde_min_mm)}, {_shift(r.mde_max_mm)}] | {r.rep_k}/{r.rep_n} | "
                     f"{format_pct(r.rep_rate)} | {_interval_pct(r.rep_low, r.rep_high)} | "
                     f"{_factor(r.effect_ratio, r.effect_low, r.effect_high)} | "
                     f"{verdict_text(r.effect_verdict, r.effect_p_min) if r.effect_verdict else '–'} |")
    lines += ["", "## What could not be judged", ""]
    if c.not_judged.empty:
        lines.append("Every fault applied to every SLAM and every case got a verdict.")
    else:
        lines += ["| SLAM | fault | what | count | reason |", "|---|---|---|--:|---|"]
        for r in c.not_judged.itertuples(index=False):
            lines.append(f"| {r.slam} | {r.fault} | {r.what} | {r.count or ''} | {r.reason} |")
    lines += ["", "Tables: `accuracy.csv`, `sensitivity.csv`, `not_judged.csv`; the stores: `store/<SLAM>/`.", ""]
    return "\n".join(lines)


def write_slam_report(c: SlamComparison, out: str | Path, *, intro: str = "") -> Path:
    """Write the tables, ``slams.png`` and ``README.md`` (``intro`` above the generated page) to ``out``."""
    out = Path(out)
    c.save(out)
    slam_figure(c).savefig(out / "slams.png", dpi=130)
    page = slam_markdown(c)
    (out / "README.md").write_text((intro.rstrip() + "\n\n" if intro else "") + page)
    return out / "README.md"
