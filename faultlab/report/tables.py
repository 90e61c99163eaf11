"""Table II of a run (Sec. VII-D) beside the paper's, and the detection rates, as CSV, Markdown and LaTeX.

The table has the paper's layout: one row per (suite, algorithm variant), one column per
(evaluation run, test case) holding the case's RMS map error rounded to mm, the cells whose
case detects the fault (the paper's green cells) marked, then the share of cases that detect
the fault ("Detected Faults", with a 95 % confidence interval) and the suite's "by Suite"
figure.  Every row appears twice: once for this run, once for the paper (the paper's raw
RMS data of ``paper_repro/`` and its printed percentages).

Everything shown comes from an :class:`~faultlab.analysis.Analysis`; this module selects,
orders and formats its tables and computes nothing.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, NamedTuple, Sequence

import pandas as pd

from faultlab.analysis import Analysis
from faultlab.analysis.schema import DETECTION_RATES, PAPER, THIS_RUN
from faultlab.precision import write_csv
from faultlab.vocabulary import BASELINE, PAPER_FAULTS, SUITE_ORDER, JobStatus, ordered

__all__ = [
    "THIS_RUN",
    "PAPER",
    "RUNS_PER_BLOCK",
    "round_mm",
    "format_mm",
    "format_pct",
    "format_pct_interval",
    "md_table",
    "suite_label",
    "variant_label",
    "order_variants",
    "order_suites",
    "cell_text",
    "table2_rows",
    "table2_columns",
    "table2_runs",
    "table2_frame",
    "table2_caption",
    "table2_csv_frame",
    "tex_escape",
    "table2_markdown",
    "table2_latex",
    "detection_markdown",
    "detection_records",
    "verdict_text",
    "campaign_verdict_records",
    "campaign_verdict_note",
    "campaign_verdict_line",
    "write_tables",
    "TableFiles",
]

_VARIANT_LABELS = {
    "baseline": "Nonfaulty Baseline",
    "naive_resampling": "Naive Resampling",
    "missing_angle_wrap": "Faulty Rotation",
    "motion_sign_error": "Sign Error",
}

#: Number of evaluation runs per block of columns in Markdown / LaTeX / PDF (the paper shows 3).
RUNS_PER_BLOCK = 3


# --------------------------------------------------------------------------- labels, rounding


def suite_label(suite: str) -> str:
    """``"systematic"`` -> ``"Systematic"`` (the paper's spelling)."""
    return str(suite).capitalize()


def variant_label(variant: str) -> str:
    """The paper's name of a variant (``missing_angle_wrap`` -> ``Faulty Rotation``)."""
    return _VARIANT_LABELS.get(str(variant), str(variant))


def order_variants(variants: Iterable[str]) -> list[str]:
    """Baseline first, then the paper's faults in Table II order, then others alphabetically."""
    return ordered((str(v) for v in variants), (BASELINE,) + PAPER_FAULTS)


def order_suites(suites: Iterable[str]) -> list[str]:
    """The paper's suite order (systematic, fixed, random), unknown suites last."""
    return ordered((str(s) for s in suites), SUITE_ORDER)


def round_mm(value: float) -> int:
    """Round an error in mm to a whole mm, halves away from zero (as the paper's table).

    Python's ``round`` rounds halves to even (``round(40.5) == 40``); a printed table
    rounds 40.5 up: halves go away from zero.
    """
    value = float(value)
    if not math.isfinite(value):
        raise ValueError(f"cannot round a non-finite error {value!r} to mm")
    a = abs(value)
    whole = math.floor(a)
    # a - floor(a) is exact in floating point, unlike a + 0.5 (0.49999999999999994 + 0.5 == 1.0)
    rounded = whole + 1 if a - whole >= 0.5 else whole
    return int(-rounded if value < 0 else rounded)


def format_mm(value: float) -> str:
    """``5615.8`` -> ``"5616"``; NaN -> ``""``."""
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    return str(round_mm(value))


def format_pct(rate: float, digits: int = 0) -> str:
    """A rate in [0, 1] as a percentage string (``0.2667`` -> ``"27"``)."""
    if rate is None or not math.isfinite(float(rate)):
        return ""
    pct = 100.0 * float(rate)
    if digits == 0:
        return str(round_mm(pct))
    return f"{pct:.{digits}f}"


def format_pct_interval(low: float, high: float, digits: int = 0) -> str:
    """An interval of rates as percentages, ``low-high`` (each as :func:`format_pct`)."""
    return f"{format_pct(low, digits)}-{format_pct(high, digits)}"


# --------------------------------------------------------------------------- Table II layout


def table2_columns(analysis: Analysis) -> list[tuple[int, int]]:
    """All (run, case) columns of Table II, sorted."""
    pairs = analysis.table2_cells[["run", "case"]].drop_duplicates()
    return sorted((int(r), int(c)) for r, c in pairs.itertuples(index=False))


def table2_runs(analysis: Analysis) -> list[int]:
    """The evaluation runs of Table II's columns."""
    return sorted({r for r, _ in table2_columns(analysis)})


def table2_rows(analysis: Analysis) -> list[tuple[str, str, str]]:
    """(suite, variant, source) of every row, in the paper's order, this run before paper."""
    cells = analysis.table2_cells
    present = set(map(tuple, cells[["suite", "variant", "source"]].drop_duplicates().itertuples(index=False)))
    sources = [s for s in (THIS_RUN, PAPER) if s in set(cells["source"])]
    return [(s, v, src) for s in order_suites(cells["suite"]) for v in order_variants(cells["variant"])
            for src in sources if (s, v, src) in present]


def _blocks(analysis: Analysis) -> list[list[int]]:
    runs = table2_runs(analysis)
    return [runs[i:i + RUNS_PER_BLOCK] for i in range(0, len(runs), RUNS_PER_BLOCK)] or [[]]


class _Rate(NamedTuple):
    """One Table II figure: a rate with its Wilson interval and the paper's printed percentage."""

    rate: float
    low: float
    high: float
    printed: float


def _rate_figures(analysis: Analysis) -> dict[tuple[str, str, str], _Rate]:
    """(source, suite, variant) -> "Detected Faults" figure of this run and of the paper."""
    out = {(THIS_RUN, r.suite, r.variant): _Rate(r.rate, r.wilson_low, r.wilson_high, math.nan)
           for r in analysis.detection_rates.itertuples(index=False)}
    out.update({(PAPER, r.suite, r.fault): _Rate(r.rate, r.wilson_low, r.wilson_high, r.reported_pct)
                for r in analysis.paper_rates.itertuples(index=False)})
    return out


def _by_suite_figures(analysis: Analysis) -> dict[tuple[str, str], _Rate]:
    """(source, suite) -> "by Suite" figure of this run and of the paper."""
    out = {(THIS_RUN, r.suite): _Rate(r.rate, r.wilson_low, r.wilson_high, math.nan)
           for r in analysis.by_suite.itertuples(index=False)}
    out.update({(PAPER, r.suite): _Rate(r.rate, r.wilson_low, r.wilson_high, r.reported_pct)
                for r in analysis.paper_by_suite.itertuples(index=False)})
    return out


# --------------------------------------------------------------------------- cell text


def cell_text(rms_mm: float, status: str, detected: bool, *, style: str = "csv") -> str:
    """Text of one RMS cell: mm rounded, detected cells marked.

    ``style`` "csv" appends ``*``; "md" wraps in ``**``; "tex" wraps in ``\\textbf{}``;
    "plain" leaves the number unmarked.  Crashed / timed-out jobs show their status.
    """
    if status in (JobStatus.CRASH.value, JobStatus.TIMEOUT.value):
        return status
    if status == "missing" or rms_mm is None or not math.isfinite(float(rms_mm)):
        return ""
    text = format_mm(rms_mm)
    if not detected:
        return text
    return {"csv": f"{text}*", "md": f"**{text}**", "tex": f"\\textbf{{{text}}}",
            "plain": text}[style]


def _percent_text(figure: _Rate | None, *, empty: str) -> str:
    """The rate in whole percent; where the paper printed another figure, the printed one first
    and the rule's in brackets."""
    if figure is None:
        return empty
    computed = format_pct(figure.rate)
    if not pd.isna(figure.printed):
        printed = str(round_mm(float(figure.printed)))
        return printed if printed == computed else f"{printed} (rule: {computed})"
    return computed


def _ci_text(figure: _Rate | None) -> str:
    if figure is None or pd.isna(figure.low):
        return ""
    return format_pct_interval(figure.low, figure.high)


def table2_frame(analysis: Analysis, *, style: str = "csv", runs: Sequence[int] | None = None) -> pd.DataFrame:
    """Table II as a frame of strings in the paper's layout (+ a ``Source`` column).

    Columns: Suite, Algorithm, Source, ``R<run>C<case>`` for every (run, case) (only ``runs`` if
    given), ``Detected %``, ``95% CI``, ``by Suite %`` (on the baseline row, as in the paper).
    """
    cols = [(r, c) for r, c in table2_columns(analysis) if runs is None or r in runs]
    lookup = {(row.source, row.suite, row.variant, int(row.run), int(row.case)): row
              for row in analysis.table2_cells.itertuples(index=False)}
    rates, by_suite = _rate_figures(analysis), _by_suite_figures(analysis)
    records = []
    for suite, variant, source in table2_rows(analysis):
        rec = {"Suite": suite_label(suite), "Algorithm": variant_label(variant), "Source": source}
        for run, case in cols:
            cell = lookup.get((source, suite, variant, run, case))
            rec[f"R{run}C{case}"] = ("" if cell is None else
                                     cell_text(cell.rms_mm, cell.status, cell.detected, style=style))
        if variant == BASELINE:
            rec["Detected %"], rec["95% CI"] = "-", ""
            rec["by Suite %"] = _percent_text(by_suite.get((source, suite)), empty="")
        else:
            figure = rates.get((source, suite, variant))
            rec["Detected %"] = _percent_text(figure, empty="-")
            rec["95% CI"] = _ci_text(figure)
            rec["by Suite %"] = ""
        records.append(rec)
    return pd.DataFrame.from_records(records)


def table2_csv_frame(analysis: Analysis) -> pd.DataFrame:
    """The CSV form: every run's columns, detected cells suffixed with ``*``."""
    return table2_frame(analysis, style="csv")


def table2_caption(analysis: Analysis) -> str:
    n_reps = analysis.n_reps
    rep = "" if n_reps == 1 else (
        f" RMS cells and rates show SLAM repetition {analysis.rep} of {n_reps} (one pair per case, as the paper);"
        " the case-level verdicts use every repetition.")
    conf = round_mm(100 * (1 - analysis.alpha))
    return ("RMS map errors (rounded to mm); cells whose case detects the fault are marked "
            "(the paper's green cells). Detected %: share of cases detecting the fault, with its "
            f"{conf} % Wilson interval; for the paper the printed figure, and in brackets the rule "
            "applied to the paper's raw data where the two differ. by Suite %: share of fault x run "
            "pairs detected by at least one case." + rep)


def md_table(frame: pd.DataFrame) -> str:
    """A Markdown table of ``frame``: header, separator, one line per row (cells as ``str``)."""
    header = "| " + " | ".join(frame.columns) + " |"
    sep = "| " + " | ".join("---" for _ in frame.columns) + " |"
    body = ["| " + " | ".join(str(v) for v in row) + " |" for row in frame.itertuples(index=False)]
    return "\n".join([header, sep, *body])


def table2_markdown(analysis: Analysis) -> str:
    """Markdown: one table per block of three evaluation runs; detected cells in bold."""
    parts = ["# Table II: this run beside the paper", "", table2_caption(analysis), ""]
    blocks = _blocks(analysis)
    for block in blocks:
        if len(blocks) > 1:
            parts += [f"## Evaluation runs {block[0]}-{block[-1]}", ""]
        parts += [md_table(table2_frame(analysis, style="md", runs=block)), ""]
    return "\n".join(parts)


_TEX_ESCAPES = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#",
                "_": r"\_", "{": r"\{", "}": r"\}", "~": r"\textasciitilde{}",
                "^": r"\textasciicircum{}"}


