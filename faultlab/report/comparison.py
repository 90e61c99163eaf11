"""Honest comparison of a run with the paper's Table II, row by row, in words.

For every Table II row the report states whether this run agrees with the paper, and when it
does not, says so in words.  The criteria are explicit and conservative:

* **Baseline rows** (Sec. VII-D: "Nonfaulty Baseline").  For the *fixed* suite, whose cases all
  share the default parameters, the paper's baseline errors span a narrow range (computed from
  ``paper_repro/``: 38-101 mm).  This run agrees when every fixed-suite baseline error lies in
  the paper's range widened by ``range_factor`` on both sides (default 2: 19-202 mm).  The
  systematic and random suites vary the parameters on purpose, so their ranges are wide; there
  the run agrees when its range overlaps the paper's range widened the same way.
* **Fault rows** (suite x fault).  A two-sample exact test of counts
  (:func:`faultlab.stats.cases.compare_with_paper`, the Analysis table ``paper_comparisons``):
  the paper's printed count k/15 against this run's detected / judged cases, Boschloo's exact
  test; *disagrees* when p < alpha, *agrees* when it does not differ and the smallest difference
  detectable with the default power (:data:`~faultlab.vocabulary.DEFAULT_POWER`) is below the stated margin, else *inconclusive* (too few cases for
  "no difference" to mean anything).  Rows without a printed figure fall back to the paper's
  rate from its raw data lying inside this run's Wilson interval.
* **by Suite** per suite: the paper's share lies inside this run's interval for that share.
* **Claims** of Sec. VII-D: the systematic suite detects every fault in every run; it detects at
  least as many fault-run pairs as the random and the fixed suite; only varied suites detect
  the naive resampling fault.

Every figure and interval comes from an :class:`~faultlab.analysis.Analysis`; this module only
judges them against the criteria above and words the result.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum
from typing import NamedTuple

import numpy as np
import pandas as pd

from faultlab.analysis import Analysis
from faultlab.analysis.schema import PAPER, THIS_RUN
from faultlab.report.tables import (
    format_pct,
    format_pct_interval,
    order_suites,
    order_variants,
    round_mm,
    suite_label,
    variant_label,
)
from faultlab.vocabulary import BASELINE, POWER_TEXT

__all__ = ["Verdict", "Statement", "Comparison", "compare_with_paper"]


class Verdict(StrEnum):
    """Outcome of one comparison with the paper."""

    AGREES = "agrees"
    DISAGREES = "disagrees"
    INCONCLUSIVE = "inconclusive"
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
        unsure = len(self.by_verdict(Verdict.INCONCLUSIVE))
        text = f"{agree} of {agree + disagree + unsure} comparable statements agree with the paper"
        text += f", {disagree} disagree" if disagree else ""
        text += f", {unsure} inconclusive (too few cases to tell)" if unsure else ""
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


# --------------------------------------------------------------------------- figures


class _Figure(NamedTuple):
    """A detection count out of n with its rate, Wilson interval and the paper's printed percent."""

    k: int
    n: int
    rate: float
    low: float = math.nan
    high: float = math.nan
    printed: float = math.nan


def _first(frame: pd.DataFrame, **where):
    m = np.ones(len(frame), dtype=bool)
    for k, v in where.items():
        m &= (frame[k] == v).to_numpy()
    return None if not m.any() else next(frame[m].itertuples(index=False))


def _rate(analysis: Analysis, source: str, suite: str, variant: str) -> _Figure | None:
    """The "Detected Faults" figure of one Table II row of this run or of the paper."""
    if source == THIS_RUN:
        r = _first(analysis.detection_rates, suite=suite, variant=variant)
        return None if r is None else _Figure(int(r.k), int(r.n), r.rate, r.wilson_low, r.wilson_high)
    r = _first(analysis.paper_rates, suite=suite, fault=variant)
    return None if r is None else _Figure(int(r.detected), int(r.n), r.rate, r.wilson_low, r.wilson_high,
                                          r.reported_pct)


def _by_suite(analysis: Analysis, source: str, suite: str) -> _Figure | None:
    """The "by Suite" figure of one suite of this run or of the paper."""
    frame = analysis.by_suite if source == THIS_RUN else analysis.paper_by_suite
    r = _first(frame, suite=suite)
    if r is None:
        return None
    printed = math.nan if source == THIS_RUN else r.reported_pct
    return _Figure(int(r.detected_pairs), int(r.n_pairs), r.rate, r.wilson_low, r.wilson_high, printed)


def _mm_range(values: np.ndarray) -> str:
    lo, hi = round_mm(values.min()), round_mm(values.max())
    return f"{lo} mm" if lo == hi else f"{lo}-{hi} mm"


