"""The fidelity page: this run's RMS distributions against the paper's raw data, per suite and variant.

Renders a :class:`faultlab.analysis.fidelity.Fidelity` (nothing is computed here): ``fidelity.csv``
(the table as computed) and ``fidelity.md`` (what ran, the rule, the table in mm, and in words which
figures are reproduced, which differ and where the faulty-rotation errors lie against the paper's).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from faultlab.analysis.fidelity import FIDELITY, FIDELITY_CSV, Fidelity, Verdict
from faultlab.report.tables import format_mm, md_table, suite_label, variant_label

__all__ = ["FidelityFiles", "fidelity_markdown", "write_fidelity", "FIDELITY_MD"]

FIDELITY_MD = "fidelity.md"
#: The fault whose magnitude the paper profile exists to compare (Table II's "faulty rotation").
_ROTATION = "missing_angle_wrap"


@dataclass(frozen=True)
class FidelityFiles:
    """The files :func:`write_fidelity` wrote."""

    csv: Path
    markdown: Path

    def __str__(self) -> str:
        return f"fidelity: {self.csv}, {self.markdown}"


def _ratio_text(row) -> str:
    return f"{row.ratio:.2f} [{row.ratio_low:.2f}, {row.ratio_high:.2f}]"


def _p_text(p: float) -> str:
    return f"{p:.2g}"


def _campaign_text(fid: Fidelity) -> list[str]:
    c = fid.campaign
    what = (f"SLAM `{c.get('slam')}`" + (f", profile `{c['profile']}`" if c.get("profile") else "")
            + f", fov_bug = {str(bool(c.get('fov_bug'))).lower()}, {c.get('runs')} run(s), "
              f"{c.get('n_steps')} steps per case, {c.get('particles')} particles")
    lines = [f"This run: {what}."]
    if c.get("reduced"):
        lines += ["", "**REDUCED configuration**: fewer steps, particles or runs than the paper's protocol "
                      "(1000 steps, 200 particles, 3 runs). Map errors grow with the length of a trace, so "
                      "sizes are compared with the paper's full-length runs only as an indication."]
    return lines


def _rule_text(fid: Fidelity) -> str:
    conf = round(100 * (1 - fid.alpha))
    return (f"Per suite and variant, this run's RMS errors against the paper's raw ones (`paper_repro/`): "
            f"two-sided Mann-Whitney U, p-values Holm-adjusted over the table; the ratio of medians (this run "
            f"/ paper) with a {conf} % percentile bootstrap interval ({fid.n_boot} resamples, seed "
            f"{fid.seed}). Verdict: **differs** when the adjusted p < {fid.alpha:g}; **reproduced** when it "
            f"does not differ, each side has at least {fid.min_n} values and the ratio's interval lies within "
            f"[1/{fid.factor:g}, {fid.factor:g}]; **inconclusive** otherwise. \"paper median in CI\": the "
            f"paper's median lies within the {conf} % interval of this run's median.")


def _display(fid: Fidelity) -> pd.DataFrame:
    t = fid.table
    return pd.DataFrame({
        "suite": [suite_label(s) for s in t["suite"]],
        "variant": [variant_label(v) for v in t["variant"]],
        "n / paper": [f"{a} / {b}" for a, b in zip(t["n"], t["paper_n"])],
        "range mm": [f"{format_mm(a)}-{format_mm(b)}" for a, b in zip(t["min_mm"], t["max_mm"])],
        "paper range mm": [f"{format_mm(a)}-{format_mm(b)}" for a, b in zip(t["paper_min_mm"], t["paper_max_mm"])],
        "median mm [CI]": [f"{format_mm(m)} [{format_mm(lo)}, {format_mm(hi)}]"
                           for m, lo, hi in zip(t["median_mm"], t["median_low_mm"], t["median_high_mm"])],
        "paper median mm": [format_mm(m) for m in t["paper_median_mm"]],
        "paper median in CI": ["yes" if b else "no" for b in t["paper_median_in_ci"]],
        "ratio [CI]": [_ratio_text(r) for r in t.itertuples()],
        "p (Holm)": [f"{_p_text(p)} ({_p_text(q)})" for p, q in zip(t["p"], t["p_holm"])],
        "verdict": list(t["verdict"]),
    })


def _cells(frame: pd.DataFrame) -> str:
    if frame.empty:
        return "none"
    return "; ".join(f"{suite_label(r.suite)} / {variant_label(r.variant)}" for r in frame.itertuples())


def _rotation_text(fid: Fidelity) -> list[str]:
    t = fid.table[fid.table["variant"] == _ROTATION]
    if t.empty:
        return []
    lo, hi = float(t["min_mm"].min()), float(t["max_mm"].max())
    plo, phi = float(t["paper_min_mm"].min()), float(t["paper_max_mm"].max())
    if plo <= lo and hi <= phi:
        relation = "within the paper's range."
    elif lo <= phi and plo <= hi:
        relation = (f"the ranges overlap (this run's extremes are {lo / plo:.2f} and {hi / phi:.2f} times the "
                    f"paper's).")
        if 0.5 <= lo / plo <= 2 and 0.5 <= hi / phi <= 2:
            relation = "the same range within a factor of 2 at both ends; " + relation
    else:
        relation = "the ranges do not overlap."
    return ["## Faulty rotation (`missing_angle_wrap`)", "",
            f"Over all suites this run's errors span {format_mm(lo)}-{format_mm(hi)} mm, the paper's "
            f"{format_mm(plo)}-{format_mm(phi)} mm: " + relation
            + " Per suite: " + "; ".join(
                f"{suite_label(r.suite)} {format_mm(r.min_mm)}-{format_mm(r.max_mm)} mm (paper "
                f"{format_mm(r.paper_min_mm)}-{format_mm(r.paper_max_mm)} mm, {r.verdict})"
                for r in t.itertuples()) + ".", ""]


def fidelity_markdown(fid: Fidelity) -> str:
    """The page as Markdown."""
    reproduced = fid.cells(Verdict.REPRODUCED)
    differs = fid.cells(Verdict.DIFFERS)
    in_ci = fid.table[fid.table["paper_median_in_ci"]]
    parts = ["# Map errors against the paper's raw data", "", *_campaign_text(fid), "", _rule_text(fid), "",
             md_table(_display(fid)), "",
             f"Reproduced ({len(reproduced)} of {len(fid.table)}): {_cells(reproduced)}.", "",
             f"Differs ({len(differs)}): {_cells(differs)}.", "",
             f"The paper's median lies within this run's interval ({len(in_ci)} of {len(fid.table)}): "
             f"{_cells(in_ci)}.", "", *_rotation_text(fid)]
    return "\n".join(parts).rstrip() + "\n"


def write_fidelity(fid: Fidelity, reports_dir: str | Path) -> FidelityFiles:
    """Write ``fidelity.csv`` and ``fidelity.md`` to ``reports_dir`` (created)."""
    d = Path(reports_dir)
    d.mkdir(parents=True, exist_ok=True)
    csv = FIDELITY.to_csv(fid.table, d / FIDELITY_CSV)
    md = d / FIDELITY_MD
    md.write_text(fidelity_markdown(fid))
    return FidelityFiles(csv=csv, markdown=md)
