"""Honest comparison of a run with the paper's Table II (issue 6, item 6).

For every Table II row the report states whether this run agrees with the paper, and when it
does not, says so in words.  The criteria are explicit and conservative:

* **Baseline rows** (Sec. VII-D: "Nonfaulty Baseline").  For the *fixed* suite, whose cases all
  share the default parameters, the paper's baseline errors span a narrow range (computed from
  ``paper_repro/``: 38-101 mm).  This run agrees when every fixed-suite baseline error lies in
  the paper's range widened by ``range_factor`` on both sides (default 2: 19-202 mm).  The
  systematic and random suites vary the parameters on purpose, so their ranges are wide; there
  the run agrees when its range overlaps the paper's range widened the same way.
* **Fault rows** (suite x fault).  This run agrees when (a) the suite detects the fault in at
  least one case exactly when the paper's suite did, and (b) the paper's detection rate (the
  rule applied to the paper's raw RMS data) lies inside this run's 95 % Wilson interval.
* **by Suite** per suite: the paper's share lies inside this run's interval for that share.
* **Claims** of Sec. VII-D: the systematic suite detects every fault in every run; it detects at
  least as many fault-run pairs as the random and the fixed suite; only varied suites detect
  the naive resampling fault.

Intervals come from :mod:`faultlab.stats` through :class:`~faultlab.report.tables.Table2`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum

import numpy as np
import pandas as pd

from faultlab.vocabulary import SUITE_KINDS
from faultlab.report.tables import (
    PAPER,
    THIS_RUN,
    Table2,
    format_pct,
    order_suites,
    order_variants,
    round_mm,
    suite_label,
    variant_label,
)

__all__ = ["Verdict", "Statement", "Comparison", "compare_with_paper"]


class Verdict(StrEnum):
    """Outcome of one comparison with the paper."""

    AGREES = "agrees"
    DISAGREES = "disagrees"
    NOT_COMPARABLE = "not comparable"


@dataclass(frozen=True)
class Statement:
    """One sentence of the comparison.

    Attributes
    ----------
    topic : str
        ``"baseline range"``, ``"detection"``, ``"by suite"`` or ``"claim"``.
    suite, variant : str
        The Table II row ("" where the statement is not about one row).
    verdict : Verdict
    this_run, paper : str
        The compared figures, short (``"35-88 mm"``, ``"27 % (4/15)"``).
    text : str
        The full sentence; it contains the verdict's word.
    """

    topic: str
    suite: str
    variant: str
    verdict: Verdict
    this_run: str
    paper: str
    text: str


@dataclass(frozen=True)
class Comparison:
    """All statements of a comparison, in Table II order, then the by-suite rows and claims."""

    statements: tuple[Statement, ...]
    range_factor: float = 2.0

    def by_verdict(self, verdict: Verdict) -> list[Statement]:
        return [s for s in self.statements if s.verdict == verdict]

    def find(self, suite: str, variant: str, topic: str | None = None) -> Statement:
        """The statement of one Table II row (KeyError if absent)."""
        for s in self.statements:
            if s.suite == suite and s.variant == variant and (topic is None or s.topic == topic):
                return s
        raise KeyError(f"no statement for suite {suite!r}, variant {variant!r}")

    def summary(self) -> str:
        agree = len(self.by_verdict(Verdict.AGREES))
        disagree = len(self.by_verdict(Verdict.DISAGREES))
        na = len(self.by_verdict(Verdict.NOT_COMPARABLE))
        text = f"{agree} of {agree + disagree} comparable statements agree with the paper"
        text += f", {disagree} disagree" if disagree else ""
        text += f" ({na} not comparable)." if na else "."
        return text

    def frame(self) -> pd.DataFrame:
        return pd.DataFrame([{"topic": s.topic, "suite": s.suite, "variant": s.variant,
                              "verdict": str(s.verdict), "this_run": s.this_run, "paper": s.paper,
                              "text": s.text} for s in self.statements])

    def markdown(self) -> str:
        lines = ["# Comparison with the paper (Table II)", "", self.summary(), ""]
        for s in self.statements:
            lines.append(f"- **{s.verdict}** — {s.text}")
        lines.append("")
        return "\n".join(lines)


# --------------------------------------------------------------------------- helpers


def _mm_range(values: np.ndarray) -> str:
    lo, hi = round_mm(values.min()), round_mm(values.max())
    return f"{lo} mm" if lo == hi else f"{lo}-{hi} mm"


def _rate_figure(row: pd.Series) -> str:
    return f"{format_pct(row['rate'])} % ({int(row['k'])}/{int(row['n'])})"


def _ci_figure(low: float, high: float) -> str:
    return f"{format_pct(low)}-{format_pct(high)} %"


def _inside(value: float, low: float, high: float) -> bool:
    # the interval bounds are floats: allow rounding noise at the edge (rate == bound)
    return low - 1e-12 <= value <= high + 1e-12


def _baseline_values(table: Table2, suite: str, source: str) -> np.ndarray:
    c = table.cells
    m = (c["source"] == source) & (c["suite"] == suite) & (c["variant"] == "baseline")
    v = c.loc[m, "rms_mm"].to_numpy(dtype=float)
    return v[np.isfinite(v)]


def _row(frame: pd.DataFrame, **where) -> pd.Series | None:
    m = np.ones(len(frame), dtype=bool)
    for k, v in where.items():
        m &= (frame[k] == v).to_numpy()
    return None if not m.any() else frame[m].iloc[0]


def _baseline_statement(table: Table2, suite: str, factor: float) -> Statement:
    mine = _baseline_values(table, suite, THIS_RUN)
    paper = _baseline_values(table, suite, PAPER)
    label = f"{suite_label(suite)} suite, Nonfaulty Baseline"
    if mine.size == 0 or paper.size == 0:
        missing = "this run has no successful baseline job" if mine.size == 0 else \
            "the paper has no such row"
        return Statement("baseline range", suite, "baseline", Verdict.NOT_COMPARABLE,
                         _mm_range(mine) if mine.size else "-",
                         _mm_range(paper) if paper.size else "-",
                         f"{label}: not comparable ({missing}).")
    lo, hi = paper.min() / factor, paper.max() * factor
    widened = f"{round_mm(lo)}-{round_mm(hi)} mm"
    head = (f"{label}: this run's RMS errors span {_mm_range(mine)}, the paper's "
            f"{_mm_range(paper)}")
    if suite == "fixed":
        outside = mine[(mine < lo) | (mine > hi)]
        if outside.size == 0:
            return Statement("baseline range", suite, "baseline", Verdict.AGREES, _mm_range(mine),
                             _mm_range(paper),
                             f"{head}; agrees (every value lies within the paper's range "
                             f"widened by a factor of {factor:g}, {widened}).")
        worst = outside[np.argmax(np.abs(np.log(outside / np.sqrt(lo * hi))))]
        return Statement("baseline range", suite, "baseline", Verdict.DISAGREES, _mm_range(mine),
                         _mm_range(paper),
                         f"{head}; disagrees: {outside.size} of {mine.size} values lie outside "
                         f"the paper's range widened by a factor of {factor:g} ({widened}), "
                         f"the farthest is {round_mm(worst)} mm.")
    overlap = mine.max() >= lo and mine.min() <= hi
    if overlap:
        return Statement("baseline range", suite, "baseline", Verdict.AGREES, _mm_range(mine),
                         _mm_range(paper),
                         f"{head}; agrees (the ranges overlap once the paper's is widened by a "
                         f"factor of {factor:g} to {widened}).")
    return Statement("baseline range", suite, "baseline", Verdict.DISAGREES, _mm_range(mine),
                     _mm_range(paper),
                     f"{head}; disagrees: the ranges do not overlap even with the paper's "
                     f"widened by a factor of {factor:g} to {widened}.")


def _detection_statement(table: Table2, suite: str, variant: str) -> Statement:
    rates = table.rates
    mine = _row(rates, source=THIS_RUN, suite=suite, variant=variant)
    paper = _row(rates, source=PAPER, suite=suite, variant=variant)
    label = f"{suite_label(suite)} suite, {variant_label(variant)}"
    conf = round_mm(100 * (1 - table.alpha))
    if mine is None or paper is None or int(mine["n"]) == 0:
        why = ("the paper has no such row" if paper is None else
               "this run has no such row" if mine is None else
               "this run has no case where both variants finished")
        return Statement("detection", suite, variant, Verdict.NOT_COMPARABLE,
                         "-" if mine is None else _rate_figure(mine),
                         "-" if paper is None else _rate_figure(paper),
                         f"{label}: not comparable ({why}).")
    printed = paper.get("printed_pct", np.nan)
    paper_fig = _rate_figure(paper)
    if printed is not None and not pd.isna(printed) and \
            round_mm(float(printed)) != round_mm(100 * float(paper["rate"])):
        paper_fig += f", printed {round_mm(float(printed))} %"
    head = (f"{label}: this run detects the fault in {_rate_figure(mine)} of cases "
            f"({conf} % CI {_ci_figure(mine['ci_low'], mine['ci_high'])}), the paper in {paper_fig}")
    reasons = []
    if (int(mine["k"]) > 0) != (int(paper["k"]) > 0):
        reasons.append("the paper's suite never detected this fault but this run's does"
                       if int(paper["k"]) == 0 else
                       "the paper's suite detected this fault but this run's never does")
    if not _inside(float(paper["rate"]), float(mine["ci_low"]), float(mine["ci_high"])):
        reasons.append(f"the paper's rate {format_pct(paper['rate'])} % lies outside this run's "
                       f"{conf} % interval")
    if reasons:
        return Statement("detection", suite, variant, Verdict.DISAGREES, _rate_figure(mine),
                         paper_fig, f"{head}; disagrees: {' and '.join(reasons)}.")
    return Statement("detection", suite, variant, Verdict.AGREES, _rate_figure(mine), paper_fig,
                     f"{head}; agrees (both {'detect' if int(paper['k']) else 'miss'} it, and the "
                     f"paper's rate lies inside this run's {conf} % interval).")


def _suite_interval(row: pd.Series) -> tuple[float, float] | None:
    for low, high in (("ci_low", "ci_high"), ("wilson_low", "wilson_high")):
        if low in row and not pd.isna(row[low]):
            return float(row[low]), float(row[high])
    return None


def _by_suite_statement(table: Table2, suite: str) -> Statement:
    mine = _row(table.by_suite, source=THIS_RUN, suite=suite)
    paper = _row(table.by_suite, source=PAPER, suite=suite)
    label = f"{suite_label(suite)} suite, by Suite"
    if mine is None or paper is None or int(mine["n"]) == 0:
        return Statement("by suite", suite, "", Verdict.NOT_COMPARABLE,
                         "-" if mine is None else _rate_figure(mine),
                         "-" if paper is None else _rate_figure(paper),
                         f"{label}: not comparable (no {'paper' if paper is None else 'run'} figure).")
    head = (f"{label}: this run detects {_rate_figure(mine)} of fault x run pairs, the paper "
            f"{_rate_figure(paper)}")
    ci = _suite_interval(mine)
    if ci is None:
        same = int(mine["k"]) * int(paper["n"]) == int(paper["k"]) * int(mine["n"])
        verdict = Verdict.AGREES if same else Verdict.DISAGREES
        return Statement("by suite", suite, "", verdict, _rate_figure(mine), _rate_figure(paper),
                         f"{head}; {verdict} (no interval available: compared exactly).")
    conf = round_mm(100 * (1 - table.alpha))
    if _inside(float(paper["rate"]), *ci):
        return Statement("by suite", suite, "", Verdict.AGREES, _rate_figure(mine),
                         _rate_figure(paper),
                         f"{head}; agrees (the paper's share lies inside this run's {conf} % "
                         f"interval {_ci_figure(*ci)}).")
    return Statement("by suite", suite, "", Verdict.DISAGREES, _rate_figure(mine),
                     _rate_figure(paper),
                     f"{head}; disagrees: the paper's share lies outside this run's {conf} % "
                     f"interval {_ci_figure(*ci)}.")


def _claims(table: Table2) -> list[Statement]:
    out: list[Statement] = []
    b = table.by_suite
    shares = {s: _row(b, source=THIS_RUN, suite=s) for s in SUITE_KINDS}
    paper_shares = {s: _row(b, source=PAPER, suite=s) for s in SUITE_KINDS}
    sys_row = shares["systematic"]
    if sys_row is not None and int(sys_row["n"]) > 0 and paper_shares["systematic"] is not None:
        complete = int(sys_row["k"]) == int(sys_row["n"])
        paper_complete = int(paper_shares["systematic"]["k"]) == int(paper_shares["systematic"]["n"])
        verdict = Verdict.AGREES if complete == paper_complete else Verdict.DISAGREES
        what = "detects every fault in every run" if complete else \
            f"misses {int(sys_row['n']) - int(sys_row['k'])} of {int(sys_row['n'])} fault x run pairs"
        out.append(Statement(
            "claim", "systematic", "", verdict, _rate_figure(sys_row),
            _rate_figure(paper_shares["systematic"]),
            f"Claim 'the systematic suite detects every fault in every run' "
            f"({'true' if paper_complete else 'false'} for the paper's data): this run's systematic "
            f"suite {what}; {verdict}."))
    for other in ("random", "fixed"):
        o, po, ps = shares[other], paper_shares[other], paper_shares["systematic"]
        if sys_row is None or o is None or po is None or ps is None or \
                int(sys_row["n"]) == 0 or int(o["n"]) == 0:
            continue
        holds = float(sys_row["rate"]) >= float(o["rate"])
        paper_holds = float(ps["rate"]) >= float(po["rate"])
        verdict = Verdict.AGREES if holds == paper_holds else Verdict.DISAGREES
        out.append(Statement(
            "claim", f"systematic vs {other}", "", verdict,
            f"{format_pct(sys_row['rate'])} % vs {format_pct(o['rate'])} %",
            f"{format_pct(ps['rate'])} % vs {format_pct(po['rate'])} %",
            f"Claim 'the systematic suite detects at least as many fault x run pairs as the "
            f"{other} suite' ({'true' if paper_holds else 'false'} for the paper's data, "
            f"{format_pct(ps['rate'])} % vs {format_pct(po['rate'])} %): this run "
            f"{format_pct(sys_row['rate'])} % vs {format_pct(o['rate'])} %; {verdict}."))
    r = table.rates
    fixed_nr = _row(r, source=THIS_RUN, suite="fixed", variant="naive_resampling")
    varied = [_row(r, source=THIS_RUN, suite=s, variant="naive_resampling")
              for s in ("systematic", "random")]
    p_fixed = _row(r, source=PAPER, suite="fixed", variant="naive_resampling")
    p_varied = [_row(r, source=PAPER, suite=s, variant="naive_resampling")
                for s in ("systematic", "random")]
    if fixed_nr is not None and all(v is not None for v in varied + p_varied) and p_fixed is not None:
        holds = int(fixed_nr["k"]) == 0 and any(int(v["k"]) > 0 for v in varied)
        paper_holds = int(p_fixed["k"]) == 0 and any(int(v["k"]) > 0 for v in p_varied)
        verdict = Verdict.AGREES if holds == paper_holds else Verdict.DISAGREES
        mine_txt = (f"fixed {int(fixed_nr['k'])}, systematic {int(varied[0]['k'])}, "
                    f"random {int(varied[1]['k'])} detecting cases")
        paper_txt = (f"fixed {int(p_fixed['k'])}, systematic {int(p_varied[0]['k'])}, "
                     f"random {int(p_varied[1]['k'])} detecting cases")
        out.append(Statement(
            "claim", "all", "naive_resampling", verdict, mine_txt, paper_txt,
            f"Claim 'only suites with varied parameters detect the naive resampling fault' "
            f"({'true' if paper_holds else 'false'} for the paper's data: {paper_txt}): this run "
            f"{mine_txt}; {verdict}."))
    return out


def compare_with_paper(table: Table2, *, range_factor: float = 2.0) -> Comparison:
    """Compare this run's Table II with the paper's, row by row (see the module docstring).

    Parameters
    ----------
    table : Table2
        Built with ``paper=`` (:func:`faultlab.report.tables.table2`).
    range_factor : float
        Factor (> 1) by which the paper's baseline error range is widened on both sides.
    """
    if not range_factor >= 1.0 or not math.isfinite(range_factor):
        raise ValueError(f"range_factor must be a finite number >= 1, got {range_factor!r}")
    if PAPER not in table.sources:
        return Comparison((Statement("claim", "", "", Verdict.NOT_COMPARABLE, "", "",
                                     "No paper data was given: nothing to compare with."),),
                          range_factor)
    statements: list[Statement] = []
    for suite in order_suites(table.cells["suite"]):
        for variant in order_variants(table.cells["variant"]):
            if variant == "baseline":
                statements.append(_baseline_statement(table, suite, range_factor))
            else:
                statements.append(_detection_statement(table, suite, variant))
    for suite in order_suites(table.by_suite["suite"]):
        statements.append(_by_suite_statement(table, suite))
    statements.extend(_claims(table))
    return Comparison(tuple(statements), range_factor)