def _rate_figure(fig: _Figure) -> str:
    return f"{format_pct(fig.rate)} % ({fig.k}/{fig.n})"


def _ci_figure(low: float, high: float) -> str:
    return f"{format_pct_interval(low, high)} %"


def _inside(value: float, low: float, high: float) -> bool:
    # the interval bounds are floats: allow rounding noise at the edge (rate == bound)
    return low - 1e-12 <= value <= high + 1e-12


def _baseline_values(analysis: Analysis, suite: str, source: str) -> np.ndarray:
    c = analysis.table2_cells
    m = (c["source"] == source) & (c["suite"] == suite) & (c["variant"] == BASELINE)
    v = c.loc[m, "rms_mm"].to_numpy(dtype=float)
    return v[np.isfinite(v)]


def _conf(analysis: Analysis) -> int:
    return round_mm(100 * (1 - analysis.alpha))


# --------------------------------------------------------------------------- statements


def _baseline_statement(analysis: Analysis, suite: str, factor: float) -> Statement:
    mine = _baseline_values(analysis, suite, THIS_RUN)
    paper = _baseline_values(analysis, suite, PAPER)
    label = f"{suite_label(suite)} suite, Nonfaulty Baseline"
    if mine.size == 0 or paper.size == 0:
        missing = "this run has no successful baseline job" if mine.size == 0 else \
            "the paper has no such row"
        return Statement("baseline range", suite, BASELINE, Verdict.NOT_COMPARABLE,
                         _mm_range(mine) if mine.size else "-",
                         _mm_range(paper) if paper.size else "-",
                         f"{label}: not comparable ({missing}).")
    lo, hi = paper.min() / factor, paper.max() * factor
    widened = f"{round_mm(lo)}-{round_mm(hi)} mm"
    head = (f"{label}: this run's RMS errors span {_mm_range(mine)}, the paper's "
            f"{_mm_range(paper)}")
    figures = (_mm_range(mine), _mm_range(paper))
    if suite == "fixed":
        outside = mine[(mine < lo) | (mine > hi)]
        if outside.size == 0:
            return Statement("baseline range", suite, BASELINE, Verdict.AGREES, *figures,
                             f"{head}; agrees (every value lies within the paper's range "
                             f"widened by a factor of {factor:g}, {widened}).")
        worst = outside[np.argmax(np.abs(np.log(outside / np.sqrt(lo * hi))))]
        return Statement("baseline range", suite, BASELINE, Verdict.DISAGREES, *figures,
                         f"{head}; disagrees: {outside.size} of {mine.size} values lie outside "
                         f"the paper's range widened by a factor of {factor:g} ({widened}), "
                         f"the farthest is {round_mm(worst)} mm.")
    if mine.max() >= lo and mine.min() <= hi:
        return Statement("baseline range", suite, BASELINE, Verdict.AGREES, *figures,
                         f"{head}; agrees (the ranges overlap once the paper's is widened by a "
                         f"factor of {factor:g} to {widened}).")
    return Statement("baseline range", suite, BASELINE, Verdict.DISAGREES, *figures,
                     f"{head}; disagrees: the ranges do not overlap even with the paper's "
                     f"widened by a factor of {factor:g} to {widened}.")


_TWO_SAMPLE = {"agrees": Verdict.AGREES, "differs": Verdict.DISAGREES, "inconclusive": Verdict.INCONCLUSIVE}


def _two_sample_statement(analysis: Analysis, suite: str, variant: str) -> Statement | None:
    rows = analysis.paper_comparisons
    rows = rows[(rows["suite"] == suite) & (rows["fault"] == variant)]
    if rows.empty:
        return None
    r = rows.iloc[0]
    label = f"{suite_label(suite)} suite, {variant_label(variant)}"
    mine = f"{format_pct(r['rate'])} % ({r['k']}/{r['n']} cases)"
    paper = f"{format_pct(r['paper_rate'])} % ({r['paper_k']}/{r['paper_n']}, printed)"
    verdict = _TWO_SAMPLE[r["verdict"]]
    why = {"differs": f"p = {r['p']:.3g} < alpha = {analysis.alpha:g}",
           "agrees": f"p = {r['p']:.3g} and a difference of {format_pct(r['detectable_difference'])} percentage "
                     f"points would have been detected with {POWER_TEXT} power",
           "inconclusive": f"p = {r['p']:.3g}, but only a difference of {format_pct(r['detectable_difference'])} "
                           f"percentage points or more would have been detected with {POWER_TEXT} power"}[r["verdict"]]
    return Statement("detection", suite, variant, verdict, mine, paper,
                     f"{label}: this run detects the fault in {mine}, the paper in {paper}; {verdict} "
                     f"(Boschloo's exact two-sample test, {analysis.rule.rule} rule over cases: {why}).")