def tex_escape(text: str) -> str:
    """Escape LaTeX's special characters in plain text."""
    return "".join(_TEX_ESCAPES.get(ch, ch) for ch in str(text))


def _tex_cell(text: str) -> str:
    # cells made by cell_text(style="tex") already hold LaTeX; escape everything else
    return text if text.startswith("\\textbf{") else tex_escape(text)


def _tex_block(frame: pd.DataFrame, block: Sequence[int]) -> list[str]:
    """One booktabs ``tabular`` of Table II: two header rows, a rule between suites."""
    cases = [c for c in frame.columns if c.startswith("R")]
    out = [f"\\begin{{tabular}}{{lll{'r' * len(cases)}rrr}}", "\\toprule"]
    header1 = ["", "", ""]
    for run in block:
        n_cases = sum(1 for c in cases if c.startswith(f"R{run}C"))
        header1.append(f"\\multicolumn{{{n_cases}}}{{c}}{{Evaluation Run {run}}}")
    header1 += ["", "", ""]
    out.append(" & ".join(header1) + " \\\\")
    header2 = ["Suite", "Algorithm", "Source"] + [c.split("C", 1)[1] for c in cases] + [
        "Detected \\%", "95\\% CI", "by Suite \\%"]
    out += [" & ".join(header2) + " \\\\", "\\midrule"]
    previous = None
    for row in frame.itertuples(index=False):
        values = list(row)
        if previous is not None and values[0] != previous:
            out.append("\\midrule")
        previous = values[0]
        out.append(" & ".join(_tex_cell(str(v)) for v in values) + " \\\\")
    return out + ["\\bottomrule", "\\end{tabular}", ""]


