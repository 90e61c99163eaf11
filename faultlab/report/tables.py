"""Table II of a run (Sec. VII-D) beside the paper's, as CSV, Markdown and LaTeX.

The table has the paper's layout: one row per (suite, algorithm variant), one column per
(evaluation run, test case) holding the case's RMS map error rounded to mm, the cells whose
case detects the fault (the paper's green cells) marked, then the share of cases that detect
the fault ("Detected Faults", with a 95 % confidence interval) and the suite's "by Suite"
figure.  Every row appears twice: once for this run, once for the paper (the paper's raw
RMS data of ``paper_repro/`` and its printed percentages).

Detection, rates and confidence intervals come from :mod:`faultlab.stats`; this module only
arranges and formats them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np
import pandas as pd

from faultlab import stats
from faultlab.errors import ResultsError
from faultlab.vocabulary import BASELINE, PAPER_FAULTS, SUITE_ORDER

__all__ = [
    "THIS_RUN",
    "PAPER",
    "SUITE_ORDER",
    "PAPER_FAULTS",
    "Table2",
    "table2",
    "round_mm",
    "format_mm",
    "suite_label",
    "variant_label",
    "order_variants",
    "order_suites",
    "format_pct",
    "cell_text",
    "default_rule",
    "paired",
    "rates",
    "suite_rates",
    "paper_results_frame",
    "load_paper",
    "table2_frame",
    "table2_caption",
    "RUNS_PER_BLOCK",
    "table2_csv_frame",
    "tex_escape",
    "table2_markdown",
    "table2_latex",
    "detection_frame",
    "detection_markdown",
    "detection_records",
    "write_tables",
    "TableFiles",
]

#: Source labels of the two halves of the comparison.
THIS_RUN = "this run"
PAPER = "paper"


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
    variants = list(dict.fromkeys(str(v) for v in variants))
    head = [v for v in (BASELINE,) + PAPER_FAULTS if v in variants]
    return head + sorted(v for v in variants if v not in head)


def order_suites(suites: Iterable[str]) -> list[str]:
    """The paper's suite order (systematic, fixed, random), unknown suites last."""
    suites = list(dict.fromkeys(str(s) for s in suites))
    head = [s for s in SUITE_ORDER if s in suites]
    return head + sorted(s for s in suites if s not in head)


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


# --------------------------------------------------------------------------- statistics access
#
# All detection logic, rates and intervals live in faultlab.stats (helper C).  These functions
# call it and only rename columns for the report:
#   paired:      faultlab.stats.outcomes            -> ..., variant (= fault), outcome, detected
#   rates:       faultlab.stats.detection_rates     -> ..., variant (= fault), k, n, rate, wilson_*, cp_*
#   suite_rates: faultlab.stats.by_suite            -> suite, k (= detected_pairs), n (= n_pairs), rate, ...


def default_rule():
    """The paper's detection rule (250 mm and 25 %), :class:`faultlab.stats.DetectionRule`."""
    return stats.DetectionRule()


def paired(results: pd.DataFrame, *, rule) -> pd.DataFrame:
    """Each faulty job beside its baseline with its outcome class (:func:`faultlab.stats.outcomes`).

    Columns as faultlab.stats gives them, with ``fault`` renamed ``variant`` and a boolean
    ``detected`` (outcome == "detected").
    """
    out = stats.outcomes(results, rule=rule).rename(columns={"fault": "variant"})
    out["detected"] = out["outcome"].astype(str) == "detected"
    return out


def rates(results: pd.DataFrame, *, rule, alpha: float = 0.05) -> pd.DataFrame:
    """Detection rate per (suite, fault) with Wilson and Clopper-Pearson intervals
    (:func:`faultlab.stats.detection_rates`; ``fault`` renamed ``variant``)."""
    return stats.detection_rates(results, rule=rule, alpha=alpha).rename(
        columns={"fault": "variant"})


def suite_rates(results: pd.DataFrame, *, rule, alpha: float = 0.05) -> pd.DataFrame:
    """The paper's "by Suite" share (:func:`faultlab.stats.by_suite`), with ``k`` = detected
    pairs and ``n`` = fault x run pairs."""
    out = stats.by_suite(results, rule=rule, alpha=alpha)
    return out.rename(columns={"detected_pairs": "k", "n_pairs": "n"})


# --------------------------------------------------------------------------- Table II


