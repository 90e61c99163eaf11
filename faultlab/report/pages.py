"""The pages of ``report.pdf``, each rendered from an :class:`~faultlab.analysis.Analysis`.

One function per kind of page: title, Table II, detection rates, the comparison with the paper,
figures, the test cases (Fig. 5 style, from the saved cases), coverage of Table I, statistics
beyond the paper, run metadata.  They select and format the Analysis' tables; none computes a
statistic.
"""

from __future__ import annotations

import math
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
import seaborn as sns
from matplotlib.figure import Figure

from faultlab import __version__
from faultlab.analysis import BEYOND_THE_PAPER, Analysis
from faultlab.analysis.schema import ALL_VARIANTS, PAPER
from faultlab.errors import FaultlabError
from faultlab.report.casefig import case_title, plot_case
from faultlab.report.comparison import Comparison, Verdict
from faultlab.report.figures import PAGE_SIZE, detection_rate_figure, draw_detection_rates, rms_distribution_figure
from faultlab.report.pdf import PAGE_TITLE_ATTR, new_page, table_pages, text_pages
from faultlab.report.tables import (
    campaign_verdict_line,
    campaign_verdict_note,
    campaign_verdict_records,
    detection_records,
    format_pct,
    format_pct_interval,
    order_suites,
    round_mm,
    suite_label,
    table2_caption,
    table2_frame,
    table2_rows,
    table2_runs,
    variant_label,
    verdict_text,
)
from faultlab.runner.store import case_path
from faultlab.scenario.model import Scenario, load_scenario
from faultlab.stats.cases import AGREEMENT_MARGIN
from faultlab.stats.class_effects import MIN_EPV
from faultlab.inference.exact import alternative_of, min_pairs
from faultlab.vocabulary import POWER_TEXT, JobStatus

__all__ = ["MAX_PICTURED_RUNS", "REPORT_TITLE", "EFFECT_PAGE_TITLE", "CLASS_EFFECT_PAGE_TITLE", "summary_pages",
           "title_pages", "table2_pages", "rates_pages", "comparison_pages",
           "figure_pages", "case_pages", "coverage_pages", "beyond_pages", "metadata_pages"]

#: Runs whose cases are pictured (Fig. 5 style) and whose coverage is tabulated one by one.
MAX_PICTURED_RUNS = 3
#: Title of the report (first page and PDF metadata).
REPORT_TITLE = "faultlab report: the paper's Table II reproduced"
#: Title of the page of continuous per-parameter effects (difficulty and each fault's effect size).
EFFECT_PAGE_TITLE = "Beyond the paper: which scenario parameters drive the map error and the faults"
#: Title of the page of class-indicator logistic regressions of the case verdicts.
CLASS_EFFECT_PAGE_TITLE = "Which classes drive detection (logistic regression over cases)"
#: Evaluation runs per page of Table II in the PDF (5 case columns each: two fit a page at 8 pt).
PDF_RUNS_PER_BLOCK = 2
_GREEN = "#c6efce"  # the paper's green "detected" cells
_RED = "#f4cccc"
_GREY = "#eeeeee"
_PANELS_PER_ROW = 5
_ROWS_PER_PAGE = 3


def _titled(fig: Figure, title: str) -> Figure:
    setattr(fig, PAGE_TITLE_ATTR, title)
    return fig


def _fmt_seconds(s: float | None) -> str:
    if s is None or not math.isfinite(float(s)):
        return "unknown"
    s = float(s)
    if s < 120:
        return f"{s:.1f} s"
    if s < 7200:
        return f"{s / 60:.1f} min"
    return f"{s / 3600:.2f} h"


def _frame_text(frame: pd.DataFrame, digits: int = 3) -> pd.DataFrame:
    def fmt(v):
        if isinstance(v, (bool, np.bool_)):
            return "yes" if v else "no"
        if isinstance(v, (float, np.floating)):
            if not math.isfinite(v):
                return ""
            return f"{v:.{digits}g}"
        return str(v)

    return frame.apply(lambda col: col.map(fmt)).astype(str)


def _without_empty_columns(frame: pd.DataFrame) -> tuple[pd.DataFrame, list[str]]:
    """``frame`` (cells as text) without its columns that are empty in every row, and their names."""
    empty = [c for c in frame.columns if len(frame) and (frame[c].astype(str).str.strip() == "").all()]
    return frame.drop(columns=empty), empty


def _left_out(columns: list[str]) -> str:
    return "" if not columns else (f" Left out, empty for every case of this campaign: "
                                   f"{', '.join(columns)}.")


def _g3(value: float) -> str:
    return "" if not math.isfinite(value) else f"{value:.3g}"


# --------------------------------------------------------------------------- summary

#: Title of the report's first page.
SUMMARY_TITLE = "Summary: what this run detected"


def _detected_lines(analysis: Analysis) -> list[str]:
    """One line per fault: the cases whose test detects it, per suite (the campaign's own rule)."""
    lines = []
    case_rates = analysis.case_rates
    if len(case_rates):  # K >= 2 repetitions: one verdict per case from all its repetitions
        conf = round_mm(100 * (1 - analysis.alpha))
        campaign = {r.fault: r for r in analysis.campaign_verdicts.itertuples(index=False)}
        for fault, rows in case_rates.groupby("fault", sort=False):
            k, n = int(rows["k"].sum()), int(rows["n"].sum())
            per = ", ".join(f"{suite_label(r.suite)} {int(r.k)}/{int(r.n)}" for r in rows.itertuples())
            whole = f"; {campaign_verdict_line(campaign[fault])}" if fault in campaign else ""
            lines.append(f"- {variant_label(fault)}: detected on {k} of {n} judged cases by the "
                         f"{rows['rule'].iloc[0]} rule ({per}; {conf} % Clopper-Pearson per suite in the tables)"
                         f"{whole}.")
        return lines
    rates = analysis.detection_rates
    for fault in dict.fromkeys(rates["variant"]):
        rows = rates[rates["variant"] == fault]
        k, n = int(rows["k"].sum()), int(rows["n"].sum())
        per = ", ".join(f"{suite_label(r.suite)} {int(r.k)}/{int(r.n)}" for r in rows.itertuples())
        lines.append(f"- {variant_label(fault)}: detected on {k} of {n} case pairs ({per}).")
    return lines