def table2_latex(analysis: Analysis) -> str:
    """LaTeX (booktabs): one ``tabular`` per block of three runs; detected cells in bold."""
    out = [
        "% Table II of a faultlab run beside the paper's; needs \\usepackage{booktabs}",
        "\\begin{table*}",
        "\\centering",
        "\\scriptsize",
        "\\setlength{\\tabcolsep}{2.5pt}",
    ]
    for block in _blocks(analysis):
        out += _tex_block(table2_frame(analysis, style="tex", runs=block), block)
    out.append(f"\\caption{{{tex_escape(table2_caption(analysis))}}}")
    out.append("\\label{tab:faultlab-table2}")
    out.append("\\end{table*}")
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------- detection rates


def detection_records(analysis: Analysis, *, compact: bool = False) -> pd.DataFrame:
    """Display rows of the Analysis' detection rates: one per (suite, fault), formatted strings.

    Columns: suite, fault, k/n, rate, Wilson and Clopper-Pearson intervals, the
    crash / timeout / baseline-failed counts, the rate with failures counted as
    detections and the paper's figures where there is paper data.  ``compact`` gives the
    short headers of the PDF page.
    """
    conf = round_mm(100 * (1 - analysis.alpha))
    cp = "C-P" if compact else "Clopper-Pearson"
    incl = "Rate % incl. failures" if compact else "Rate % (crash, timeout = detected)"
    paper_rule = "Paper % (rule)" if compact else "Paper % (rule on raw data)"
    records = []
    for r in analysis.detection_rates.itertuples(index=False):
        rec = {
            "Suite": suite_label(r.suite),
            "Fault": variant_label(r.variant),
            "k/n": f"{r.k}/{r.n}",
            "Rate %": format_pct(r.rate, 1),
            f"Wilson {conf} %": format_pct_interval(r.wilson_low, r.wilson_high, 1),
            f"{cp} {conf} %": format_pct_interval(r.cp_low, r.cp_high, 1),
            "crash": str(r.crash),
            "timeout": str(r.timeout),
            "baseline failed": str(r.baseline_failed),
            incl: (format_pct(r.rate_incl, 1) if compact else
                   f"{format_pct(r.rate_incl, 1)} ({r.k_incl}/{r.n_incl})"),
        }
        if analysis.has_paper:
            rec[paper_rule] = format_pct(r.paper_rate, 1)
            rec["Paper % (printed)"] = "" if pd.isna(r.paper_printed_pct) else str(round_mm(r.paper_printed_pct))
        records.append(rec)
    return pd.DataFrame.from_records(records)


