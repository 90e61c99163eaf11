"""The HTML report of a ``faultlab compare``: the verdict, every case in one sortable, filterable table,
and the Markdown summary as written to ``compare.md``."""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd

from faultlab.analysis.compare import CompareResult
from faultlab.inference.equivalence import percent
from faultlab.report.compare import compare_markdown
from faultlab.report.html.site import Code, Page, Site, Table, Text, write_site

__all__ = ["compare_pages", "write_compare_html"]


def _cases_frame(result: CompareResult) -> pd.DataFrame:
    """One row per case: both versions' errors (mm), the effect and its interval (%), the verdict."""
    def pct(x):
        return percent(x) if x is not None and math.isfinite(x) else math.nan

    rows = []
    for c in result.cases:
        comp = c.comparison
        rows.append({"case": c.case_id, "verdict": c.verdict, "baseline_mm": c.baseline_mm,
                     "candidate_mm": c.candidate_mm, "effect_pct": pct(comp.effect) if comp else math.nan,
                     "ci_low_pct": pct(comp.ci_low) if comp else math.nan,
                     "ci_high_pct": pct(comp.ci_high) if comp else math.nan,
                     "failed_runs": f"{c.baseline_failed} of {c.runs[0]} / {c.candidate_failed} of {c.runs[1]}",
                     "reason": c.reason, **{str(k): str(v) for k, v in c.values.items()}})
    return pd.DataFrame(rows, columns=None if rows else ["case", "verdict"])


def compare_pages(result: CompareResult) -> list[Page]:
    """The overview: the verdict, the table of cases, the Markdown summary."""
    p = result.pooled
    headline = ("REGRESSION" if result.regression else p.verdict) + (
        f": the candidate changes the map error by {percent(p.effect):+.1f} %" if math.isfinite(p.effect) else "")
    if math.isfinite(p.ci_low):
        headline += f" ({100 * (1 - 2 * result.alpha):g} % interval {percent(p.ci_low):+.1f} % to {percent(p.ci_high):+.1f} %)"
    sections = (Text("Verdict", (headline + ".", p.test + ".")),
                Table("Cases", _cases_frame(result), key="cases",
                      caption="Per case: each version's geometric-mean map error over its finished runs (mm), the "
                              "effect and its interval (%; empty where judged exactly), the verdict (each at level "
                              "alpha, not adjusted for their number: they show where, the pooled verdict decides); "
                              "the remaining columns are the case's parameters."),
                Code("The summary, as written to compare.md", compare_markdown(result)))
    return [Page("index.html", "Overview", sections)]


def write_compare_html(result: CompareResult, out: str | Path) -> Site:
    """Write the comparison's site into ``out`` (created)."""
    return write_site(Path(out), compare_pages(result), title=f"faultlab compare: {result.candidate} vs "
                                                              f"{result.baseline}", nav=(("Overview", "index.html"),))
