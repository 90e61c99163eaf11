"""Report of a strategies study: Markdown, the analysis tables as CSV and one figure.

Rendered from one :class:`~faultlab.analysis.study.StudyAnalysis`: detection probability of a
drawn suite against its size per strategy (one panel per fault, one for the mutation score), the
mutation scores at equal size with their paired comparisons, the power statement, the run time
and the machine load.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from faultlab.analysis.study import STUDY_TABLES, StudyAnalysis, analyse_study
from faultlab.report.figures import PAGE_SIZE, suite_palette
from faultlab.report.mutation import markdown_table
from faultlab.runner.progress import format_duration
from faultlab.inference.exact import min_p_value
from faultlab.vocabulary import MDD_COLUMN, POWER_TEXT, SUITE_ORDER, ordered

__all__ = ["FIGURE_FILE", "REPORT_FILE", "detection_figure", "study_markdown", "write_study_report"]

#: File names written by :func:`write_study_report`.
FIGURE_FILE = "detection_vs_size.png"
REPORT_FILE = "study.md"
# strategies differ by marker and line style too, not by colour alone
_MARKERS = ("o", "s", "^", "D", "v", "P")
_LINES = ("-", "--", "-.", ":")


def _pct(x: float) -> str:
    return "n/a" if x is None or not np.isfinite(x) else f"{100 * x:.0f} %"


def _interval(rate: float, lo: float, hi: float) -> str:
    """``rate % (lo-hi)`` in whole percent, with as many decimals as keep a non-zero width visible."""
    digits = 0
    while digits < 3 and hi > lo and f"{100 * lo:.{digits}f}" == f"{100 * hi:.{digits}f}":
        digits += 1
    low, high = f"{100 * lo:.{digits}f}", f"{100 * hi:.{digits}f}"
    if hi > lo and low == high:  # narrower than the last decimal: round outwards, so the width stays visible
        step = 10.0 ** -digits
        low = f"{math.floor(100 * lo / step) * step:.{digits}f}"
        high = f"{math.ceil(100 * hi / step) * step:.{digits}f}"
    return f"{_pct(rate)} ({low}-{high})"


def _p(p: float) -> str:
    return "n/a" if not np.isfinite(p) else (f"{p:.2g}" if p >= 0.001 else "<0.001")


def detection_figure(analysis: StudyAnalysis, *, figsize=PAGE_SIZE) -> Figure:
    """Detection probability of a drawn suite vs its size, per strategy (lines) with 95 % bootstrap
    bands; one panel per fault and a last panel with the expected mutation score."""
    det = analysis.detection[analysis.detection["kind"] == "fault"]
    faults = list(dict.fromkeys(det["variant"]))
    strategies = ordered(det["strategy"], SUITE_ORDER)
    palette = suite_palette(strategies)
    panels = faults + (["mutation score"] if not analysis.scores.empty else [])
    ncols = min(4, len(panels))
    nrows = math.ceil(len(panels) / ncols)
    fig = Figure(figsize=figsize, layout="constrained")
    axes = fig.subplots(nrows, ncols, sharex=True, sharey=True, squeeze=False).ravel()
    for ax, panel in zip(axes, panels):
        frame = analysis.scores.rename(columns={"score": "rate"}) if panel == "mutation score" else \
            det[det["variant"] == panel]
        for k, s in enumerate(strategies):
            rows = frame[frame["strategy"] == s].sort_values("size")
            ax.plot(rows["size"], rows["rate"], marker=_MARKERS[k % len(_MARKERS)], ms=4,
                    ls=_LINES[k % len(_LINES)], color=palette[s], label=s)
            ax.fill_between(rows["size"], rows["ci_low"], rows["ci_high"], color=palette[s], alpha=0.15, lw=0)
        ax.set_title(panel, fontsize=9)
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
    for ax in axes[len(panels):]:
        ax.set_visible(False)
    for ax in axes[(nrows - 1) * ncols:]:
        ax.set_xlabel("suite size (cases)")
    for ax in axes[::ncols]:
        ax.set_ylabel("P(suite detects)")
    axes[0].legend(fontsize=7, loc="lower right")
    m = analysis.meta
    fig.suptitle(f"Detection probability of a suite drawn from each strategy's pool (95 % bootstrap over pool "
                 f"cases; K = {m['repetitions']}, {m['study']['multiplicity']} at alpha = {m['study']['alpha']})",
                 fontsize=10)
    return fig


def _detection_md(analysis: StudyAnalysis) -> pd.DataFrame:
    det = analysis.detection[analysis.detection["kind"] == "fault"]
    strategies = ordered(det["strategy"], SUITE_ORDER)
    rows = []
    for (fault, n), g in det.groupby(["variant", "size"], sort=False):
        g = g.set_index("strategy")
        rows.append({"fault": fault, "size": n} | {s: _interval(g.at[s, "rate_generated"], g.at[s, "ci_low"],
                                                                  g.at[s, "ci_high"])
                                                   for s in strategies if s in g.index})
    return pd.DataFrame(rows)


def _scores_md(analysis: StudyAnalysis) -> pd.DataFrame:
    s = analysis.scores
    strategies = ordered(s["strategy"], SUITE_ORDER)
    rows = []
    for n, g in s.groupby("size"):
        g = g.set_index("strategy")
        rows.append({"size": n} | {st: _interval(g.at[st, "score"], g.at[st, "ci_low"], g.at[st, "ci_high"])
                                   for st in strategies if st in g.index})
    return pd.DataFrame(rows)


def _comparisons_md(analysis: StudyAnalysis) -> pd.DataFrame:
    c = analysis.comparisons
    return pd.DataFrame({
        "size": c["size"], "a vs b": [f"{a} vs {b}" for a, b in zip(c["strategy_a"], c["strategy_b"])],
        "score a - b (95 % CI)": [f"{100 * d:+.0f} pp ({100 * lo:+.0f} to {100 * hi:+.0f})"
                                  for d, lo, hi in zip(c["diff"], c["ci_low"], c["ci_high"])],
        "p (bootstrap)": [_p(p) for p in c["p_boot"]], "p (Holm)": [_p(p) for p in c["p_holm"]],
        f"detectable at {POWER_TEXT}": [f"{100 * d:.0f} pp" if np.isfinite(d) else "n/a (no spread)"
                                       for d in c[MDD_COLUMN]],
        "only a / only b (mean)": [f"{a:.1f} / {b:.1f}" for a, b in zip(c["only_a"], c["only_b"])],
        "McNemar p (median)": [_p(p) for p in c["mcnemar_p_median"]],
        f"drawn pairs with McNemar p <= {analysis.meta['study']['alpha']}": [_pct(x) for x in c["mcnemar_share_sig"]]})


def _detection_comparisons_md(c: pd.DataFrame) -> pd.DataFrame:
    """One row per fault: the pairs whose difference is shown (Holm within the fault), the largest
    equivalence margin of the others and the range of detectable differences."""
    rows = []
    for fault, g in c.groupby("variant", sort=False):
        shown = g[g["shown"]].sort_values("p_holm")
        rest = g[~g["shown"]]
        rows.append({
            "fault": fault,
            "differences shown (a - b, 95 % CI, Holm p)": "; ".join(
                f"{r.strategy_a} - {r.strategy_b} {100 * r.diff:+.0f} pp ({100 * r.ci_low:+.0f} to "
                f"{100 * r.ci_high:+.0f}), {_p(r.p_holm)}" for r in shown.itertuples()) or "none",
            "other pairs equivalent within": f"±{100 * rest['equivalence_margin'].max():.0f} pp" if len(rest) else "-",
            f"detectable at {POWER_TEXT}": f"{100 * g[MDD_COLUMN].min():.0f}-{100 * g[MDD_COLUMN].max():.0f} pp"})
    return pd.DataFrame(rows)


def _detection_means_md(m: pd.DataFrame) -> pd.DataFrame:
    def interval(r) -> str:
        if not np.isfinite(r.ci_low):
            return f"{100 * r.diff:+.1f} pp (cannot be judged: no case's score varies)"
        return f"{100 * r.diff:+.1f} pp ({100 * r.ci_low:+.1f} to {100 * r.ci_high:+.1f})"

    def by_run(r) -> str:
        if "run_diff_low" not in m.columns or not np.isfinite(r.run_diff_low):
            return "n/a"
        return f"{100 * r.run_diff:+.1f} pp ({100 * r.run_diff_low:+.1f} to {100 * r.run_diff_high:+.1f}), {int(r.runs)} runs"

    out = pd.DataFrame({
        "a vs b": [f"{a} vs {b}" for a, b in zip(m["strategy_a"], m["strategy_b"])],
        "mean a": m["mean_a"].map(_pct), "mean b": m["mean_b"].map(_pct),
        "a - b, case as unit (95 % CI)": [interval(r) for r in m.itertuples()],
        "p (Welch)": m["p"].map(_p), "p (Holm)": m["p_holm"].map(_p)})
    if "run_p" in m.columns:
        out["a - b, paired by run (95 % CI)"] = [by_run(r) for r in m.itertuples()]
        out["p by run (t / exact sign-flip)"] = [f"{_p(a)} / {_p(b)}" for a, b in zip(m["run_p"], m["run_p_exact"])]
        out["p by run (Holm)"] = m["run_p_holm"].map(_p)
    out["|a - b| shown below (margin from the data: exploratory)"] = [
        f"{100 * d:.1f} pp" if np.isfinite(d) else "n/a" for d in m["equivalence_margin"]]
    if "analysis" in m.columns:
        out["analysis"] = m["analysis"]
    return out


def _detection_means_text(m: pd.DataFrame, alpha: float) -> str:
    text = (f"Averaged over the {int(m['variants'].iloc[0])} faults: each pool case scores the share of the faults it "
            f"alone detects, and two strategies' pools are compared by Welch's t test with the case as the unit, Holm "
            f"over the {len(m)} pairs; two one-sided tests at {alpha} give the smallest margin within which a "
            f"difference is shown to lie (derived from the data it describes: exploratory, never a declared margin).")
    if "run_p" in m.columns:
        text += (" A pool's cases are nested in evaluation runs (one generated suite per run, stratified for the "
                 "covering strategies), so the same comparison is made with the run as the unit: paired by run, the "
                 "t test and 95 % interval over the runs' differences of the two suites' mean scores, with the exact "
                 "sign-flip p value over runs beside it, Holm over the pairs (`run_*` in `detection_means.csv`); the "
                 "simulations in `tests/inference/test_clusters.py` show the run-level test holding its level at "
                 "11 and 13 runs where the case-level test does not. Where the two answers differ, the run-level "
                 "one is the one the design supports.")
    return text + " (`detection_means.csv`)."


def _detection_comparisons_text(c: pd.DataFrame, alpha: float) -> str:
    pairs = c.groupby("variant").size().max()
    study = int((c["p_holm_study"] <= alpha).sum())
    return (f"the share of a strategy's pool cases that alone detect the fault (a suite of one case), compared "
            f"pair by pair: the difference with its 95 % Agresti-Caffo interval and the two-sided test on the same "
            f"adjusted proportions (statsmodels), Holm over the {pairs} pairs of a fault (the power plan's family). "
            f"{int(c['shown'].sum())} of {len(c)} comparisons are shown at {alpha}; {study} also under Holm over all "
            f"{len(c)} (`p_holm_study` in `detection_comparisons.csv`). For the other pairs, two one-sided tests at "
            f"{alpha} (per pair, not adjusted for the family) show the difference within the margin given (the "
            f"largest over the fault's pairs; each pair's own is `equivalence_margin`). Detectable: the difference a "
            f"pair detects with {POWER_TEXT} power at Holm's first step ({alpha} / {pairs}).")


def _whole_rate(rate: float, lo: float, hi: float, rmin: float, rmax: float, suites: int) -> str:
    """A detection rate with its interval, or a mutation score with its range over suites (no interval)."""
    if np.isfinite(lo) and np.isfinite(hi):
        return _interval(rate, lo, hi)
    if suites == 1:
        return _pct(rate)
    if rmin == rmax:
        return f"{_pct(rate)} (every one of {suites} suites)"
    return f"{_pct(rate)} (range {100 * rmin:.0f}-{100 * rmax:.0f})"


def _whole_md(whole: pd.DataFrame) -> pd.DataFrame:
    return pd.DataFrame({"strategy": whole["strategy"], "variant": whole["variant"],
                         "cases": whole["size"].map(lambda x: f"{x:g}"), "suites": whole["suites"],
                         "detected": [_whole_rate(*row) for row in
                                      zip(whole["rate"], whole["ci_low"], whole["ci_high"], whole["range_min"],
                                          whole["range_max"], whole["suites"])],
                         "paper rule": whole["rate_paper"].map(_pct)})


def _run_text(meta: dict) -> str:
    load = meta.get("load") or {}
    sessions = meta.get("sessions", [])
    started = [s.get("started") for s in sessions if s.get("started")]
    when = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(min(started))) if started else "unknown"
    counts = ", ".join(f"{v} {k}" for k, v in sorted(meta["status_counts"].items()))
    text = (f"Run: {meta['n_jobs']} SLAM executions ({counts}), started {when}, wall time "
            f"{format_duration(meta['wall_time_s'])} over {len(sessions)} session(s) with "
            f"{sessions[0].get('jobs', '?') if sessions else '?'} worker processes on a machine with "
            f"{sessions[0].get('cpus', '?') if sessions else '?'} cores; SLAM time (sum of the jobs' wall times) "
            f"{format_duration(meta['slam_time_s'])}.")
    if load:
        text += (f" The machine was shared: 1-minute load average {load['load1_mean']:.1f} on average "
                 f"(min {load['load1_min']:.1f}, max {load['load1_max']:.1f}; {load['samples']} samples every "
                 f"30 s), so the run had a fraction of the cores and the wall time overstates the cost.")
    return text


def _failures_text(meta: dict) -> str:
    def listing(counts: dict) -> str:
        return ", ".join(f"{v} ({n})" for v, n in counts.items()) or "none"

    return (f"Pool cases the baseline itself failed on (cannot be judged for any variant): "
            f"{meta.get('cannot_judge_cases', 0)}. Variants that alone crashed, with the number of pool cases "
            f"(detections): {listing(meta.get('crash_cases', {}))}. Variants that alone ran out of time "
            f"(untested cases, not detections): {listing(meta.get('timeout_cases', {}))}.")


def _mdd_text(comparisons: pd.DataFrame) -> str:
    mdd = comparisons[MDD_COLUMN].dropna() if not comparisons.empty else pd.Series(dtype=float)
    if mdd.empty:
        return ""
    return (f"For mutation scores the smallest difference detectable with {POWER_TEXT} power ranges from "
            f"{100 * mdd.min():.0f} to {100 * mdd.max():.0f} pp over the comparisons with any bootstrap spread "
            f"(`comparisons.csv`, `{MDD_COLUMN}`).")


def _sidedness(meta: dict) -> str:
    if meta.get("alternative", "greater") == "two-sided":
        return "two-sided (a variant is detected when it changes the map error, worse or better)"
    return "one-sided (the paper's notion: the map gets worse)"


def _not_evaluated_text(meta: dict) -> str:
    missing = meta.get("sizes_not_evaluated") or {}
    if not missing:
        return ""
    return (" Not evaluated: suites of " + ", ".join(f"{n} cases (K >= {k} needed)" for n, k in missing.items())
            + f" -- with K = {meta['repetitions']} no case of such a suite could reject at alpha / n with this test, "
            "so it would detect by crashes only.")


def _weights_text(meta: dict) -> str:
    weights = meta.get("weights") or {}
    classes = weights.get("classes")
    if not classes:
        return ""
    listing = "; ".join(f"{par}: " + ", ".join(f"{c} {w:.2f}" for c, w in sorted(ws.items(), key=lambda x: -x[1]))
                        for par, ws in classes.items())
    source = f"`{weights['file']}`" if weights.get("file") else "the study file's [space.weights]"
    return (f" Effect-guided suites cover every class once, then draw classes by the class weights of {source} "
            f"(an earlier effects study; heaviest first): {listing}; every other parameter's classes have equal "
            f"weights.")


def _whole_not_evaluated_text(meta: dict) -> str:
    missing = meta.get("whole_not_evaluated") or {}
    if not missing:
        return ""
    return ("Not judged whole: " + ", ".join(f"{s} (K >= {k} needed)" for s, k in missing.items())
            + f" -- with K = {meta['repetitions']} no case of such a suite could reject at alpha / n.")


def _declaration_md(meta: dict) -> list[str]:
    d = meta.get("declaration")
    if not d:
        return ["## Declared analyses", "",
                "None: the study declared no analysis before it ran, so every figure below is exploratory.", ""]
    confirmatory = d.get("recorded") == "before the run"
    head = ("Recorded in the results store by `study run` before the first SLAM execution (its metadata checksum "
            "covers it): the analyses below are **confirmatory**; every other figure of this report is exploratory."
            if confirmatory else
            "**Declared after the run**: added to the study's record afterwards, as the plan stood before it ran. "
            "The analyses below are what the study was planned to test, and they too are exploratory; so is every "
            "claim that rests on a margin, since no margin was declared before the run.")
    lines = ["## Declared analyses", "", head, "",
             f"Level alpha = {d['alpha']}, {d['sidedness']} difference tests, multiplicity over the declared "
             f"analyses: {d['family']}, unit of analysis: the {'evaluation run (cases paired by run)' if d['unit'] == 'run' else 'case'}."
             + (f" Note: {d['note']}" if d.get("note") else ""), ""]
    return lines


def _declared_md(declared: pd.DataFrame) -> pd.DataFrame:
    def figure(r) -> str:
        if not np.isfinite(r.estimate):
            return "-"
        if not np.isfinite(r.estimate_low):
            return f"{100 * r.estimate:+.1f} pp (cannot be judged: no spread)"
        return (f"{100 * r.estimate:+.1f} pp ({100 * r.level:.0f} % CI {100 * r.estimate_low:+.1f} to "
                f"{100 * r.estimate_high:+.1f})")

    return pd.DataFrame({
        "declared analysis": declared["analysis"], "status": declared["status"],
        "unit": [f"{u} ({int(n)})" if np.isfinite(n) else u for u, n in zip(declared["unit"], declared["runs"])],
        "a - b": [figure(r) for r in declared.itertuples()],
        "p": declared["p"].map(_p), "p (family)": declared["p_family"].map(_p), "decision": declared["decision"]})


def _controls_md(summary: pd.DataFrame, alpha: float) -> list[str]:
    if summary.empty:
        return ["## Controls: each strategy against itself (A/A)", "",
                "Not possible here: each strategy's pool comes from one evaluation run, so the study holds no two "
                "independent samples of one strategy.", ""]
    kind = "mutant" if summary["comparison"].str.contains("mutant").any() else "fault"
    rows = pd.DataFrame({
        "A/A comparison": [f"{c}, {u} as unit" for c, u in zip(summary["comparison"], summary["unit"])],
        "per comparison (unadjusted, at alpha)": [
            f"{k}/{n} = {_interval(r, lo, hi)}" if n else "none testable (too few runs, or no spread)"
            for k, n, r, lo, hi in
            zip(summary["false_alarms"], summary["comparisons"], summary["false_alarm_rate"],
                summary["false_alarm_rate_low"], summary["false_alarm_rate_high"])],
        "families with a false alarm": [f"{k} of {n} ({rule})" if n else "-" for k, n, rule in
                                        zip(summary["families_with_false_alarm"], summary["families"],
                                            summary["family_rule"])]})
    return ["## Controls: each strategy against itself (A/A)", "",
            "Each strategy's evaluation runs are split in two halves (alternate runs), two independent samples of "
            f"the same strategy, compared with the tests that compare two strategies: per {kind} (Agresti-Caffo, the "
            f"case as unit), and on the mean over the {kind}s with the case (Welch) and the run (paired t over "
            "consecutive runs) as unit. Every rejection is a false alarm. The per-comparison rate (unadjusted, "
            f"nominal {alpha}; 95 % Clopper-Pearson, nominal since one strategy's comparisons share its cases) and "
            f"the family-wise outcome (a family per strategy; nominal at most {alpha} each) are different rates and "
            "are given in separate columns (`controls.csv`, `controls_summary.csv`).", "",
            markdown_table(rows)]


def study_markdown(analysis: StudyAnalysis) -> str:
    """The study's Markdown report."""
    m = analysis.meta
    st = m["study"]
    pools = ", ".join(f"{k} {v}" for k, v in m["pool"].items())
    pool_sizes = dict(zip(analysis.power["strategy"], analysis.power["pool"]))
    slam = m["slam"]
    p = analysis.power
    md = [
        "# Which test-design strategy detects faults with fewer cases?", "",
        ("**Quick scale (reduced).** " if m.get("quick") else "")
        + f"Case pools: {', '.join(f'{s} {n} cases' for s, n in pool_sizes.items())} ({m['runs']} run(s) of the "
        f"generators with suites of {pools} cases). SLAM: {slam.get('name')} with {slam.get('particles')} particles, "
        f"{m['n_steps']} active steps per case (plus the case's inactivity steps), K = {m['repetitions']} "
        f"repetitions per (case, variant) with common random numbers, time limit {m['timeout_s']:g} s per execution. "
        f"Variants: {len(m['faults'])} built-in faults ({', '.join(m['faults'])}) and {len(m['mutants'])} live "
        f"mutants sampled from the screened catalogue of the reference FastSLAM 1.0." + _weights_text(m), "",
        _run_text(m), "",
        _failures_text(m), "",
        *_declaration_md(m),
        *([markdown_table(_declared_md(analysis.declared))] if not analysis.declared.empty else []),
        *_controls_md(analysis.controls_summary, st["alpha"]),
        "## Method", "",
        f"Every pool case ran once per variant; per (case, variant) the kill matrix (`kill_matrix.csv`) keeps the exact "
        f"{_sidedness(m)} paired sign-flip p value over the K repetitions (with the observed direction, worse or "
        f"better), whether the variant alone crashed or timed out, "
        f"and the paper rule's flag. A suite of n cases detects a fault / kills a mutant when the variant crashes on "
        f"one of its cases or when {st['multiplicity'].capitalize()}'s procedure over its n cases rejects one at "
        f"family-wise alpha = {st['alpha']} (for 'some case rejects', Holm and Bonferroni coincide: min p <= alpha/n; "
        f"untestable cases count as p = 1). For every strategy and size {st['draws']} suites were drawn from the pool "
        f"without replacement (Monte Carlo error at most {100 * 0.5 / math.sqrt(st['draws']):.1f} pp; the exact "
        f"hypergeometric value is in `detection.csv`, `rate_exact`). Because every case of a suite of n is judged "
        f"at alpha / n, and K = {m['repetitions']} repetitions give p values no smaller than "
        f"{min_p_value(int(m['repetitions']), alternative=m.get('alternative', 'greater')):.4f}, a variant that only "
        f"some repetitions reveal can become *less* likely to be detected as the suite grows: the price of "
        f"controlling the suite's false alarms." + _not_evaluated_text(m), "",
        "**What the intervals mean.** Drawn suites share pool cases, so their number is not the sample size: the "
        "unit of evidence is the pool case. A detection probability's interval is exact: the Clopper-Pearson 95 % "
        "interval of the strategy's share of strong cases (cases that alone make a suite of this size detect) "
        "from the pool's count, mapped to n independently generated cases -- it never has zero width (0 of 16 "
        "strong cases still allows up to 21 % per case), and the table prints the point of that quantity, "
        "1 - (1 - h/N)^n from the pool's h strong cases of N (the drawn suites' rate, `rate`, and the hypergeometric "
        "`rate_exact` concern suites drawn from this pool and may lie outside it); the 95 % percentile bootstrap over the pool's cases "
        f"({st['bootstrap']} replicates) is kept beside it in `detection.csv` (`boot_low`, `boot_high`; empty where every resample agrees and it has no width). "
        "Mutation scores are bootstrap intervals resampling pool cases and mutants (the same resample for every strategy, "
        "so comparisons are paired over mutants). The bootstrap treats pool cases as independent; the cases of one "
        "covering array or each-choice suite are balanced rather than independent, for which it is conservative. "
        "A score interval where every replicate agrees is replaced by the Clopper-Pearson interval over the "
        "sampled mutants. Intervals do not cover other SLAM settings: these are figures of the reduced SLAM above.", "",
        "## Detection probability of a drawn suite, per fault (95 % exact interval)", "",
        markdown_table(_detection_md(analysis)),
        f"![detection probability vs suite size]({FIGURE_FILE})", "",
    ]
    if not analysis.detection_comparisons.empty:
        c = analysis.detection_comparisons
        md += ["## Strategies compared on the single-case detection probability", "",
               "Exploratory, except the rows the `analysis` column of the CSV tables marks as declared.", ""]
        if not analysis.detection_means.empty:
            md += [_detection_means_text(analysis.detection_means, st["alpha"]), "",
                   markdown_table(_detection_means_md(analysis.detection_means))]
        md += ["Per fault: " + _detection_comparisons_text(c, st["alpha"]), "",
               markdown_table(_detection_comparisons_md(c))]
    if not analysis.scores.empty:
        md += ["## Expected mutation score of a drawn suite (95 % bootstrap interval over cases and mutants)", "",
               markdown_table(_scores_md(analysis)),
               "## Strategies compared at equal size on the same mutants", "",
               "Score difference with its bootstrap interval and two-sided bootstrap p (Holm over the strategy "
               f"pairs of a size); the smallest difference detectable with {POWER_TEXT} power from the bootstrap standard "
               "error; and exact McNemar tests over the mutants for the suites drawn with the same index (statsmodels), "
               "summarised over the drawn pairs (they concern a typical pair of suites, not the strategies).", "",
               markdown_table(_comparisons_md(analysis))]
    if not analysis.whole.empty:
        w = analysis.whole
        md += ["## Whole generated suites", "",
               "Each evaluation run's suite of " + ", ".join(f"`{x}`" for x in dict.fromkeys(w["strategy"]))
               + " judged whole (for pairwise: one whole covering array, randomised independently per run), by the "
               "same suite rule at its own size. The unit is the generated suite: the interval is Clopper-Pearson "
               "over suites; for the mutation score, the lowest and highest score of one suite (a range; with one suite, "
               "its score alone).", "",
               markdown_table(_whole_md(w))]
    if _whole_not_evaluated_text(m):
        md += [_whole_not_evaluated_text(m), ""]
    md += ["## Power", "",
           f"Suites drawn per strategy and size: {st['draws']}; bootstrap replicates: {st['bootstrap']}; pool sizes: "
           + ", ".join(f"{s} {n}" for s, n in pool_sizes.items()) + ". "
           f"A size-1 detection probability is the share of a pool's cases that detect; with these pools a two-sample "
           f"test at {st['alpha']} detects with {POWER_TEXT} power a difference between two strategies of about "
           f"{100 * p[f'{MDD_COLUMN}_at_0.5'].max():.0f} pp around 50 % and "
           f"{100 * p[f'{MDD_COLUMN}_at_0.1'].max():.0f} pp around 10 %. "
           + _mdd_text(analysis.comparisons), "",
           markdown_table(p.round(3)),
           "Files: `kill_matrix.csv` (per pool case and variant), `detection.csv` (every variant, strategy and size; "
           "`rate_paper` = the same under the paper's rule without correction), `detection_means.csv`, `detection_comparisons.csv`, "
           "`scores.csv`, `comparisons.csv`, `power.csv`, `whole.csv`, `study_meta.json`.", ""]
    return "\n".join(md)


def write_study_report(results: str | Path, reports: str | Path) -> list[Path]:
    """Analyse the study in ``results`` and write its CSV tables, ``study.md`` and the figure to ``reports``."""
    analysis = analyse_study(results)
    out = Path(reports)
    analysis.save(out)
    paths = [out / f"{name}.csv" for name in STUDY_TABLES]
    (out / REPORT_FILE).write_text(study_markdown(analysis))
    fig = detection_figure(analysis)
    fig.savefig(out / FIGURE_FILE, dpi=110)
    return paths + [out / REPORT_FILE, out / FIGURE_FILE]