@dataclass(frozen=True)
class Table2:
    """Table II of a run beside the paper's.

    Attributes
    ----------
    cells : DataFrame
        One row per (source, suite, variant, run, case): ``rms_mm`` (NaN unless ok),
        ``status`` (ok | crash | timeout | missing), ``detected`` (bool, False for baselines).
        For this run the cells are SLAM repetition ``rep`` (the paper ran each case once).
    rates : DataFrame
        One row per (source, suite, variant) of a fault: ``k``, ``n``, ``rate``, ``ci_low``,
        ``ci_high`` (Wilson), and ``printed_pct`` (the paper's printed figure, NaN for this run).
    by_suite : DataFrame
        One row per (source, suite): ``k``, ``n``, ``rate``.
    rep : int
        The SLAM repetition shown in the RMS cells.
    n_reps : int
        Repetitions per case in this run (the rates count all of them).
    alpha : float
        1 - confidence level of the intervals.
    """

    cells: pd.DataFrame
    rates: pd.DataFrame
    by_suite: pd.DataFrame
    rep: int = 0
    n_reps: int = 1
    alpha: float = 0.05

    @property
    def sources(self) -> list[str]:
        return [s for s in (THIS_RUN, PAPER) if s in set(self.cells["source"])]

    @property
    def suites(self) -> list[str]:
        return order_suites(self.cells["suite"])

    @property
    def variants(self) -> list[str]:
        return order_variants(self.cells["variant"])

    @property
    def columns(self) -> list[tuple[int, int]]:
        """All (run, case) columns, sorted."""
        pairs = self.cells[["run", "case"]].drop_duplicates()
        return sorted((int(r), int(c)) for r, c in pairs.itertuples(index=False))

    def runs(self) -> list[int]:
        return sorted({r for r, _ in self.columns})

    def rows(self) -> list[tuple[str, str, str]]:
        """(suite, variant, source) of every row, in the paper's order, this run before paper."""
        present = set(map(tuple, self.cells[["suite", "variant", "source"]].drop_duplicates()
                          .itertuples(index=False)))
        return [(s, v, src) for s in self.suites for v in self.variants for src in self.sources
                if (s, v, src) in present]


def _cells_of(results: pd.DataFrame, pairs: pd.DataFrame, *, source: str, rep: int) -> pd.DataFrame:
    base = results[results["rep"] == rep]
    cells = base[["suite", "variant", "run", "case", "rms_mm", "status"]].copy()
    cells["rms_mm"] = np.where(cells["status"] == "ok", cells["rms_mm"], np.nan)
    det = pairs[pairs["rep"] == rep][["suite", "variant", "run", "case", "detected"]]
    cells = cells.merge(det, on=["suite", "variant", "run", "case"], how="left")
    cells["detected"] = cells["detected"].fillna(False).astype(bool)
    cells.insert(0, "source", source)
    return cells


def _rates_of(results: pd.DataFrame, *, rule, alpha: float, source: str) -> pd.DataFrame:
    r = rates(results, rule=rule, alpha=alpha)
    out = pd.DataFrame({
        "source": source,
        "suite": r["suite"].astype(str),
        "variant": r["variant"].astype(str),
        "k": r["k"].astype(int),
        "n": r["n"].astype(int),
        "rate": r["rate"].astype(float),
        "ci_low": r["wilson_low"].astype(float),
        "ci_high": r["wilson_high"].astype(float),
    })
    out["printed_pct"] = np.nan
    return out


def _by_suite_of(results: pd.DataFrame, *, rule, alpha: float, source: str) -> pd.DataFrame:
    b = suite_rates(results, rule=rule, alpha=alpha)
    out = pd.DataFrame({
        "source": source,
        "suite": b["suite"].astype(str),
        "k": b["k"].astype(int),
        "n": b["n"].astype(int),
        "rate": b["rate"].astype(float),
    })
    low, high = ("wilson_low", "wilson_high") if "wilson_low" in b else ("ci_low", "ci_high")
    out["ci_low"] = b[low].astype(float) if low in b else np.nan
    out["ci_high"] = b[high].astype(float) if high in b else np.nan
    out["printed_pct"] = np.nan
    return out


