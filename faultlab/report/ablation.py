"""The ablation page: each isolated difference from the paper's filter and its effect on map errors.

Renders a :class:`faultlab.analysis.ablation.AblationResult` (nothing is computed here):
``ablation.csv`` and ``ablation.json`` (the table as computed and its settings, written by the
result's :meth:`~faultlab.analysis.bundle.TableBundle.save`), ``ablation.md`` (what ran, the rule, one table per
difference, and a sentence per row the paper-fidelity page quotes) and the same as pages of ``report.pdf``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
from matplotlib.figure import Figure

from faultlab.analysis.ablation import ABLATION_CSV, ABLATION_JSON, AblationResult
from faultlab.report.pdf import table_pages, text_pages
from faultlab.report.tables import format_mm, md_table, variant_label
from faultlab.slam.profiles import ABLATIONS

__all__ = ["AblationFiles", "ablation_markdown", "ablation_pages", "effect_sentence", "write_ablation", "ABLATION_MD"]

ABLATION_MD = "ablation.md"
_TITLE = "Differences from the paper's filter, one at a time"


@dataclass(frozen=True)
class AblationFiles:
    """The files :func:`write_ablation` wrote."""

    csv: Path
    meta: Path
    markdown: Path

    def __str__(self) -> str:
        return f"ablation: {self.csv}, {self.meta}, {self.markdown}"


def _mm1(value: float) -> str:
    """Millimetres with one decimal (sub-mm effects such as rounding stay visible)."""
    return "" if value is None or not math.isfinite(float(value)) else f"{float(value):.1f}"


def _campaign_text(result: AblationResult) -> str:
    c = result.campaign
    shapes: dict[str, list[str]] = {}
    for arm, cases in (c.get("arm_cases") or {}).items():
        shapes.setdefault(", ".join(f"{k} {v}" for k, v in cases.items()), []).append(f"`{arm}`")
    per_suite = "; ".join(f"{' '.join(arms) if len(shapes) > 1 else 'every arm'}: {shape} cases"
                          for shape, arms in shapes.items())
    return (f"Both arms of every row run the same cases with the same SLAM seeds, and a row pairs the cases "
            f"both of its arms ran (column pairs): {c.get('runs')} evaluation run(s) of the paper's protocol "
            f"({per_suite}), {c.get('n_steps')} steps per case, "
            f"{c.get('particles')} particles; variants: {', '.join(variant_label(v) for v in c.get('variants', []))}. "
            f"REDUCED against the paper's three runs: a difference is shown on these cases only.")


def _rule_text(result: AblationResult) -> str:
    conf = round(100 * (1 - result.alpha))
    return (f"Per row and variant: the RMS errors with the paper's choice against those with faultlab's "
            f"alternative, paired by case and seed. diff = paper - alternative (mm): median with a {conf} % "
            f"percentile bootstrap interval over the pairs ({result.n_boot} resamples, seed {result.seed}); "
            f"ratio = median of paper / alternative; larger = pairs in which the paper's choice gave the "
            f"larger error; p = two-sided Wilcoxon signed-rank over the non-zero differences, Holm-adjusted over "
            f"the table. Equal maps (diff = 0) count as no evidence.")


def _display(table: pd.DataFrame) -> pd.DataFrame:
    return pd.DataFrame({
        "variant": [variant_label(v) for v in table["variant"]],
        "pairs": [f"{n}" + (f" ({z} equal)" if z else "") for n, z in zip(table["n"], table["n_zero"])],
        "median mm paper / alt.": [f"{format_mm(a)} / {format_mm(b)}"
                                   for a, b in zip(table["paper_median_mm"], table["alternative_median_mm"])],
        # every pair bit-identical: no interval is estimated from differences that are all exactly 0
        "diff mm [CI]": ["0 (identical in every pair)" if z == n else f"{_mm1(d)} [{_mm1(lo)}, {_mm1(hi)}]"
                         for d, lo, hi, z, n in zip(table["diff_median_mm"], table["diff_low_mm"],
                                                    table["diff_high_mm"], table["n_zero"], table["n"])],
        "ratio": [f"{r:.3g}" for r in table["ratio_median"]],
        "larger": [f"{k} of {n}" for k, n in zip(table["n_larger"], table["n"])],
        "p (Holm)": [f"{p:.2g} ({q:.2g})" for p, q in zip(table["p"], table["p_holm"])],
    })


def effect_sentence(result: AblationResult, point: str) -> str:
    """One sentence on ``point``'s effect (the paper-fidelity page's figure column), or "" if it was not run."""
    t = result.ablation[result.ablation["point"] == point]
    if t.empty:
        return ""
    parts = []
    for r in t.itertuples():
        sig = "" if r.p_holm >= result.alpha else ", significant"
        parts.append(f"{variant_label(r.variant)} {_mm1(r.diff_median_mm)} mm [{_mm1(r.diff_low_mm)}, "
                     f"{_mm1(r.diff_high_mm)}] (p_Holm {r.p_holm:.2g}{sig})")
    return "paired median difference paper - alternative: " + "; ".join(parts)


def _sections(result: AblationResult):
    """(point, change, arms text, rows) per ablation that ran, in the order of ABLATIONS."""
    changes = {a.point: a for a in ABLATIONS}
    for point in dict.fromkeys(result.ablation["point"]):
        rows = result.ablation[result.ablation["point"] == point]
        a = changes.get(point)
        change = a.change if a is not None else ""
        arms = f"`{rows['paper_arm'].iloc[0]}` (paper's choice) against `{rows['alternative_arm'].iloc[0]}`"
        yield point, change, arms, rows


def ablation_markdown(result: AblationResult) -> str:
    """The page as Markdown."""
    parts = ["# " + _TITLE, "", _campaign_text(result), "", _rule_text(result), ""]
    for point, change, arms, rows in _sections(result):
        parts += [f"## {point}", "", f"Alternative: {change}. Arms: {arms}.", "", md_table(_display(rows)), ""]
    return "\n".join(parts).rstrip() + "\n"


def ablation_pages(result: AblationResult) -> list[Figure]:
    """The page(s) of ``report.pdf``: the rule, then one table per row of the differences."""
    frames = []
    for point, change, arms, rows in _sections(result):
        d = _display(rows)
        d.insert(0, "difference", [point] + [""] * (len(d) - 1))
        frames.append(d)
    table = pd.concat(frames, ignore_index=True)
    return (text_pages(_TITLE, [_campaign_text(result), _rule_text(result)]
                       + [f"- {p}: {c} ({a})" for p, c, a, _ in _sections(result)])
            + table_pages(_TITLE + ": effects", table, max_rows=36))


def write_ablation(result: AblationResult, reports_dir: str | Path) -> AblationFiles:
    """Write ``ablation.csv``, ``ablation.json`` and ``ablation.md`` to ``reports_dir`` (created)."""
    d = result.save(reports_dir)
    md = d / ABLATION_MD
    md.write_text(ablation_markdown(result))
    return AblationFiles(csv=d / ABLATION_CSV, meta=d / ABLATION_JSON, markdown=md)