def _detection_statement(analysis: Analysis, suite: str, variant: str) -> Statement:
    two_sample = _two_sample_statement(analysis, suite, variant)
    if two_sample is not None:
        return two_sample
    mine = _rate(analysis, THIS_RUN, suite, variant)
    paper = _rate(analysis, PAPER, suite, variant)
    label = f"{suite_label(suite)} suite, {variant_label(variant)}"
    conf = _conf(analysis)
    if mine is None or paper is None or mine.n == 0:
        why = ("the paper has no such row" if paper is None else
               "this run has no such row" if mine is None else
               "this run has no case where both variants finished")
        return Statement("detection", suite, variant, Verdict.NOT_COMPARABLE,
                         "-" if mine is None else _rate_figure(mine),
                         "-" if paper is None else _rate_figure(paper),
                         f"{label}: not comparable ({why}).")
    paper_fig = _rate_figure(paper)
    if not pd.isna(paper.printed) and round_mm(float(paper.printed)) != round_mm(100 * float(paper.rate)):
        paper_fig += f", printed {round_mm(float(paper.printed))} %"
    head = (f"{label}: this run detects the fault in {_rate_figure(mine)} of cases "
            f"({conf} % CI {_ci_figure(mine.low, mine.high)}), the paper in {paper_fig}")
    reasons = []
    if (mine.k > 0) != (paper.k > 0):
        reasons.append("the paper's suite never detected this fault but this run's does"
                       if paper.k == 0 else
                       "the paper's suite detected this fault but this run's never does")
    if not _inside(float(paper.rate), float(mine.low), float(mine.high)):
        reasons.append(f"the paper's rate {format_pct(paper.rate)} % lies outside this run's "
                       f"{conf} % interval")
    if reasons:
        return Statement("detection", suite, variant, Verdict.DISAGREES, _rate_figure(mine),
                         paper_fig, f"{head}; disagrees: {' and '.join(reasons)}.")
    return Statement("detection", suite, variant, Verdict.AGREES, _rate_figure(mine), paper_fig,
                     f"{head}; agrees (both {'detect' if paper.k else 'miss'} it, and the "
                     f"paper's rate lies inside this run's {conf} % interval).")


def _by_suite_statement(analysis: Analysis, suite: str) -> Statement:
    mine = _by_suite(analysis, THIS_RUN, suite)
    paper = _by_suite(analysis, PAPER, suite)
    label = f"{suite_label(suite)} suite, by Suite"
    if mine is None or paper is None or mine.n == 0:
        return Statement("by suite", suite, "", Verdict.NOT_COMPARABLE,
                         "-" if mine is None else _rate_figure(mine),
                         "-" if paper is None else _rate_figure(paper),
                         f"{label}: not comparable (no {'paper' if paper is None else 'run'} figure).")
    head = (f"{label}: this run detects {_rate_figure(mine)} of fault x run pairs, the paper "
            f"{_rate_figure(paper)}")
    figures = (_rate_figure(mine), _rate_figure(paper))
    if pd.isna(mine.low):
        same = mine.k * paper.n == paper.k * mine.n
        verdict = Verdict.AGREES if same else Verdict.DISAGREES
        return Statement("by suite", suite, "", verdict, *figures,
                         f"{head}; {verdict} (no interval available: compared exactly).")
    conf = _conf(analysis)
    if _inside(float(paper.rate), float(mine.low), float(mine.high)):
        return Statement("by suite", suite, "", Verdict.AGREES, *figures,
                         f"{head}; agrees (the paper's share lies inside this run's {conf} % "
                         f"interval {_ci_figure(mine.low, mine.high)}).")
    return Statement("by suite", suite, "", Verdict.DISAGREES, *figures,
                     f"{head}; disagrees: the paper's share lies outside this run's {conf} % "
                     f"interval {_ci_figure(mine.low, mine.high)}.")


def _systematic_claim(analysis: Analysis) -> list[Statement]:
    """Sec. VII-D: the systematic suite detects every fault in every run."""
    mine, paper = _by_suite(analysis, THIS_RUN, "systematic"), _by_suite(analysis, PAPER, "systematic")
    if mine is None or mine.n == 0 or paper is None:
        return []
    complete, paper_complete = mine.k == mine.n, paper.k == paper.n
    verdict = Verdict.AGREES if complete == paper_complete else Verdict.DISAGREES
    what = "detects every fault in every run" if complete else \
        f"misses {mine.n - mine.k} of {mine.n} fault x run pairs"
    return [Statement(
        "claim", "systematic", "", verdict, _rate_figure(mine), _rate_figure(paper),
        f"Claim 'the systematic suite detects every fault in every run' "
        f"({'true' if paper_complete else 'false'} for the paper's data): this run's systematic "
        f"suite {what}; {verdict}.")]