def paper_results_frame(paper) -> pd.DataFrame:
    """The paper's raw RMS rows in the results schema (rep 0, every job ok).

    ``paper`` is a :class:`faultlab.stats.PaperTable` (its ``raw_path`` is read with
    :func:`faultlab.stats.load_paper_raw`) or such a frame already.
    """
    if isinstance(paper, pd.DataFrame):
        frame = paper
    else:
        frame = stats.load_paper_raw(paper.raw_path)
    need = {"suite", "variant", "run", "case", "rep", "rms_mm", "status"}
    missing = need - set(frame.columns)
    if missing:
        raise ResultsError(f"paper RMS table lacks column(s) {', '.join(sorted(missing))}")
    return frame


def _printed_rates(paper) -> pd.DataFrame | None:
    """The paper's printed "Detected Faults" percentages: suite, variant, printed_pct."""
    r = getattr(paper, "rates", None)
    if not isinstance(r, pd.DataFrame) or "reported_pct" not in r:
        return None
    return r[["suite", "fault", "reported_pct"]].rename(
        columns={"fault": "variant", "reported_pct": "printed_pct"})


def _printed_by_suite(paper) -> pd.DataFrame | None:
    """The paper's printed "by Suite" percentages: suite, printed_pct."""
    b = getattr(paper, "by_suite", None)
    if not isinstance(b, pd.DataFrame) or "reported_pct" not in b:
        return None
    return b[["suite", "reported_pct"]].rename(columns={"reported_pct": "printed_pct"})


def load_paper(raw_csv=None, reported_csv=None, *, rule=None):
    """The paper's Table II data (:func:`faultlab.stats.paper_table`), found by
    :func:`faultlab.stats.resolve_data_path` (``paper_repro/`` of the working directory or
    the repository) unless paths are given."""
    resolve = stats.resolve_data_path
    raw = resolve(raw_csv, stats.RAW_CSV)
    reported = resolve(reported_csv, stats.REPORTED_CSV)
    rule = default_rule() if rule is None else rule
    return stats.paper_table(raw, reported, rule=rule)


def table2(results: pd.DataFrame, *, rule=None, paper=None, rep: int = 0,
           alpha: float = 0.05) -> Table2:
    """Build Table II of a run, and of the paper when ``paper`` is given.

    Parameters
    ----------
    results : DataFrame
        Results store (schema in BRIEF.md).
    rule : faultlab.stats.DetectionRule, optional
        Detection rule; the paper's (250 mm, 25 %) by default.
    paper : PaperTable or DataFrame, optional
        The paper's data (:func:`faultlab.stats.paper.paper_table`); its RMS grid goes through the
        same detection code as this run's, and its printed percentages are kept beside.
    rep : int
        SLAM repetition shown in the RMS cells (rates count every repetition).
    """
    rule = default_rule() if rule is None else rule
    if results is None or len(results) == 0:
        raise ResultsError("the results store holds no rows: nothing to tabulate")
    if rep not in set(results["rep"].astype(int)):
        raise ResultsError(f"no results for SLAM repetition {rep}; the store has "
                           f"{sorted(set(results['rep'].astype(int)))}")
    cells = [_cells_of(results, paired(results, rule=rule), source=THIS_RUN, rep=rep)]
    rate_frames = [_rates_of(results, rule=rule, alpha=alpha, source=THIS_RUN)]
    suite_frames = [_by_suite_of(results, rule=rule, alpha=alpha, source=THIS_RUN)]
    if paper is not None:
        pres = paper_results_frame(paper)
        cells.append(_cells_of(pres, paired(pres, rule=rule), source=PAPER, rep=0))
        prates = _rates_of(pres, rule=rule, alpha=alpha, source=PAPER)
        printed = _printed_rates(paper)
        if printed is not None:
            prates = prates.drop(columns="printed_pct").merge(printed, on=["suite", "variant"],
                                                             how="left")
        rate_frames.append(prates)
        pby = _by_suite_of(pres, rule=rule, alpha=alpha, source=PAPER)
        printed_by = _printed_by_suite(paper)
        if printed_by is not None:
            pby = pby.drop(columns="printed_pct").merge(printed_by, on="suite", how="left")
        suite_frames.append(pby)
    n_reps = int(results["rep"].nunique())
    return Table2(
        cells=pd.concat(cells, ignore_index=True),
        rates=pd.concat(rate_frames, ignore_index=True),
        by_suite=pd.concat(suite_frames, ignore_index=True),
        rep=int(rep),
        n_reps=n_reps,
        alpha=float(alpha),
    )


# --------------------------------------------------------------------------- cell text