def summary_pages(analysis: Analysis, comparison: Comparison) -> list[Figure]:
    """One page: what was run, what was detected, the agreement with the paper, and one figure."""
    meta = analysis.metadata
    exp = meta.get("experiment") or {}
    slam = exp.get("slam") or {}
    counts = analysis.status_counts
    failed = counts[JobStatus.CRASH.value] + counts[JobStatus.TIMEOUT.value]
    lines = [
        f"{meta.get('experiment_source', '?')} ({meta.get('description', '')}): "
        f"{exp.get('runs', '?')} evaluation run(s), "
        f"{sum(analysis.cases_per_run.values())} cases per run, {exp.get('repetitions', 1)} SLAM repetition(s) "
        f"per case, SLAM {slam.get('name', '?')}; {analysis.n_rows} SLAM executions ({failed} crashed or timed "
        f"out). Detection rule: {analysis.rule.describe()}.",
        *(_detected_lines(analysis) or ["- No faulty variant was run."]),
        "Agreement with the paper: " + comparison.summary(),
    ]
    rules = set(analysis.case_rates["rule"]) if len(analysis.case_rates) else set()
    if rules - {"paper"} or int(exp.get("repetitions", 1) or 1) > 1:
        lines.append("The figure: the paper's rule on one SLAM pair per case (repetition 0), as the paper judged "
                     "it; the lines above judge each case from all its repetitions.")
    w, h = PAGE_SIZE
    fig = new_page(SUMMARY_TITLE, REPORT_TITLE)
    y = 1 - 1.25 / h
    for block in lines:
        for line in textwrap.wrap(block, 150, subsequent_indent="   " if block.startswith("- ") else ""):
            fig.text(0.6 / w, y, line, fontsize=9.5, va="top", ha="left")
            y -= 0.19 / h
        y -= 0.06 / h
    with sns.axes_style("whitegrid"):
        ax = fig.add_axes([0.9 / w, 0.75 / h, (w - 3.6) / w, max(0.2, y - 1.35 / h)])
    if not draw_detection_rates(ax, analysis):
        ax.set_visible(False)
    return [fig]


# --------------------------------------------------------------------------- title


def _run_blocks(analysis: Analysis) -> list[str]:
    """The title page's description of the campaign."""
    meta = analysis.metadata
    exp = meta.get("experiment") or {}
    slam = exp.get("slam") or {}
    suites = ", ".join(f"{s} {n}" for s, n in analysis.cases_per_run.items())
    counts = analysis.status_counts
    return [
        "## This run",
        f"- Experiment: {meta.get('experiment_source', '?')} — {meta.get('description', '')}",
        f"- Protocol: {exp.get('runs', '?')} evaluation run(s); suites {suites or '?'} cases per run; "
        f"variants {', '.join(meta.get('variants', [])) or '?'}; {exp.get('repetitions', 1)} SLAM "
        f"repetition(s) per case; {exp.get('n_steps', '?')} steps per case; SLAM "
        f"{slam.get('name', '?')} with {slam.get('particles', '?')} particles.",
        f"- Results: {analysis.n_rows} jobs — " + ", ".join(f"{counts[s.value]} {s.value}" for s in JobStatus) + ".",
        f"- Detection rule (Sec. VII-A): {analysis.rule.describe()}.",
        f"- Wall time of the campaign: {_fmt_seconds(meta.get('wall_time_s'))}; faultlab "
        f"{meta.get('faultlab_version', '?')} (report built with {__version__}).",
    ]


def title_pages(analysis: Analysis, comparison: Comparison, notes: list[str]) -> list[Figure]:
    """What was run, how it compares with the paper, what the report holds, and its notes."""
    blocks = [
        "This report reproduces the evaluation of Tasche & Herber, 'A Coverage-Driven Systematic "
        "Test Approach for Simultaneous Localization and Mapping' (Sec. VII, Table II) with faultlab, "
        "and extends it with statistics the paper could not afford. It was built from saved results "
        "only (python -m faultlab report RESULTS rebuilds it).",
        *_run_blocks(analysis),
        "## Agreement with the paper",
        comparison.summary(),
    ]
    dis = comparison.by_verdict(Verdict.DISAGREES)
    if dis:
        blocks.append("Disagreements: " + "; ".join(
            f"{suite_label(s.suite)}{' / ' + variant_label(s.variant) if s.variant else ''} ({s.topic})"
            for s in dis) + ".")
    blocks += [
        "## Contents",
        "- Table II of this run beside the paper's; detection rates with confidence intervals; "
        "the comparison with the paper in words; detection-rate and RMS-distribution figures; the "
        "test cases of each suite (Fig. 5 style) and each suite's coverage of Table I; statistics "
        "beyond the paper (false alarms, statistical oracle, suite comparisons, parameter effects); "
        "run metadata.",
    ]
    if notes:
        blocks.append("## Notes")
        blocks += [f"- {n}" for n in notes]
    meta = analysis.metadata
    return text_pages(REPORT_TITLE, blocks, subtitle=f"experiment hash {str(meta.get('experiment_hash', ''))[:16]}")


# --------------------------------------------------------------------------- Table II and rates