def _p_text(p: float) -> str:
    return "" if not math.isfinite(p) else f"{p:.2g}"


def verdict_text(verdict: str, p_min: float) -> str:
    """A verdict in words: "changed", "no change shown", or "cannot judge (smallest attainable p = ...)"."""
    if verdict == "detected":
        return "changed"
    if verdict == "not_detected":
        return "no change shown"
    return f"cannot judge (smallest attainable p = {p_min:.3g})" if math.isfinite(p_min) else "cannot judge"


def _factor(x: float) -> str:
    return "" if not math.isfinite(x) else f"{x:.3g}"


def campaign_verdict_records(analysis: Analysis) -> pd.DataFrame:
    """Display rows of the campaign-level verdicts (:func:`faultlab.stats.pooling.campaign_verdicts`)."""
    conf = round_mm(100 * (1 - analysis.alpha))
    records = []
    for r in analysis.campaign_verdicts.itertuples(index=False):
        records.append({
            "Fault": variant_label(r.fault) + (" (A/A control)" if r.family == "control" else ""),
            "Verdict": verdict_text(r.verdict, r.p_min),
            "Direction": r.direction if r.n_tested else "",
            "Error factor": _factor(r.ratio),
            f"{conf} % interval": (f"[{_factor(r.ratio_low)}, {_factor(r.ratio_high)}]"
                                   if math.isfinite(r.ratio_low) and math.isfinite(r.ratio_high) else "none possible"),
            "Cases tested/all": f"{r.n_tested}/{r.n_cases}",
            "Crashed": str(r.n_crashed),
            "Judged exactly": str(r.n_exact),
            "Suite draws": str(r.n_draws),
            "p": _p_text(r.p) + (" (Monte Carlo)" if r.mc_se > 0 else ""),
            "p (Holm)": _p_text(r.p_holm),
            "Smallest attainable p": _p_text(r.p_min),
        })
    return pd.DataFrame.from_records(records)