def cell_text(rms_mm: float, status: str, detected: bool, *, style: str = "csv") -> str:
    """Text of one RMS cell: mm rounded, detected cells marked.

    ``style`` "csv" appends ``*``; "md" wraps in ``**``; "tex" wraps in ``\\textbf{}``;
    "plain" leaves the number unmarked.  Crashed / timed-out jobs show their status.
    """
    if status in ("crash", "timeout"):
        return status
    if status == "missing" or rms_mm is None or not math.isfinite(float(rms_mm)):
        return ""
    text = format_mm(rms_mm)
    if not detected:
        return text
    return {"csv": f"{text}*", "md": f"**{text}**", "tex": f"\\textbf{{{text}}}",
            "plain": text}[style]


def _rate_row(table: Table2, suite: str, variant: str, source: str) -> pd.Series | None:
    r = table.rates
    m = r[(r["suite"] == suite) & (r["variant"] == variant) & (r["source"] == source)]
    return None if m.empty else m.iloc[0]


def _suite_row(table: Table2, suite: str, source: str) -> pd.Series | None:
    b = table.by_suite
    m = b[(b["suite"] == suite) & (b["source"] == source)]
    return None if m.empty else m.iloc[0]


def detected_text(row: pd.Series | None, *, source: str) -> str:
    """The "Detected Faults" figure: this run's rate; for the paper the printed % and,
    where the rule applied to the raw data gives another figure, that one too."""
    if row is None:
        return "-"
    computed = format_pct(row["rate"])
    printed = row.get("printed_pct", np.nan)
    if source == PAPER and printed is not None and not pd.isna(printed):
        printed = str(round_mm(float(printed)))
        return printed if printed == computed else f"{printed} (rule: {computed})"
    return computed


def ci_text(row: pd.Series | None) -> str:
    if row is None or pd.isna(row["ci_low"]):
        return ""
    return f"{format_pct(row['ci_low'])}-{format_pct(row['ci_high'])}"


def by_suite_text(row: pd.Series | None) -> str:
    if row is None:
        return ""
    computed = format_pct(row["rate"])
    printed = row.get("printed_pct", np.nan)
    if printed is not None and not pd.isna(printed):
        printed = str(round_mm(float(printed)))
        return printed if printed == computed else f"{printed} (rule: {computed})"
    return computed


def table2_frame(table: Table2, *, style: str = "csv",
                 runs: Sequence[int] | None = None) -> pd.DataFrame:
    """Table II as a frame of strings in the paper's layout (+ a ``Source`` column).

    Columns: Suite, Algorithm, Source, ``R<run>C<case>`` for every (run, case) (only ``runs`` if
    given), ``Detected %``, ``95% CI``, ``by Suite %`` (on the baseline row, as in the paper).
    """
    cols = [(r, c) for r, c in table.columns if runs is None or r in runs]
    lookup = {(row.source, row.suite, row.variant, int(row.run), int(row.case)): row
              for row in table.cells.itertuples(index=False)}
    records = []
    for suite, variant, source in table.rows():
        rec = {"Suite": suite_label(suite), "Algorithm": variant_label(variant), "Source": source}
        for run, case in cols:
            cell = lookup.get((source, suite, variant, run, case))
            rec[f"R{run}C{case}"] = ("" if cell is None else
                                     cell_text(cell.rms_mm, cell.status, cell.detected, style=style))
        if variant == "baseline":
            rec["Detected %"] = "-"
            rec["95% CI"] = ""
            rec["by Suite %"] = by_suite_text(_suite_row(table, suite, source))
        else:
            rrow = _rate_row(table, suite, variant, source)
            rec["Detected %"] = detected_text(rrow, source=source)
            rec["95% CI"] = ci_text(rrow)
            rec["by Suite %"] = ""
        records.append(rec)
    return pd.DataFrame.from_records(records)


def table2_csv_frame(table: Table2) -> pd.DataFrame:
    """The CSV form: every run's columns, detected cells suffixed with ``*``."""
    return table2_frame(table, style="csv")


def _blocks(table: Table2) -> list[list[int]]:
    runs = table.runs()
    return [runs[i:i + RUNS_PER_BLOCK] for i in range(0, len(runs), RUNS_PER_BLOCK)] or [[]]