def _table2_styles(analysis: Analysis, frame: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Cell colours and bold flags of one block of Table II: detected green, failed red, paper grey."""
    lookup = {(r.source, r.suite, r.variant, int(r.run), int(r.case)): r
              for r in analysis.table2_cells.itertuples(index=False)}
    colours = pd.DataFrame("", index=frame.index, columns=frame.columns)
    bold = pd.DataFrame(False, index=frame.index, columns=frame.columns)
    for i, (suite, variant, source) in enumerate(table2_rows(analysis)):
        if source == PAPER:
            colours.iloc[i, :3] = _GREY
        for col in frame.columns:
            if not (col.startswith("R") and "C" in col[1:]):
                continue
            run, case = (int(x) for x in col[1:].split("C"))
            cell = lookup.get((source, suite, variant, run, case))
            if cell is None:
                continue
            if cell.status in (JobStatus.CRASH.value, JobStatus.TIMEOUT.value):
                colours.loc[i, col] = _RED
            elif cell.detected:
                colours.loc[i, col] = _GREEN
                bold.loc[i, col] = True
    return colours, bold


def table2_pages(analysis: Analysis) -> list[Figure]:
    """Table II beside the paper's, three evaluation runs per page block, the paper's colours."""
    runs = table2_runs(analysis)
    blocks = [runs[i:i + PDF_RUNS_PER_BLOCK] for i in range(0, len(runs), PDF_RUNS_PER_BLOCK)] or [[]]
    note = (table2_caption(analysis) + " Green: detected. Red: crash or timeout. Paper rows: the "
            "replication package's raw RMS errors rounded to mm (the printed Table II differs from "
            "them in a few cells: python -m faultlab paper-table lists them).")
    pages = []
    for block in blocks:
        frame = table2_frame(analysis, style="plain", runs=block)
        colours, bold = _table2_styles(analysis, frame)
        title = "Table II: this run beside the paper"
        if len(blocks) > 1:
            title += (f" (evaluation runs {block[0]}-{block[-1]})" if len(block) > 1
                      else f" (evaluation run {block[0]})")
        pages += table_pages(title, frame, colours=colours, bold=bold, note=note, max_rows=40, key_columns=3,
                             fontsize=8,
                             subtitle="columns R<run>C<case>: RMS map error of test case <case> "
                                      "in evaluation run <run>, mm")
    return pages


def _by_suite_records(analysis: Analysis) -> pd.DataFrame:
    conf = round_mm(100 * (1 - analysis.alpha))
    mine = analysis.by_suite.set_index("suite")
    paper = analysis.paper_by_suite.set_index("suite")
    rows = []
    for s in order_suites(list(mine.index) + list(paper.index)):
        rec = {"Suite": suite_label(s)}
        if s in mine.index:
            m = mine.loc[s]
            rec["this run"] = f"{format_pct(m['rate'])} % ({m['detected_pairs']}/{m['n_pairs']})"
            rec[f"Wilson {conf} %"] = format_pct_interval(m["wilson_low"], m["wilson_high"])
        if s in paper.index:
            p = paper.loc[s]
            rec["paper (rule)"] = f"{format_pct(p['rate'])} % ({p['detected_pairs']}/{p['n_pairs']})"
            rec["paper (printed)"] = "" if pd.isna(p["reported_pct"]) else f"{round_mm(p['reported_pct'])} %"
        rows.append(rec)
    return pd.DataFrame(rows)


def rates_pages(analysis: Analysis) -> list[Figure]:
    """Detected faults per suite and fault (Table II's right-hand columns) and "by Suite"."""
    note = ("k/n: faulty jobs detecting the fault among those where both the faulty and the baseline "
            "SLAM produced a map (the paper's 'Detected Faults'). Crashes and timeouts of the faulty "
            "SLAM are their own outcome classes; 'Rate % incl. failures' counts them as detections. "
            "'base failed': the baseline produced no map, so the case judges nothing. Paper (rule): "
            "this run's detection rule applied to the paper's raw RMS data; printed: Table II as "
            "printed.")
    pages = table_pages("Detected faults per suite and fault (Table II, right-hand columns)",
                        detection_records(analysis, compact=True), note=note, fontsize=8)
    pages += table_pages("by Suite: fault x run pairs detected by at least one case",
                         _by_suite_records(analysis), fontsize=9,
                         note="The paper's 'by Suite' column: the share of fault x run pairs in "
                              "which at least one case of the suite detected the fault.")
    return pages


def comparison_pages(comparison: Comparison) -> list[Figure]:
    """The comparison with the paper, statement by statement, grouped by suite."""
    blocks = [
        comparison.summary(),
        f"Criteria. Baseline rows: the fixed suite agrees when every baseline RMS error lies in the "
        f"paper's range widened by a factor of {comparison.range_factor:g} on both sides; the "
        f"systematic and random suites (parameters varied on purpose) agree when their ranges overlap "
        f"the widened range. Fault rows: agree when the suite detects the fault at all exactly when "
        f"the paper's did, and the paper's rate (its raw data, this rule) lies inside this run's 95 % "
        f"Wilson interval. by Suite: the paper's share lies inside this run's interval. Claims: the "
        f"qualitative conclusions of Sec. VII-D.",
    ]
    groups: dict[str, list[str]] = {}
    for s in comparison.statements:
        head = ("The paper's claims (Sec. VII-D)" if s.topic == "claim"
                else f"{suite_label(s.suite)} suite")
        groups.setdefault(head, []).append(f"- [{str(s.verdict).upper()}] {s.text}")
    for head, lines in groups.items():
        blocks.append("## " + head)
        blocks += lines
    return text_pages("Comparison with the paper, row by row", blocks)


def figure_pages(analysis: Analysis) -> list[Figure]:
    """Detection rates with intervals, and the RMS distributions (the paper's beside)."""
    return [_titled(detection_rate_figure(analysis),
                    "Detection rates per suite and fault with confidence intervals"),
            _titled(rms_distribution_figure(analysis),
                    "RMS map error distributions per suite and variant (log scale)")]


# --------------------------------------------------------------------------- test cases


def _load_run_cases(store_dir: Path, analysis: Analysis, run: int) -> tuple[list[tuple[str, list]], list, int]:
    """Rows of panels ``(suite, [(case, Scenario)])`` of one run, seed rows, why each unreadable file is."""
    cases = analysis.cases[analysis.cases["run"] == run]
    rows: list[tuple[str, list[tuple[int, Scenario]]]] = []
    seeds, missing = [], []
    for suite in order_suites(cases["suite"]):
        loaded = []
        for c in sorted(int(c) for c in cases.loc[cases["suite"] == suite, "case"]):
            try:
                loaded.append((c, load_scenario(case_path(store_dir, run, suite, c))))
            except (FaultlabError, OSError) as exc:
                missing.append(str(exc))
        seeds += [(run, suite, c, sc.seed, sc.landmarks.shape[0], sc.n_steps) for c, sc in loaded]
        rows += [(suite, loaded[i:i + _PANELS_PER_ROW]) for i in range(0, len(loaded), _PANELS_PER_ROW)]
    return rows, seeds, missing


def _case_page(run: int, rows: list[tuple[str, list]], continued: bool) -> Figure:
    """One page of Fig. 5-style panels: a row per suite (wrapped after five cases)."""
    title = (f"Test cases of evaluation run {run} (Fig. 5 style: landmarks orange, "
             f"true path blue)" + (" (continued)" if continued else ""))
    fig = _titled(Figure(figsize=PAGE_SIZE), title)
    fig.suptitle(title, fontsize=13, fontweight="bold")
    axes = fig.subplots(len(rows), _PANELS_PER_ROW, squeeze=False)
    for r, (suite, panel) in enumerate(rows):
        for k in range(_PANELS_PER_ROW):
            ax = axes[r][k]
            if k >= len(panel):
                ax.set_axis_off()
                continue
            c, sc = panel[k]
            *what, steps = case_title(sc).split(", ")
            plot_case(sc, ax, title=f"{suite_label(suite)} case {c}\n{', '.join(what)}\n{steps}")
            ax.title.set_fontsize(7)
            ax.tick_params(labelsize=6.5)
            ax.set_xlabel("")
            ax.set_ylabel("")
    fig.subplots_adjust(left=0.04, right=0.98, top=0.87, bottom=0.075, hspace=0.62, wspace=0.32)
    return fig


def case_pages(store_dir: Path, analysis: Analysis) -> tuple[list[Figure], list, list[str]]:
    """Fig. 5-style pictures of the saved cases (runs 1..MAX_PICTURED_RUNS), their seeds, notes.

    The cases are read from the results store's ``cases/`` directory; files that cannot be read
    are left out and counted in a note.
    """
    runs = sorted(int(r) for r in analysis.cases["run"].unique())
    pages, seeds, notes, missing = [], [], [], []
    for run in runs[:MAX_PICTURED_RUNS]:
        rows, run_seeds, run_missing = _load_run_cases(store_dir, analysis, run)
        seeds += run_seeds
        missing += run_missing
        for start in range(0, len(rows), _ROWS_PER_PAGE):
            pages.append(_case_page(run, rows[start:start + _ROWS_PER_PAGE], continued=start > 0))
    if missing:
        notes.append(f"{len(missing)} saved test case file(s) under {store_dir}/cases could not be "
                     f"read; their pictures are left out: {'; '.join(missing[:3])}"
                     + (f"; and {len(missing) - 3} more" if len(missing) > 3 else "") + ".")
    if len(runs) > MAX_PICTURED_RUNS:
        notes.append(f"test cases are pictured for evaluation runs 1-{MAX_PICTURED_RUNS} of {len(runs)}.")
    return pages, seeds, notes


# --------------------------------------------------------------------------- coverage


def _coverage_frame(coverage: pd.DataFrame) -> pd.DataFrame | None:
    """One scope's coverage: per parameter, classes and each suite's covered share and gaps."""
    frame = None
    for suite in order_suites(coverage["suite"]):
        t = coverage[coverage["suite"] == suite].reset_index(drop=True)
        label = suite_label(suite)
        shown = pd.DataFrame({
            "parameter": t["parameter"], "classes": t["classes"],
            label: [f"{c}/{k} ({100 * r:.0f} %)" for c, k, r in zip(t["covered"], t["classes"], t["coverage"])],
            f"{label}: uncovered": np.where(t["parameter"] == "overall", t["counts"],
                                            t["uncovered"].replace("", "-")),
        })
        frame = shown if frame is None else frame.merge(shown, on=["parameter", "classes"])
    return frame


def coverage_pages(analysis: Analysis) -> list[Figure]:
    """Each suite's coverage of Table I's classes, per pictured run and pooled over the runs."""
    cov = analysis.coverage
    runs = sorted(int(r) for r in cov["run"].dropna().unique())
    n_runs = analysis.cases["run"].nunique()
    groups = [(f"evaluation run {r}", cov[cov["run"] == r]) for r in runs[:MAX_PICTURED_RUNS]]
    if n_runs > 1:
        groups.append((f"all {n_runs} runs pooled", cov[cov["run"].isna()]))
    pages = []
    for label, scope in groups:
        frame = _coverage_frame(scope)
        if frame is None:
            continue
        pages += table_pages(
            f"Coverage of Table I's equivalence classes per suite ({label})", frame, fontsize=7.5,
            note="Covered classes / classes of each parameter (Sec. V), classifying every case's "
                 "values against the experiment's parameter space. The systematic suite is built to "
                 "cover every class (Sec. VI); random and fixed suites are the paper's controls.")
    return pages


# --------------------------------------------------------------------------- beyond the paper


def _false_alarm_pages(analysis: Analysis) -> list[Figure]:
    fa = analysis.false_alarms
    conf = round(100 * (1 - analysis.alpha))
    show = pd.DataFrame({
        "suite": fa["suite"],
        "cases": fa["n_cases"].astype(str),
        "baseline pairs": fa["n_pairs"].astype(str),
        "flagged": fa["flagged"].astype(str),
        "false-alarm rate %": [format_pct(v, 1) for v in fa["rate"]],
        f"{conf} % CI (clustered by case)": [format_pct_interval(lo, hi, 1) for lo, hi in zip(fa["low"], fa["high"])],
    })
    return table_pages("Beyond the paper: false alarms of the detection rule", show,
                       note="Every ordered pair of baseline repetitions of one case (another "
                            "SLAM seed, same scenario) judged by the paper's rule: how often "
                            "seed noise alone 'detects a fault'. Pairs of one case are correlated, "
                            "so the interval is Clopper-Pearson on the effective sample size from a "
                            "case-clustered variance (Korn & Graubard).")


def _verdict_test(analysis: Analysis) -> str:
    rule = analysis.rule
    if rule.statistical:
        return (f"Test: {rule.test_name} over each case's K repetitions; alpha = "
                f"{rule.alpha:g}; Holm within the multiplicity family '{rule.family}'.")
    return ("Test: the paper's thresholds per repetition; a case is detected when a strict majority of its "
            "judged repetitions detect ('share': detecting / judged repetitions); no multiplicity correction "
            "(the paper's rule is not a test).")


def _case_verdict_pages(analysis: Analysis) -> list[Figure]:
    v = analysis.case_verdicts
    show = pd.DataFrame({
        "suite": v["suite"].map(suite_label), "run": v["run"], "case": v["case"],
        "fault": v["fault"].map(variant_label), "verdict": v["verdict"].str.replace("_", " "),
        "reason": v["reason"].str.replace("_", " "), "K": v["n_reps"], "judged": v["n_judged"],
        "share": [format_pct(x) for x in v["share"]], "p": [_g3(x) for x in v["p"]],
        "p (Holm)": [_g3(x) for x in v["p_holm"]], "change": v["direction"].fillna(""),
        "median diff mm [CI]": [_effect(m, lo, hi, "{:.0f}") for m, lo, hi in
                                zip(v["median_diff_mm"], v["median_low_mm"], v["median_high_mm"])],
        "ratio [CI]": [_effect(m, lo, hi, "{:.2f}") for m, lo, hi in zip(v["ratio"], v["ratio_low"], v["ratio_high"])],
        f"MDE mm ({POWER_TEXT})": [_g3(x) for x in v["mde_mm"]],
    })
    cannot = int((v["verdict"] == "cannot_judge").sum())
    show, empty = _without_empty_columns(_frame_text(show))
    return table_pages(f"Per-case verdicts ({analysis.rule.rule} rule)", show, fontsize=7,
                       max_rows=34,
                       note=f"{_verdict_test(analysis)} A crash or timeout of the faulty variant alone counts "
                            f"as detected. {cannot} case(s) cannot be judged (baseline failed or too few "
                            f"pairs: K >= {min_pairs(analysis.rule.alpha, alternative=alternative_of(analysis.rule.direction))} "
                            f"needed at alpha = {analysis.rule.alpha:g}); they are not misses. Change: sign of the "
                            f"mean paired difference; effect: median difference (mm) and median ratio faulty / "
                            f"baseline with order-statistic intervals (coverage >= 1 - alpha where K allows). MDE: "
                            f"smallest shift of the paired differences the decision's test (its sidedness, Holm's "
                            f"first step alpha / m over the family) detects with {POWER_TEXT} power.{_left_out(empty)}")


def _effect(mid: float, lo: float, hi: float, fmt: str) -> str:
    if not np.isfinite(mid):
        return ""
    text = fmt.format(mid)
    return text if not (np.isfinite(lo) and np.isfinite(hi)) else f"{text} [{fmt.format(lo)}, {fmt.format(hi)}]"


def _case_rate_pages(analysis: Analysis) -> list[Figure]:
    r = analysis.case_rates
    conf = round(100 * (1 - analysis.alpha))
    show = pd.DataFrame({
        "suite": r["suite"].map(suite_label), "fault": r["fault"].map(variant_label),
        "detected/judged cases": [f"{k}/{n}" for k, n in zip(r["k"], r["n"])],
        "cannot judge": r["n_cannot_judge"], "rate %": [format_pct(x) for x in r["rate"]],
        f"Clopper-Pearson {conf} %": [format_pct_interval(lo, hi) for lo, hi in zip(r["cp_low"], r["cp_high"])],
        f"Wilson {conf} %": [format_pct_interval(lo, hi) for lo, hi in zip(r["wilson_low"], r["wilson_high"])],
    })
    return table_pages("Detection rates over cases (the case is the unit)", show,
                       note=f"{_verdict_test(analysis)} Rates are shares of judged cases, whatever K; "
                            "cannot-judge cases are counted apart.")


def _suite_verdict_pages(analysis: Analysis) -> list[Figure]:
    v = analysis.suite_verdicts
    a = analysis.rule.alpha
    alternative = alternative_of(analysis.rule.direction)

    def yes(x) -> str:
        return "yes" if x else "no"

    show = pd.DataFrame({
        "suite": v["suite"].map(suite_label), "run": v["run"], "fault": v["fault"].map(variant_label),
        "tested/cases": [f"{t}/{n}" for t, n in zip(v["n_tested"], v["n_cases"])], "crashed": v["n_crashed"],
        "min p": [_g3(x) for x in v["min_p"]], "per-case min": v["detected_min"].map(yes),
        "pooled p": [_g3(x) for x in v["pooled_p"]],
        "pooled": [verdict_text(x, m) for x, m in zip(v["pooled_verdict"], v["pooled_p_min"])],
        "combined": [verdict_text(x, min(c, m) if math.isfinite(c) and math.isfinite(m) else m)
                     for x, c, m in zip(v["verdict"], v["case_p_min"], v["pooled_p_min"])],
    })
    return table_pages("Suite-level decisions: per-case minimum and pooled", show, fontsize=8,
                       note=f"Per suite run: 'per-case min' detects when the fault crashes alone on a case or the "
                            f"smallest per-case exact {alternative} sign-flip p is at "
                            f"most {a:g} / n; 'combined' when it crashes, that p is at most {a:g} / (2 n), or the "
                            f"pooled sign-flip test over the cases' mean log ratios gives p at most {a:g} / 2 "
                            f"(family-wise {a:g}). The pooled test can reject at {a / 2:g} only from "
                            f"{min_pairs(a / 2, alternative=alternative)} tested cases: with fewer it says 'cannot "
                            f"judge' with its smallest attainable p, never 'no change shown'; the campaign-level "
                            f"verdict pools every suite's cases.")


def _campaign_verdict_pages(analysis: Analysis) -> list[Figure]:
    records = campaign_verdict_records(analysis)
    if not len(records):
        return []
    return table_pages("Campaign-level verdict per fault (all its cases pooled)", records, fontsize=7.5,
                       note=campaign_verdict_note(analysis))


def _case_comparison_pages(analysis: Analysis) -> list[Figure]:
    c = analysis.case_comparisons
    show = pd.DataFrame({
        "fault": c["fault"].map(variant_label),
        "suites": [f"{a} vs {b}" for a, b in zip(c["suite_a"], c["suite_b"])],
        "cases k/n": [f"{ka}/{na} vs {kb}/{nb}" for ka, na, kb, nb in zip(c["k_a"], c["n_a"], c["k_b"], c["n_b"])],
        "risk difference": [f"{x:+.2f}" for x in c["risk_difference"]],
        "runs": c["n_clusters"], "method": c["method"].str.replace("_", " "),
        "p": [_g3(x) for x in c["p"]], "p (Holm)": [_g3(x) for x in c["p_holm"]],
    })
    return table_pages("Suites compared per fault, cases as units", show, fontsize=8,
                       note=f"Binomial GEE of the case verdicts (exchangeable working correlation within an "
                            f"evaluation run, robust standard errors, Wald test); a cluster bootstrap over runs "
                            f"where GEE cannot fit; Holm over the suite pairs of one fault (family: the fault) at "
                            f"alpha = {analysis.alpha:g}. Degenerate tables (none or all detected on both sides) "
                            f"carry no information and are left out of the Holm family.")


def _replica_false_alarm_pages(analysis: Analysis) -> list[Figure]:
    fa = analysis.replica_false_alarms
    conf = round(100 * (1 - analysis.alpha))
    show = pd.DataFrame({
        "rule": fa["rule"], "suite": fa["suite"], "cases": fa["n_cases"],
        "trials": [f"{n} {'rep. pairs' if r == 'paper' else 'cases'}" for n, r in zip(fa["n_pairs"], fa["rule"])],
        "flagged": fa["flagged"], "false-alarm rate %": [format_pct(x, 1) for x in fa["rate"]],
        f"{conf} % CI (clustered by case)": [format_pct_interval(lo, hi, 1) for lo, hi in zip(fa["low"], fa["high"])],
    })
    return table_pages("A/A control: false alarms of both rules (baseline_replica vs baseline)", show,
                       note=f"The replica is the unmodified SLAM with independent SLAM seeds: every detection "
                            f"is a false alarm. Paper rule: one trial per repetition; statistical rule: one per "
                            f"judged case (alpha = {analysis.rule.alpha:g}, the replica its own family). "
                            f"The statistical rule is calibrated when its interval's lower bound is below alpha.")


def _paper_comparison_pages(analysis: Analysis) -> list[Figure]:
    c = analysis.paper_comparisons
    show = pd.DataFrame({
        "suite": c["suite"].map(suite_label), "fault": c["fault"].map(variant_label),
        "paper k/n": [f"{k}/{n}" for k, n in zip(c["paper_k"], c["paper_n"])],
        "this run k/n (cases)": [f"{k}/{n}" for k, n in zip(c["k"], c["n"])],
        "difference": [f"{x:+.2f}" for x in c["difference"]], "p (Boschloo)": [_g3(x) for x in c["p"]],
        f"detectable difference ({POWER_TEXT})": [_g3(x) for x in c["detectable_difference"]], "verdict": c["verdict"],
    })
    return table_pages("Detection counts compared with the paper (two-sample exact test)", show, fontsize=8,
                       note=f"Boschloo's exact unconditional test (two-sided) of the paper's printed count "
                            f"against this run's detected / judged cases, alpha = {analysis.alpha:g}, no "
                            f"multiplicity correction (each row is its own question). 'differs': p < alpha; "
                            f"'agrees': not differing and the smallest difference detectable with {POWER_TEXT} power "
                            f"is below {AGREEMENT_MARGIN:g}; otherwise 'inconclusive' (too few cases).")


def _oracle_pages(analysis: Analysis) -> list[Figure]:
    s = analysis.oracle_summary
    show = pd.DataFrame({
        "suite": s["suite"].map(suite_label),
        "fault": s["fault"].map(variant_label),
        "cases": s["n_cases"],
        "tested": s["n_tested"],
        "detected (oracle)": s["n_detected"],
        "smallest attainable p": s["min_p_min"],
        "smallest Holm p": s["min_p_holm"],
    })
    return table_pages("Beyond the paper: a statistical oracle over the SLAM repetitions", _frame_text(show),
                       note="Per case, a one-sided Mann-Whitney U test of the faulty against "
                            "the baseline RMS errors over the K repetitions (unpaired: it ignores the "
                            "common SLAM seeds), Holm-corrected over all (suite, run, case, fault) tests. "
                            "With K repetitions the smallest attainable p is 1/C(2K, K): with few "
                            "repetitions the oracle cannot reject anything after the correction. This "
                            "oracle is a second view; the report's verdicts are not its result but "
                            "that of the test on the per-case verdict pages: "
                            + _verdict_test(analysis))


def _suite_comparison_pages(analysis: Analysis) -> list[Figure]:
    cmp = analysis.suite_comparisons
    show = pd.DataFrame({
        "fault": cmp["fault"].map(variant_label),
        "suites": [f"{a} vs {b}" for a, b in zip(cmp["suite_a"], cmp["suite_b"])],
        "k/n": [f"{ka}/{na} vs {kb}/{nb}" for ka, na, kb, nb in zip(cmp["k_a"], cmp["n_a"], cmp["k_b"], cmp["n_b"])],
        "risk difference [CI]": [f"{rd:+.2f} [{lo:+.2f}, {hi:+.2f}]" for rd, lo, hi in
                                 zip(cmp["risk_difference"], cmp["rd_low"], cmp["rd_high"])],
        "odds ratio [CI]": [f"{o:.3g} [{lo:.3g}, {hi:.3g}]{' (H)' if h else ''}"
                            for o, lo, hi, h in zip(cmp["odds_ratio"], cmp["or_low"], cmp["or_high"], cmp["haldane"])],
        "p (Fisher)": [f"{p:.3g}" for p in cmp["p"]],
        "p (Holm)": [f"{p:.3g}" for p in cmp["p_holm"]],
    })
    return table_pages("Beyond the paper: suites compared per fault (Fisher's exact test)", show, fontsize=8,
                       note="Two-sided Fisher exact test on detected / not detected jobs, "
                            "Holm-adjusted over the table; risk difference with Newcombe's "
                            "interval; odds ratio with Woolf's interval, (H): Haldane-Anscombe "
                            "correction on a zero cell.")


def _effect_pages(analysis: Analysis) -> list[Figure]:
    """The continuous effect analysis (the Analysis' ``campaign_effects``): per case the baseline's
    difficulty and each fault's effect size, their mean over cases and, where the campaign is large
    enough, the cluster-robust regression on the parameters; the size it would need otherwise."""
    from faultlab.report.effects import response_label

    unavailable = analysis.notes_on("campaign_effects")
    if unavailable:
        return text_pages(EFFECT_PAGE_TITLE, [n.text for n in unavailable])
    eff = analysis.campaign_effects
    notes = sorted({n for n in eff["note"] if n.startswith("not fitted") or "too few cases" in n})
    eff = eff[eff["term"] != "(size)"]  # nothing estimated: what the size would need is in the notes
    log_scale = eff["response"] != "difficulty"
    show = pd.DataFrame({
        "response": eff["response"].map(response_label),
        "term": eff["term"],
        "cases": eff["n_cases"],
        "estimate [95 % CI]": ["" if not math.isfinite(e) else f"{e:+.3g} [{lo:+.3g}, {hi:+.3g}]"
                               for e, lo, hi in zip(eff["estimate"], eff["low"], eff["high"])],
        "x error": ["" if not (ls and t == "(mean over cases)" and math.isfinite(e)) else f"{math.exp(e):.3g}"
                    for ls, t, e in zip(log_scale, eff["term"], eff["estimate"])],
        "p": [_g3(p) for p in eff["p"]],
    })
    notes += _class_effect_notes(analysis)
    show, empty = _without_empty_columns(show.astype(str))
    pages = [] if not len(show) else table_pages(
        EFFECT_PAGE_TITLE, show, fontsize=7.5, max_rows=34,
        note="Continuous responses per case over its K repetitions: the baseline's difficulty "
             "(mean log map error) and each fault's effect size (mean log of faulty / baseline "
             "error, paired by SLAM seed); 'x error' is the geometric-mean factor. Mean over "
             "cases with its t interval; parameter rows: OLS per standard deviation, "
             "cluster-robust by case." + _left_out(empty))
    if notes:
        pages += text_pages("Parameter effects: what this campaign's size allows",
                            [n[0].upper() + n[1:] + "." for n in notes]
                            + ["Per-parameter rankings with intervals come from a designed experiment: "
                               "faultlab effects run effects --quick (Morris screening, then Sobol indices; "
                               "see reports/effects). The logistic view of detection: faultlab effects RESULTS."])
    return pages


def _class_effect_notes(analysis: Analysis) -> list[str]:
    """Why no class-indicator logistic regression was fitted (when none was), one line per fault."""
    e = analysis.class_effects
    if not len(e) or not (e["term"] == "(model)").all():
        return []
    return [f"class-indicator logistic regression of detection, {variant_label(f)}: {n}"
            for f, n in zip(e["fault"], e["note"])] + [
        f"class-indicator logistic regressions need at least {MIN_EPV:g} events per predictor (cases are the unit, "
        f"repetitions do not add events)"]


def _class_effect_pages(analysis: Analysis) -> list[Figure]:
    e = analysis.class_effects
    if (e["term"] == "(model)").all():
        return []  # nothing fitted: the continuous effects page says why (_class_effect_notes)
    show = pd.DataFrame({
        "fault": e["fault"].map(variant_label), "term": e["term"],
        "detected/n": [f"{k}/{n}" for k, n in zip(e["n_detected"], e["n"])],
        "EPV": [_g3(x) for x in e["epv"]], "fit": e["method"],
        "odds ratio": [_g3(x) for x in e["odds_ratio"]], "LR chi2 (df)": [
            "" if not math.isfinite(x) else f"{x:.3g} ({d})" for x, d in zip(e["lr_chi2"], e["df"])],
        "p": [_g3(x) for x in e["p"]], "p (Holm)": [_g3(x) for x in e["p_holm"]], "note": e["note"],
    })
    return table_pages(CLASS_EFFECT_PAGE_TITLE, show, fontsize=7,
                       max_rows=34,
                       note=f"Per fault, the case verdicts ({analysis.rule.rule} rule; cannot-judge cases left out) "
                            f"on class indicators of every Table I parameter (reference: its first class; rotation "
                            f"error by magnitude). Maximum likelihood, Firth's penalised likelihood where the data "
                            f"are separated; likelihood-ratio test per parameter, Holm over the fault's "
                            f"parameters. Fits need {MIN_EPV:g} events per predictor (EPV).")


#: Page renderer of each statistic beyond the paper, in the Analysis' order.  The continuous effects
#: (``campaign_effects``) are drawn where the parameter effects' page stands, once: _effect_pages.
_BEYOND_PAGES = {"false_alarms": _false_alarm_pages, "oracle": _oracle_pages,
                 "suite_comparisons": _suite_comparison_pages, "parameter_effects": _effect_pages,
                 "campaign_effects": lambda analysis: [],
                 "case_verdicts": _case_verdict_pages, "case_rates": _case_rate_pages,
                 "suite_verdicts": _suite_verdict_pages, "campaign_verdicts": _campaign_verdict_pages,
                 "case_comparisons": _case_comparison_pages, "replica_false_alarms": _replica_false_alarm_pages,
                 "paper_comparisons": _paper_comparison_pages, "class_effects": _class_effect_pages}


#: Topics whose notes are caveats beside a table that still has something to show.
_INFORMATIVE_NOTES = ("case_comparisons", "suite_comparisons")


def beyond_pages(analysis: Analysis) -> list[Figure]:
    """A page per statistic beyond the paper that has something to show; the notes on the others."""
    pages = [page for topic in BEYOND_THE_PAPER
             if (topic in _INFORMATIVE_NOTES or not analysis.notes_on(topic)) and len(analysis.table(topic))
             for page in _BEYOND_PAGES[topic](analysis)]
    text = [n.text for n in analysis.notes_on("verdicts", *BEYOND_THE_PAPER)]
    if text:
        pages = text_pages("Beyond the paper: what these results allow", text) + pages
    return pages


# --------------------------------------------------------------------------- metadata


def _setting_rows(value, key: str = "") -> list[tuple[str, str]]:
    """(dotted key, value) rows of a nested experiment setting, e.g. ("slam.particles", "200")."""
    if isinstance(value, dict):
        rows = []
        for k, v in value.items():
            rows += _setting_rows(v, f"{key}.{k}" if key else str(k))
        return rows or [(key, "(none)")]
    if isinstance(value, (list, tuple)):
        items = (" ".join(str(x) for x in v) if isinstance(v, (list, tuple)) else str(v) for v in value)
        return [(key, ", ".join(items) or "(none)")]
    return [(key, str(value))]


def metadata_pages(analysis: Analysis, seeds: list) -> list[Figure]:
    """Versions, experiment hash, seeds, sessions, run times and the effective experiment settings, as tables."""
    meta = analysis.metadata
    exp = meta.get("experiment") or {}
    rows = [
        ("faultlab version", f"{meta.get('faultlab_version', '?')} (results); {__version__} (this report)"),
        ("experiment", str(meta.get("experiment_source", "?"))),
        ("experiment hash", f"{meta.get('experiment_hash', '?')} (sha256 of its canonical form)"),
        ("root seed", f"{meta.get('root_seed', '?')} (every case and SLAM seed derives from it: numpy SeedSequence)"),
        ("detection rule", analysis.rule.describe()),
        ("results store", f"{meta.get('n_rows', analysis.n_rows)} rows, created {meta.get('created', '?')}"),
        ("total wall time", _fmt_seconds(meta.get("wall_time_s"))),
    ]
    rt = analysis.runtimes
    if len(rt) and int(rt["n_jobs"].iloc[-1]) > 0:
        every = rt[rt["variant"] == ALL_VARIANTS].iloc[0]
        rows.append(("SLAM time per job", f"median {every['median_s']:.2f} s, max {every['max_s']:.2f} s, "
                                          f"sum {every['total_s']:.1f} s over {every['n_jobs']} jobs"))
        per = rt[rt["variant"] != ALL_VARIANTS]
        rows += [(f"median SLAM time: {variant_label(v)}", f"{m:.2f} s")
                 for v, m in zip(per["variant"], per["median_s"])]
    for key in ("runs", "suites", "n_steps", "sensor_range", "min_distance", "slam", "variants",
                "repetitions", "metric", "metrics", "timeout_s", "detection", "space"):
        if key in exp:
            rows += [(f"setting {k}", v) for k, v in _setting_rows(exp[key], key)]
    pages = table_pages("Run metadata", pd.DataFrame(rows, columns=["item", "value"]), align="left")
    sessions = meta.get("sessions") or []
    if sessions:
        frame = pd.DataFrame([{"started": s.get("started", "?"), "state": s.get("state", "?"),
                               "new jobs": s.get("n_new", "?"), "workers": s.get("jobs", "?"),
                               "backend": s.get("backend", "?"), "wall time": _fmt_seconds(s.get("wall_time_s"))}
                              for s in sessions])
        pages += table_pages("Run metadata: sessions (each invocation of the runner)", frame)
    if seeds:
        frame = pd.DataFrame(seeds, columns=["run", "suite", "case", "seed (SeedSequence entropy)",
                                             "landmarks", "steps"]).astype(str)
        pages += table_pages("Run metadata: test-case seeds", frame, key_columns=3)
    return pages