def campaign_verdict_note(analysis: Analysis) -> str:
    """What the campaign-level verdicts are (test, unit, sidedness, level, family)."""
    v = analysis.campaign_verdicts
    alternative = v["alternative"].iloc[0] if len(v) else "two-sided"
    n_faults = int((v["family"] == "faults").sum()) if len(v) else 0
    return (f"Per fault, over all its cases (every suite and run): the exact {alternative} sign-flip test over the "
            f"cases' mean log ratios faulty / baseline (the case is the unit: its K repetitions are averaged first; "
            f"Monte Carlo over 99,999 sign patterns beyond 20 cases), alpha = {analysis.rule.alpha:g}, Holm over "
            f"the campaign's {n_faults} fault(s); the A/A replica is a control judged alone. Error factor: the "
            f"geometric mean of faulty / baseline error over the cases (below 1: better), with the interval that "
            f"inverts the same test (unadjusted). A case whose repetitions are bit-identical (a deterministic SLAM) "
            f"enters with its exact ratio; crashed cases and those whose baseline failed are left out. 'cannot "
            f"judge': no outcome of the test could reach alpha with this many cases. The test is exact given the drawn cases; "
            f"'suite draws' is the number of independent (run, suite) draws they come from.")


def campaign_verdict_line(row) -> str:
    """One sentence of the summary: a fault's campaign-level verdict with its effect and test."""
    head = verdict_text(row.verdict, row.p_min)
    if not row.n_tested:
        return f"campaign level: {head} (no case with a paired error)"
    interval = (f" [{_factor(row.ratio_low)}, {_factor(row.ratio_high)}]"
                if math.isfinite(row.ratio_low) and math.isfinite(row.ratio_high) else "")
    return (f"campaign level: {head}, {row.direction} (error x {_factor(row.ratio)}{interval} over "
            f"{row.n_tested} cases; exact {row.alternative} sign-flip test over the case means, alpha = "
            f"{row.alpha:g}, family {row.family}, p = {_p_text(row.p)}, Holm p = {_p_text(row.p_holm)})")


def detection_markdown(analysis: Analysis) -> str:
    """Markdown of the detection rates (k/n, rate, Wilson and Clopper-Pearson intervals) and of the
    campaign-level verdict of every fault."""
    conf = round_mm(100 * (1 - analysis.alpha))
    records = detection_records(analysis)
    body = md_table(records) if len(records) else "(no faulty variants)"
    lines = ["# Detection rates per suite and fault", "",
             f"Confidence level {conf} %. k/n counts the faulty jobs detected among those "
             "where both the faulty and the baseline SLAM produced a map; crashes and "
             "timeouts of the faulty SLAM are their own outcome classes (counted in their "
             "columns, and as detections in the last rate); 'baseline failed' jobs judge "
             "nothing.", "", body, ""]
    verdicts = campaign_verdict_records(analysis)
    if len(verdicts):
        lines += ["## Campaign-level verdict per fault", "", campaign_verdict_note(analysis), "",
                  md_table(verdicts), ""]
    return "\n".join(lines)


# --------------------------------------------------------------------------- writing


@dataclass(frozen=True)
class TableFiles:
    """Paths of the written tables."""

    table2_csv: Path
    table2_md: Path
    table2_tex: Path
    detection_csv: Path
    detection_md: Path


def write_tables(analysis: Analysis, reports_dir: str | Path) -> TableFiles:
    """Write table2.csv/.md/.tex and detection_rates.csv/.md into ``reports_dir``.

    ``detection_rates.csv`` is the Analysis' detection-rate table as it is
    (:data:`faultlab.analysis.schema.DETECTION_RATES`).
    """
    reports_dir = Path(reports_dir)
    reports_dir.mkdir(parents=True, exist_ok=True)
    files = TableFiles(
        table2_csv=reports_dir / "table2.csv",
        table2_md=reports_dir / "table2.md",
        table2_tex=reports_dir / "table2.tex",
        detection_csv=reports_dir / "detection_rates.csv",
        detection_md=reports_dir / "detection_rates.md",
    )
    write_csv(table2_csv_frame(analysis), files.table2_csv)
    files.table2_md.write_text(table2_markdown(analysis), encoding="utf-8")
    files.table2_tex.write_text(table2_latex(analysis), encoding="utf-8")
    DETECTION_RATES.to_csv(analysis.detection_rates, files.detection_csv)
    files.detection_md.write_text(detection_markdown(analysis), encoding="utf-8")
    return files