def table2_caption(table: Table2) -> str:
    rep = "" if table.n_reps == 1 else (
        f" RMS cells show SLAM repetition {table.rep} of {table.n_reps}; rates count all repetitions.")
    conf = round_mm(100 * (1 - table.alpha))
    return ("RMS map errors (rounded to mm); cells whose case detects the fault are marked "
            "(the paper's green cells). Detected %: share of cases detecting the fault, with its "
            f"{conf} % Wilson interval; for the paper the printed figure, and in brackets the rule "
            "applied to the paper's raw data where the two differ. by Suite %: share of fault x run "
            "pairs detected by at least one case." + rep)


def _md_table(frame: pd.DataFrame) -> str:
    header = "| " + " | ".join(frame.columns) + " |"
    sep = "| " + " | ".join("---" for _ in frame.columns) + " |"
    body = ["| " + " | ".join(str(v) for v in row) + " |" for row in frame.itertuples(index=False)]
    return "\n".join([header, sep, *body])


def table2_markdown(table: Table2) -> str:
    """Markdown: one table per block of three evaluation runs; detected cells in bold."""
    parts = ["# Table II: this run beside the paper", "", table2_caption(table), ""]
    for block in _blocks(table):
        if len(_blocks(table)) > 1:
            parts += [f"## Evaluation runs {block[0]}-{block[-1]}", ""]
        parts += [_md_table(table2_frame(table, style="md", runs=block)), ""]
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


def table2_latex(table: Table2) -> str:
    """LaTeX (booktabs): one ``tabular`` per block of three runs; detected cells in bold."""
    out = [
        "% Table II of a faultlab run beside the paper's; needs \\usepackage{booktabs}",
        "\\begin{table*}",
        "\\centering",
        "\\scriptsize",
        "\\setlength{\\tabcolsep}{2.5pt}",
    ]
    for block in _blocks(table):
        frame = table2_frame(table, style="tex", runs=block)
        n_runs = [c for c in frame.columns if c.startswith("R")]
        spec = "lll" + "r" * len(n_runs) + "rrr"
        out.append(f"\\begin{{tabular}}{{{spec}}}")
        out.append("\\toprule")
        header1 = ["", "", ""]
        for run in block:
            n_cases = sum(1 for c in n_runs if c.startswith(f"R{run}C"))
            header1.append(f"\\multicolumn{{{n_cases}}}{{c}}{{Evaluation Run {run}}}")
        header1 += ["", "", ""]
        out.append(" & ".join(header1) + " \\\\")
        header2 = ["Suite", "Algorithm", "Source"] + [c.split("C", 1)[1] for c in n_runs] + [
            "Detected \\%", "95\\% CI", "by Suite \\%"]
        out.append(" & ".join(header2) + " \\\\")
        out.append("\\midrule")
        previous = None
        for row in frame.itertuples(index=False):
            values = list(row)
            if previous is not None and values[0] != previous:
                out.append("\\midrule")
            previous = values[0]
            out.append(" & ".join(_tex_cell(str(v)) for v in values) + " \\\\")
        out.append("\\bottomrule")
        out.append("\\end{tabular}")
        out.append("")
    out.append(f"\\caption{{{tex_escape(table2_caption(table))}}}")
    out.append("\\label{tab:faultlab-table2}")
    out.append("\\end{table*}")
    return "\n".join(out) + "\n"


# --------------------------------------------------------------------------- detection rates


def detection_frame(results: pd.DataFrame, *, rule=None, paper=None,
                    alpha: float = 0.05) -> pd.DataFrame:
    """Detection rate per (suite, fault) as :func:`faultlab.stats.detection_rates` reports it,
    with the paper's computed and printed percentages beside (NaN where the paper has no row)."""
    rule = default_rule() if rule is None else rule
    frame = rates(results, rule=rule, alpha=alpha).copy()
    frame["suite"] = frame["suite"].astype(str)
    frame["variant"] = frame["variant"].astype(str)
    if paper is not None:
        pres = paper_results_frame(paper)
        prates = rates(pres, rule=rule, alpha=alpha)[["suite", "variant", "k", "n", "rate"]]
        prates = prates.rename(columns={"k": "paper_k", "n": "paper_n", "rate": "paper_rate"})
        frame = frame.merge(prates, on=["suite", "variant"], how="left")
        printed = _printed_rates(paper)
        if printed is not None:
            frame = frame.merge(printed.rename(columns={"printed_pct": "paper_printed_pct"}),
                                on=["suite", "variant"], how="left")
    suites, variants = order_suites(frame["suite"]), order_variants(frame["variant"])
    frame["_s"] = frame["suite"].map({s: i for i, s in enumerate(suites)})
    frame["_v"] = frame["variant"].map({v: i for i, v in enumerate(variants)})
    return frame.sort_values(["_s", "_v"]).drop(columns=["_s", "_v"]).reset_index(drop=True)


