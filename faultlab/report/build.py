"""Build the report of a finished (or partial) campaign from its saved results only.

:func:`build_report` reads a results store (:func:`faultlab.runner.load_results`,
:func:`faultlab.runner.load_metadata`, the saved test cases) and the paper's data, and writes
the tables and ``report.pdf``.  It never runs a SLAM, never generates a case and never writes
to the results store: ``python -m faultlab report RESULTS`` rebuilds a report at any time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from faultlab import __version__, stats
from faultlab.errors import FaultlabError, ResultsError
from faultlab.report.comparison import Comparison, Verdict, compare_with_paper
from faultlab.report.figures import PAGE_SIZE, detection_rate_figure, rms_distribution_figure
from faultlab.report.pdf import PAGE_TITLE_ATTR, table_pages, text_pages, write_pdf
from faultlab.report.tables import (
    PAPER,
    RUNS_PER_BLOCK,
    TableFiles,
    Table2,
    detection_frame,
    detection_records,
    format_pct,
    load_paper,
    order_suites,
    order_variants,
    paper_results_frame,
    round_mm,
    suite_label,
    table2,
    table2_caption,
    table2_frame,
    variant_label,
    write_tables,
)
from faultlab.space.case import PARAMETER_NAMES, VALUE_KEYS, CaseSpec

__all__ = ["ReportFiles", "build_report", "MAX_PICTURED_RUNS"]

#: Runs whose cases are pictured (Fig. 5 style) and whose coverage is tabulated one by one.
MAX_PICTURED_RUNS = 3
_GREEN = "#c6efce"  # the paper's green "detected" cells
_RED = "#f4cccc"
_GREY = "#eeeeee"


@dataclass(frozen=True)
class ReportFiles:
    """What :func:`build_report` wrote.

    Attributes
    ----------
    reports_dir : Path
    table2_csv, table2_md, table2_tex, detection_csv, detection_md, comparison_md, pdf : Path
    n_pages : int
        Pages of ``report.pdf``.
    page_titles : tuple of str
        Title of every page, in order.
    comparison : Comparison
        The statements on agreement with the paper.
    n_rows : int
        Result rows the report was built from.
    notes : tuple of str
        Parts that could not be made, with the reason (e.g. saved cases missing).
    """

    reports_dir: Path
    table2_csv: Path
    table2_md: Path
    table2_tex: Path
    detection_csv: Path
    detection_md: Path
    comparison_md: Path
    pdf: Path
    n_pages: int
    page_titles: tuple[str, ...]
    comparison: Comparison
    n_rows: int
    notes: tuple[str, ...] = ()

    @property
    def files(self) -> list[Path]:
        return [self.table2_csv, self.table2_md, self.table2_tex, self.detection_csv,
                self.detection_md, self.comparison_md, self.pdf]

    def __str__(self) -> str:
        lines = [f"report written to {self.reports_dir} ({self.n_rows} result rows):"]
        lines += [f"  {p}" for p in self.files[:-1]]
        lines.append(f"  {self.pdf} ({self.n_pages} pages)")
        lines.append(self.comparison.summary())
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)


# --------------------------------------------------------------------------- helpers


def _rule_of(meta: dict):
    det = meta.get("detection") or {}
    try:
        return stats.DetectionRule(**{k: det[k] for k in ("abs_mm", "rel") if k in det})
    except (TypeError, FaultlabError) as exc:
        raise ResultsError(f"results metadata has an invalid detection rule {det!r} ({exc})") from exc


def _space_of(meta: dict):
    from faultlab.space import space_from_mapping, table1_space

    overrides = (meta.get("experiment") or {}).get("space") or {}
    if not overrides:
        return table1_space()
    return space_from_mapping(overrides, source=f"{meta.get('experiment_source', 'experiment')} [space]")


def _cases_of(results: pd.DataFrame) -> pd.DataFrame:
    """One row per (run, suite, case) with its parameter values and classes."""
    return results.drop_duplicates(["run", "suite", "case"]).sort_values(["run", "case"])


def _case_spec(row: pd.Series) -> CaseSpec:
    values = {}
    for key in VALUE_KEYS:
        v = row[key]
        values[key] = str(v) if key == "directionality" else float(v)
    classes = {p: int(row[f"class_{p}"]) for p in PARAMETER_NAMES if f"class_{p}" in row}
    return CaseSpec(values=values, classes=classes)


def _titled(fig: Figure, title: str) -> Figure:
    setattr(fig, PAGE_TITLE_ATTR, title)
    return fig


def _fmt_seconds(s: float) -> str:
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


# --------------------------------------------------------------------------- pages


def _title_page(meta: dict, results: pd.DataFrame, comparison: Comparison,
                notes: list[str]) -> list[Figure]:
    counts = results["status"].value_counts()
    exp = meta.get("experiment") or {}
    cases = _cases_of(results).groupby(["suite", "run"]).size().groupby("suite").max()
    suites_txt = ", ".join(f"{s} {int(cases[s])}" for s in order_suites(cases.index))
    slam = exp.get("slam") or {}
    rule = _rule_of(meta)
    blocks = [
        "This report reproduces the evaluation of Tasche & Herber, 'A Coverage-Driven Systematic "
        "Test Approach for Simultaneous Localization and Mapping' (Sec. VII, Table II) with faultlab, "
        "and extends it with statistics the paper could not afford. It was built from saved results "
        "only (python -m faultlab report RESULTS rebuilds it).",
        "## This run",
        f"- Experiment: {meta.get('experiment_source', '?')} — {meta.get('description', '')}",
        f"- Protocol: {exp.get('runs', '?')} evaluation run(s); suites {suites_txt or '?'} cases per run; "
        f"variants {', '.join(meta.get('variants', [])) or '?'}; {exp.get('repetitions', 1)} SLAM "
        f"repetition(s) per case; {exp.get('n_steps', '?')} steps per case; SLAM "
        f"{slam.get('name', '?')} with {slam.get('particles', '?')} particles.",
        f"- Results: {len(results)} jobs — " + ", ".join(f"{int(counts.get(s, 0))} {s}"
                                                         for s in ("ok", "crash", "timeout")) + ".",
        f"- Detection rule (Sec. VII-A): {rule.describe()}.",
        f"- Wall time of the campaign: {_fmt_seconds(meta.get('wall_time_s'))}; faultlab "
        f"{meta.get('faultlab_version', '?')} (report built with {__version__}).",
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
    return text_pages("faultlab report: the paper's Table II reproduced", blocks,
                      subtitle=f"results {meta.get('path', '')}  ·  experiment hash "
                               f"{str(meta.get('experiment_hash', ''))[:16]}")


def _table2_pages(table: Table2) -> list[Figure]:
    runs = table.runs()
    blocks = [runs[i:i + RUNS_PER_BLOCK] for i in range(0, len(runs), RUNS_PER_BLOCK)] or [[]]
    lookup = {(r.source, r.suite, r.variant, int(r.run), int(r.case)): r
              for r in table.cells.itertuples(index=False)}
    pages = []
    for block in blocks:
        frame = table2_frame(table, style="plain", runs=block)
        colours = pd.DataFrame("", index=frame.index, columns=frame.columns)
        bold = pd.DataFrame(False, index=frame.index, columns=frame.columns)
        for i, (suite, variant, source) in enumerate(table.rows()):
            if source == PAPER:
                colours.iloc[i, :3] = _GREY
            for col in frame.columns:
                if not (col.startswith("R") and "C" in col[1:]):
                    continue
                run, case = (int(x) for x in col[1:].split("C"))
                cell = lookup.get((source, suite, variant, run, case))
                if cell is None:
                    continue
                if cell.status in ("crash", "timeout"):
                    colours.loc[i, col] = _RED
                elif cell.detected:
                    colours.loc[i, col] = _GREEN
                    bold.loc[i, col] = True
        title = "Table II: this run beside the paper"
        if len(blocks) > 1:
            title += f" (evaluation runs {block[0]}-{block[-1]})"
        note = (table2_caption(table) + " Green: detected. Red: crash or timeout. Paper rows: the "
                "replication package's raw RMS errors rounded to mm (the printed Table II differs from "
                "them in a few cells: python -m faultlab paper-table lists them).")
        pages += table_pages(title, frame, colours=colours, bold=bold, note=note, max_rows=40,
                             subtitle="columns R<run>C<case>: RMS map error of test case <case> "
                                      "in evaluation run <run>, mm")
    return pages


def _rates_pages(detection: pd.DataFrame, table: Table2) -> list[Figure]:
    conf = round_mm(100 * (1 - table.alpha))
    frame = detection_records(detection, alpha=table.alpha, compact=True)
    bs = table.by_suite
    brows = []
    for s in order_suites(bs["suite"]):
        mine = bs[(bs["suite"] == s) & (bs["source"] != PAPER)]
        paper = bs[(bs["suite"] == s) & (bs["source"] == PAPER)]
        rec = {"Suite": suite_label(s)}
        if not mine.empty:
            m = mine.iloc[0]
            rec["this run"] = f"{format_pct(m['rate'])} % ({int(m['k'])}/{int(m['n'])})"
            rec[f"Wilson {conf} %"] = f"{format_pct(m['ci_low'])}-{format_pct(m['ci_high'])}"
        if not paper.empty:
            p = paper.iloc[0]
            rec["paper (rule)"] = f"{format_pct(p['rate'])} % ({int(p['k'])}/{int(p['n'])})"
            pp = p.get("printed_pct", np.nan)
            rec["paper (printed)"] = "" if pd.isna(pp) else f"{round_mm(float(pp))} %"
        brows.append(rec)
    note = ("k/n: faulty jobs detecting the fault among those where both the faulty and the baseline "
            "SLAM produced a map (the paper's 'Detected Faults'). Crashes and timeouts of the faulty "
            "SLAM are their own outcome classes; 'Rate % incl. failures' counts them as detections. "
            "'base failed': the baseline produced no map, so the case judges nothing. Paper (rule): "
            "this run's detection rule applied to the paper's raw RMS data; printed: Table II as "
            "printed.")
    pages = table_pages("Detected faults per suite and fault (Table II, right-hand columns)", frame,
                        note=note, fontsize=8)
    pages += table_pages("by Suite: fault x run pairs detected by at least one case",
                         pd.DataFrame(brows), fontsize=9,
                         note="The paper's 'by Suite' column: the share of fault x run pairs in "
                              "which at least one case of the suite detected the fault.")
    return pages


def _comparison_pages(comparison: Comparison) -> list[Figure]:
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


def _case_pages(results_dir: Path, results: pd.DataFrame, notes: list[str]) -> tuple[list[Figure], list]:
    """Fig. 5-style pictures of the saved cases (runs 1..MAX_PICTURED_RUNS) and their seeds.

    One page per evaluation run, one row of panels per suite (wrapped after 5 cases), drawn
    with :func:`faultlab.report.casefig.plot_case` from the saved test cases.
    """
    from faultlab.report.casefig import case_title, plot_case
    from faultlab.runner import case_path
    from faultlab.scenario.model import load_scenario

    cases = _cases_of(results)
    runs = sorted(int(r) for r in cases["run"].unique())
    pages, seeds = [], []
    missing = 0
    per_row = 5
    for run in runs[:MAX_PICTURED_RUNS]:
        rows: list[tuple[str, list]] = []  # (suite, [(case, scenario)]) per row of panels
        for suite in order_suites(cases["suite"]):
            ids = sorted(int(c) for c in cases.loc[(cases["run"] == run) & (cases["suite"] == suite),
                                                   "case"])
            loaded = []
            for c in ids:
                try:
                    loaded.append((c, load_scenario(case_path(results_dir, run, suite, c))))
                except (FaultlabError, OSError):
                    missing += 1
            seeds += [(run, suite, c, sc.seed, sc.landmarks.shape[0], sc.n_steps) for c, sc in loaded]
            rows += [(suite, loaded[i:i + per_row]) for i in range(0, len(loaded), per_row)]
        for start in range(0, len(rows), 3):  # at most three rows of panels per page
            chunk = rows[start:start + 3]
            title = (f"Test cases of evaluation run {run} (Fig. 5 style: landmarks orange, "
                     f"true path blue)" + (" (continued)" if start else ""))
            fig = _titled(Figure(figsize=PAGE_SIZE), title)
            fig.suptitle(title, fontsize=13, fontweight="bold")
            axes = fig.subplots(len(chunk), per_row, squeeze=False)
            for r, (suite, panel) in enumerate(chunk):
                for k in range(per_row):
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
            pages.append(fig)
    if missing:
        notes.append(f"{missing} saved test case file(s) under {results_dir}/cases could not be "
                     "read; their pictures are left out.")
    if len(runs) > MAX_PICTURED_RUNS:
        notes.append(f"test cases are pictured for evaluation runs 1-{MAX_PICTURED_RUNS} of {len(runs)}.")
    return pages, seeds


def _coverage_pages(results: pd.DataFrame, meta: dict, notes: list[str]) -> list[Figure]:
    from faultlab.space import coverage

    try:
        space = _space_of(meta)
    except FaultlabError as exc:
        notes.append(f"coverage tables left out: the stored parameter space is invalid ({exc})")
        return []
    cases = _cases_of(results)
    runs = sorted(cases["run"].unique())
    groups = [(f"evaluation run {r}", cases[cases["run"] == r]) for r in runs[:MAX_PICTURED_RUNS]]
    if len(runs) > 1:
        groups.append((f"all {len(runs)} runs pooled", cases))
    pages = []
    for label, sub in groups:
        frame = None
        for suite in order_suites(sub["suite"]):
            specs = [_case_spec(row) for _, row in sub[sub["suite"] == suite].iterrows()]
            t = coverage(specs, space).table()
            t[suite_label(suite)] = [f"{c}/{k} ({100 * r:.0f} %)" for c, k, r in
                                     zip(t["covered"], t["classes"], t["coverage"])]
            t[f"{suite_label(suite)}: uncovered"] = t["uncovered"].replace("", "-")
            t.loc[t["parameter"] == "overall", f"{suite_label(suite)}: uncovered"] = \
                f"{len(specs)} cases"
            part = t[["parameter", "classes", suite_label(suite), f"{suite_label(suite)}: uncovered"]]
            frame = part if frame is None else frame.merge(part, on=["parameter", "classes"])
        if frame is None:
            continue
        pages += table_pages(
            f"Coverage of Table I's equivalence classes per suite ({label})", frame, fontsize=7.5,
            note="Covered classes / classes of each parameter (Sec. V), classifying every case's "
                 "values against the experiment's parameter space. The systematic suite is built to "
                 "cover every class (Sec. VI); random and fixed suites are the paper's controls.")
    return pages


def _beyond_pages(results: pd.DataFrame, rule, alpha: float, n_reps: int) -> list[Figure]:
    pages: list[Figure] = []
    text: list[str] = []
    # false alarms of the paper's rule: baseline against baseline with another SLAM seed
    try:
        fa = stats.false_alarm_rate(results, rule=rule, alpha=alpha)
        if fa.empty or int(fa["n_pairs"].sum()) == 0:
            text.append(f"False alarms of the paper's rule: need at least 2 SLAM repetitions per case "
                        f"(this run has {n_reps}); run an experiment with repetitions >= 2.")
        else:
            show = pd.DataFrame({
                "suite": fa["suite"],
                "cases": fa["n_cases"].astype(int).astype(str),
                "baseline pairs": fa["n_pairs"].astype(int).astype(str),
                "flagged": fa["flagged"].astype(int).astype(str),
                "false-alarm rate %": [format_pct(v, 1) for v in fa["rate"]],
                "Wilson 95 %": [f"{format_pct(lo, 1)}-{format_pct(hi, 1)}"
                                for lo, hi in zip(fa["wilson_low"], fa["wilson_high"])],
            })
            pages += table_pages("Beyond the paper: false alarms of the detection rule", show,
                                 note="Every ordered pair of baseline repetitions of one case (another "
                                      "SLAM seed, same scenario) judged by the paper's rule: how often "
                                      "seed noise alone 'detects a fault'. Pairs of one case are not "
                                      "independent, so the intervals are optimistic.")
    except FaultlabError as exc:
        text.append(f"False alarms: not available ({exc}).")
    # statistical oracle over the K repetitions
    try:
        orc = stats.oracle_detections(results, alpha=alpha)
        tested = orc[orc["p"].notna()] if not orc.empty else orc
        if tested.empty or int(tested["n_baseline"].max()) < 2:
            text.append(f"Statistical oracle (one-sided Mann-Whitney U over the K repetitions, Holm): "
                        f"needs repetitions >= 2 per case (this run has {n_reps}).")
        else:
            g = orc.groupby(["suite", "fault"], sort=False)
            summary = pd.DataFrame({
                "cases": g.size(),
                "tested": g["p"].count(),
                "detected (oracle)": g["detected"].sum(),
                "smallest attainable p": g["p_min"].min(),
                "smallest Holm p": g["p_holm"].min(),
            }).reset_index()
            summary["suite"] = summary["suite"].map(suite_label)
            summary["fault"] = summary["fault"].map(variant_label)
            pages += table_pages("Beyond the paper: a statistical oracle over the SLAM repetitions",
                                 _frame_text(summary),
                                 note="Per case, a one-sided Mann-Whitney U test of the faulty against "
                                      "the baseline RMS errors over the K repetitions, Holm-corrected "
                                      "over all (suite, run, case, fault) tests. With K repetitions the "
                                      "smallest attainable p is 1/C(2K, K): with few repetitions the "
                                      "oracle cannot reject anything after the correction.")
    except FaultlabError as exc:
        text.append(f"Statistical oracle: not available ({exc}).")
    # Fisher's exact suite comparisons
    try:
        cmp = stats.compare_suites(results, rule=rule, alpha=alpha)
        if cmp.empty:
            text.append("Suite comparisons (Fisher's exact test): no suite pair with usable jobs.")
        else:
            show = pd.DataFrame({
                "fault": cmp["fault"].map(variant_label),
                "suites": [f"{a} vs {b}" for a, b in zip(cmp["suite_a"], cmp["suite_b"])],
                "k/n": [f"{int(ka)}/{int(na)} vs {int(kb)}/{int(nb)}" for ka, na, kb, nb in
                        zip(cmp["k_a"], cmp["n_a"], cmp["k_b"], cmp["n_b"])],
                "risk difference [CI]": [f"{rd:+.2f} [{lo:+.2f}, {hi:+.2f}]" for rd, lo, hi in
                                         zip(cmp["risk_difference"], cmp["rd_low"], cmp["rd_high"])],
                "odds ratio [CI]": [f"{o:.3g} [{lo:.3g}, {hi:.3g}]{' (H)' if h else ''}"
                                    for o, lo, hi, h in zip(cmp["odds_ratio"], cmp["or_low"],
                                                            cmp["or_high"], cmp["haldane"])],
                "p (Fisher)": [f"{p:.3g}" for p in cmp["p"]],
                "p (Holm)": [f"{p:.3g}" for p in cmp["p_holm"]],
            })
            pages += table_pages("Beyond the paper: suites compared per fault (Fisher's exact test)",
                                 show, fontsize=8,
                                 note="Two-sided Fisher exact test on detected / not detected jobs, "
                                      "Holm-adjusted over the table; risk difference with Newcombe's "
                                      "interval; odds ratio with Woolf's interval, (H): Haldane-Anscombe "
                                      "correction on a zero cell.")
    except FaultlabError as exc:
        text.append(f"Suite comparisons: not available ({exc}).")
    # per-parameter effects (logistic regression)
    try:
        eff = stats.parameter_effects(results, rule=rule, alpha=alpha)
        if eff.empty:
            text.append("Parameter effects: no faulty jobs.")
        else:
            show = pd.DataFrame({
                "fault": eff["fault"].map(variant_label),
                "term": eff["term"],
                "detected/n": [f"{int(k)}/{int(n)}" for k, n in zip(eff["n_detected"], eff["n"])],
                "odds ratio per SD": [("" if not math.isfinite(v) else f"{v:.3g}") for v in eff["odds_ratio"]],
                "95 % CI": [("" if not math.isfinite(lo) else f"{lo:.3g}-{hi:.3g}")
                            for lo, hi in zip(eff["or_low"], eff["or_high"])],
                "p": [("" if not math.isfinite(p) else f"{p:.3g}") for p in eff["p"]],
                "note": eff["note"].fillna(""),
            })
            pages += table_pages("Beyond the paper: which scenario parameters drive detection", show,
                                 fontsize=7.5, max_rows=34,
                                 note="Per fault, a binomial GLM (logistic regression) of 'detected' on "
                                      "the standardised scenario parameters; odds ratios per standard "
                                      "deviation. Also: python -m faultlab effects RESULTS.")
    except (FaultlabError, ValueError, np.linalg.LinAlgError) as exc:
        text.append(f"Parameter effects: not available ({exc}).")
    if text:
        pages = text_pages("Beyond the paper: what these results allow", text) + pages
    return pages


def _metadata_pages(meta: dict, results: pd.DataFrame, seeds: list) -> list[Figure]:
    rule = _rule_of(meta)
    exp = meta.get("experiment") or {}
    blocks = [
        f"- faultlab version (results): {meta.get('faultlab_version', '?')}; report built with "
        f"{__version__}",
        f"- Experiment: {meta.get('experiment_source', '?')}",
        f"- Experiment hash (sha256 of its canonical form): {meta.get('experiment_hash', '?')}",
        f"- Root seed: {meta.get('root_seed', '?')} (every case and SLAM seed derives from it with "
        f"numpy SeedSequence)",
        f"- Detection rule: {rule.describe()}",
        f"- Results store: {meta.get('path', '?')}, {meta.get('n_rows', len(results))} rows, created "
        f"{meta.get('created', '?')}",
        f"- Total wall time: {_fmt_seconds(meta.get('wall_time_s'))}",
    ]
    sessions = meta.get("sessions") or []
    if sessions:
        blocks.append("## Sessions (each invocation of the runner)")
        for s in sessions:
            blocks.append(f"- {s.get('started', '?')}: {s.get('state', '?')}, {s.get('n_new', '?')} new "
                          f"jobs, {s.get('jobs', '?')} worker(s), backend {s.get('backend', '?')}, "
                          f"wall time {_fmt_seconds(s.get('wall_time_s'))}")
    rt = results["runtime_s"].astype(float)
    if len(rt):
        blocks.append("## SLAM execution times")
        blocks.append(f"- per job: median {rt.median():.2f} s, max {rt.max():.2f} s, sum {rt.sum():.1f} s "
                      f"over {len(rt)} jobs")
        by_variant = results.groupby("variant")["runtime_s"].median()
        blocks.append("- median per variant: " + ", ".join(
            f"{variant_label(v)} {by_variant[v]:.2f} s" for v in order_variants(by_variant.index)))
    if exp:
        blocks.append("## Effective experiment settings")
        for key in ("runs", "suites", "n_steps", "sensor_range", "min_distance", "slam", "variants",
                    "repetitions", "metric", "timeout_s", "detection", "space"):
            if key in exp:
                blocks.append(f"- {key}: {exp[key]}")
    pages = text_pages("Run metadata", blocks)
    if seeds:
        frame = pd.DataFrame(seeds, columns=["run", "suite", "case", "seed (SeedSequence entropy)",
                                             "landmarks", "steps"]).astype(str)
        pages += table_pages("Run metadata: test-case seeds", frame, fontsize=8, max_rows=32)
    return pages


# --------------------------------------------------------------------------- entry point


def build_report(results_dir: str | Path, reports_dir: str | Path, *, alpha: float = 0.05,
                 range_factor: float = 2.0, paper_raw: str | Path | None = None,
                 paper_reported: str | Path | None = None) -> ReportFiles:
    """Write Table II, detection rates, the comparison and ``report.pdf`` from saved results.

    Parameters
    ----------
    results_dir : path
        Output directory of :func:`faultlab.runner.run_experiment` (or its results.sqlite).
    reports_dir : path
        Where to write (created): table2.csv/.md/.tex, detection_rates.csv/.md,
        comparison.md, report.pdf.
    alpha : float
        1 - confidence level of every interval.
    range_factor : float
        Widening of the paper's baseline error range in the comparison
        (:func:`faultlab.report.comparison.compare_with_paper`).
    paper_raw, paper_reported : path, optional
        The paper's data; default ``paper_repro/`` (see :func:`faultlab.stats.resolve_data_path`).

    Returns
    -------
    ReportFiles

    Raises
    ------
    ResultsError
        No results store at ``results_dir``, or it holds no rows.
    """
    from faultlab.runner import load_metadata, load_results

    results_dir = Path(results_dir)
    reports_dir = Path(reports_dir)
    meta = load_metadata(results_dir)
    results = load_results(results_dir)
    if results.empty:
        raise ResultsError(f"the results store at {results_dir} holds no rows yet: nothing to report")
    rule = _rule_of(meta)
    notes: list[str] = []
    if meta.get("metric", "rms") != "rms":
        notes.append(f"the experiment's primary metric is {meta.get('metric')!r}; Table II and every "
                     "detection figure use the Kabsch-aligned RMS error, as the paper does.")
    equivalent = stats.suspected_equivalent_faults(results)
    if equivalent:
        notes.append(f"{', '.join(equivalent)}: every result is identical to the baseline's, so in this "
                     "campaign the fault never changed the SLAM's output (an equivalent mutant here); its "
                     "0 % detection rate says nothing about the suites. Check it with "
                     "`python -m faultlab faults --check`.")
    try:
        paper = load_paper(paper_raw, paper_reported, rule=rule)
    except ResultsError as exc:
        paper = None
        notes.append(f"the paper's data was not found, so nothing is compared with it ({exc}).")
    rep = int(results["rep"].min())
    table = table2(results, rule=rule, paper=paper, rep=rep, alpha=alpha)
    detection = detection_frame(results, rule=rule, paper=paper, alpha=alpha)
    files: TableFiles = write_tables(table, detection, reports_dir)
    comparison = compare_with_paper(table, range_factor=range_factor)
    comparison_md = reports_dir / "comparison.md"
    comparison_md.write_text(comparison.markdown(), encoding="utf-8")

    exp = meta.get("experiment") or {}
    expected = None
    try:
        suites = exp.get("suites") or {}
        pairs = suites.items() if isinstance(suites, dict) else suites
        n_cases = sum(int(n) for _, n in pairs)  # "auto" / None: unknown, skipped below
        expected = int(exp["runs"]) * n_cases * len(exp["variants"]) * int(exp["repetitions"])
    except (KeyError, TypeError, ValueError, AttributeError):
        pass
    if expected is not None and len(results) < expected:
        notes.append(f"the campaign is incomplete: {len(results)} of {expected} jobs are stored "
                     "(resume it with the same command).")

    case_pages, seeds = _case_pages(results_dir, results, notes)
    paper_frame = paper_results_frame(paper) if paper is not None else None
    body = []
    body += _table2_pages(table)
    body += _rates_pages(detection, table)
    body += _comparison_pages(comparison)
    body.append(_titled(detection_rate_figure(detection, alpha=alpha),
                        "Detection rates per suite and fault with confidence intervals"))
    body.append(_titled(rms_distribution_figure(results, paper_results=paper_frame),
                        "RMS map error distributions per suite and variant (log scale)"))
    body += case_pages
    body += _coverage_pages(results, meta, notes)
    body += _beyond_pages(results, rule, alpha, int(results["rep"].nunique()))
    body += _metadata_pages(meta, results, seeds)
    pages = _title_page(meta, results, comparison, notes) + body
    pdf = write_pdf(reports_dir / "report.pdf", pages,
                    title="faultlab report: the paper's Table II reproduced",
                    subject=f"experiment {meta.get('experiment_source', '')} "
                            f"hash {meta.get('experiment_hash', '')}",
                    footer=f"faultlab {__version__}")
    return ReportFiles(
        reports_dir=reports_dir,
        table2_csv=files.table2_csv,
        table2_md=files.table2_md,
        table2_tex=files.table2_tex,
        detection_csv=files.detection_csv,
        detection_md=files.detection_md,
        comparison_md=comparison_md,
        pdf=pdf.path,
        n_pages=pdf.n_pages,
        page_titles=pdf.titles,
        comparison=comparison,
        n_rows=len(results),
        notes=tuple(notes),
    )