def _at_least_as_many_claims(analysis: Analysis) -> list[Statement]:
    """Sec. VII-D: the systematic suite detects at least as many fault x run pairs as the others."""
    out = []
    sys_row, ps = _by_suite(analysis, THIS_RUN, "systematic"), _by_suite(analysis, PAPER, "systematic")
    for other in ("random", "fixed"):
        o, po = _by_suite(analysis, THIS_RUN, other), _by_suite(analysis, PAPER, other)
        if sys_row is None or o is None or po is None or ps is None or sys_row.n == 0 or o.n == 0:
            continue
        holds = float(sys_row.rate) >= float(o.rate)
        paper_holds = float(ps.rate) >= float(po.rate)
        verdict = Verdict.AGREES if holds == paper_holds else Verdict.DISAGREES
        mine_txt = f"{format_pct(sys_row.rate)} % vs {format_pct(o.rate)} %"
        paper_txt = f"{format_pct(ps.rate)} % vs {format_pct(po.rate)} %"
        out.append(Statement(
            "claim", f"systematic vs {other}", "", verdict, mine_txt, paper_txt,
            f"Claim 'the systematic suite detects at least as many fault x run pairs as the "
            f"{other} suite' ({'true' if paper_holds else 'false'} for the paper's data, "
            f"{paper_txt}): this run {mine_txt}; {verdict}."))
    return out


def _varied_suites_claim(analysis: Analysis) -> list[Statement]:
    """Sec. VII-D: only suites with varied parameters detect the naive resampling fault."""
    fault = "naive_resampling"
    mine = {s: _rate(analysis, THIS_RUN, s, fault) for s in ("fixed", "systematic", "random")}
    paper = {s: _rate(analysis, PAPER, s, fault) for s in ("fixed", "systematic", "random")}
    if any(v is None for v in (*mine.values(), *paper.values())):
        return []
    holds = mine["fixed"].k == 0 and (mine["systematic"].k > 0 or mine["random"].k > 0)
    paper_holds = paper["fixed"].k == 0 and (paper["systematic"].k > 0 or paper["random"].k > 0)
    verdict = Verdict.AGREES if holds == paper_holds else Verdict.DISAGREES
    mine_txt = (f"fixed {mine['fixed'].k}, systematic {mine['systematic'].k}, "
                f"random {mine['random'].k} detecting cases")
    paper_txt = (f"fixed {paper['fixed'].k}, systematic {paper['systematic'].k}, "
                 f"random {paper['random'].k} detecting cases")
    return [Statement(
        "claim", "all", fault, verdict, mine_txt, paper_txt,
        f"Claim 'only suites with varied parameters detect the naive resampling fault' "
        f"({'true' if paper_holds else 'false'} for the paper's data: {paper_txt}): this run "
        f"{mine_txt}; {verdict}.")]


def compare_with_paper(analysis: Analysis, *, range_factor: float = 2.0) -> Comparison:
    """Compare this run's Table II with the paper's, row by row (see the module docstring).

    Parameters
    ----------
    analysis : Analysis
        Computed with the paper's data (``paper=True``); otherwise nothing is comparable.
    range_factor : float
        Factor (> 1) by which the paper's baseline error range is widened on both sides.
    """
    if not range_factor >= 1.0 or not math.isfinite(range_factor):
        raise ValueError(f"range_factor must be a finite number >= 1, got {range_factor!r}")
    if not analysis.has_paper:
        return Comparison((Statement("claim", "", "", Verdict.NOT_COMPARABLE, "", "",
                                     "No paper data was given: nothing to compare with."),),
                          range_factor)
    cells = analysis.table2_cells
    statements: list[Statement] = []
    for suite in order_suites(cells["suite"]):
        for variant in order_variants(cells["variant"]):
            if variant == BASELINE:
                statements.append(_baseline_statement(analysis, suite, range_factor))
            else:
                statements.append(_detection_statement(analysis, suite, variant))
    for suite in order_suites(pd.concat([analysis.by_suite["suite"], analysis.paper_by_suite["suite"]])):
        statements.append(_by_suite_statement(analysis, suite))
    statements += _systematic_claim(analysis) + _at_least_as_many_claims(analysis) + _varied_suites_claim(analysis)
    return Comparison(tuple(statements), range_factor)