def detection_records(frame: pd.DataFrame, *, alpha: float = 0.05, compact: bool = False) -> pd.DataFrame:
    """Display rows of :func:`detection_frame`: one per (suite, fault), formatted strings.

    Columns: suite, fault, k/n, rate, Wilson and Clopper-Pearson intervals, the
    crash / timeout / baseline-failed counts, the rate with failures counted as
    detections and the paper's figures where present.  ``compact`` gives the
    short headers of the PDF page.
    """
    conf = round_mm(100 * (1 - alpha))
    cp = "C-P" if compact else "Clopper-Pearson"
    incl = "Rate % incl. failures" if compact else "Rate % (crash, timeout = detected)"
    paper_rule = "Paper % (rule)" if compact else "Paper % (rule on raw data)"
    records = []
    for row in frame.itertuples(index=False):
        r = row._asdict()
        rec = {
            "Suite": suite_label(r["suite"]),
            "Fault": variant_label(r["variant"]),
            "k/n": f"{int(r['k'])}/{int(r['n'])}",
            "Rate %": format_pct(r["rate"], 1),
            f"Wilson {conf} %": f"{format_pct(r['wilson_low'], 1)}-{format_pct(r['wilson_high'], 1)}",
            f"{cp} {conf} %": f"{format_pct(r['cp_low'], 1)}-{format_pct(r['cp_high'], 1)}",
        }
        for extra in ("crash", "timeout", "baseline_failed"):
            if extra in r:
                rec[extra.replace("_", " ")] = str(int(r[extra]))
        if "rate_incl" in r:
            rec[incl] = (format_pct(r["rate_incl"], 1) if compact else
                         f"{format_pct(r['rate_incl'], 1)} ({int(r['k_incl'])}/{int(r['n_incl'])})")
        if "paper_rate" in r:
            rec[paper_rule] = format_pct(r["paper_rate"], 1)
        if "paper_printed_pct" in r:
            p = r["paper_printed_pct"]
            rec["Paper % (printed)"] = "" if pd.isna(p) else str(round_mm(float(p)))
        records.append(rec)
    return pd.DataFrame.from_records(records)


def detection_markdown(frame: pd.DataFrame, *, alpha: float = 0.05) -> str:
    """Markdown of :func:`detection_frame`: k/n, rate, Wilson and Clopper-Pearson intervals."""
    conf = round_mm(100 * (1 - alpha))
    records = detection_records(frame, alpha=alpha)
    body = _md_table(records) if len(records) else "(no faulty variants)"
    return "\n".join(["# Detection rates per suite and fault", "",
                      f"Confidence level {conf} %. k/n counts the faulty jobs detected among those "
                      "where both the faulty and the baseline SLAM produced a map; crashes and "
                      "timeouts of the faulty SLAM are their own outcome classes (counted in their "
                      "columns, and as detections in the last rate); 'baseline failed' jobs judge "
                      "nothing.", "", body, ""])


# --------------------------------------------------------------------------- writing


@dataclass(frozen=True)
class TableFiles:
    """Paths of the written tables."""

    table2_csv: Path
    table2_md: Path
    table2_tex: Path
    detection_csv: Path
    detection_md: Path


def write_tables(table: Table2, detection: pd.DataFrame, reports_dir: str | Path) -> TableFiles:
    """Write table2.csv/.md/.tex and detection_rates.csv/.md into ``reports_dir``."""
    reports_dir = Path(reports_dir)
    reports_dir.mkdir(parents=True, exist_ok=True)
    files = TableFiles(
        table2_csv=reports_dir / "table2.csv",
        table2_md=reports_dir / "table2.md",
        table2_tex=reports_dir / "table2.tex",
        detection_csv=reports_dir / "detection_rates.csv",
        detection_md=reports_dir / "detection_rates.md",
    )
    table2_csv_frame(table).to_csv(files.table2_csv, index=False)
    files.table2_md.write_text(table2_markdown(table), encoding="utf-8")
    files.table2_tex.write_text(table2_latex(table), encoding="utf-8")
    detection.to_csv(files.detection_csv, index=False)
    files.detection_md.write_text(detection_markdown(detection, alpha=table.alpha), encoding="utf-8")
    return files
