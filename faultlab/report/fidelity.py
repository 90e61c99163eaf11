"""The fidelity page: this run's RMS distributions against the paper's raw data, per suite and variant.

Renders a :class:`faultlab.analysis.fidelity.Fidelity` (nothing is computed here): ``fidelity.csv``
and ``fidelity.json`` (the table as computed and its settings, written by the result's
:meth:`~faultlab.analysis.bundle.TableBundle.save`), ``fidelity.md`` (what ran, the rule, the table
in mm, and in words which figures are reproduced, which differ and where the faulty-rotation errors
lie against the paper's) and the same as pages of ``report.pdf`` (:func:`fidelity_pages`).  Given the ablation of the paper
profile's differences (:class:`faultlab.analysis.ablation.AblationResult`), the faulty-rotation
statement quotes the effect of every difference that acts on that fault.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd
from matplotlib.figure import Figure

from faultlab.analysis.ablation import AblationResult
from faultlab.analysis.fidelity import FIDELITY_CSV, FIDELITY_JSON, Fidelity, Verdict
from faultlab.report.pdf import table_pages, text_pages
from faultlab.report.tables import format_mm, md_table, suite_label, variant_label
from faultlab.vocabulary import PAPER_PROTOCOL

__all__ = ["FidelityFiles", "fidelity_markdown", "fidelity_pages", "write_fidelity", "FIDELITY_MD", "FIDELITY_TITLE"]

FIDELITY_MD = "fidelity.md"
#: Title of the page (Markdown heading and PDF page).
FIDELITY_TITLE = "Map errors against the paper's raw data"
#: The differences from the paper's filter that act on the faulty rotation's errors (rows of
#: :data:`faultlab.slam.profiles.ABLATIONS`).
_ROTATION_POINTS = ("predicted bearing", "innovation wraps", "field of view (scenario)", "resampling copies")
#: The fault whose magnitude the paper profile exists to compare (Table II's "faulty rotation").
_ROTATION = "missing_angle_wrap"


@dataclass(frozen=True)
class FidelityFiles:
    """The files :func:`write_fidelity` wrote."""

    csv: Path
    meta: Path
    markdown: Path

    def __str__(self) -> str:
        return f"fidelity: {self.csv}, {self.meta}, {self.markdown}"


def _ratio_text(row) -> str:
    return f"{row.ratio:.2f} [{row.ratio_low:.2f}, {row.ratio_high:.2f}]"


def _p_text(p: float) -> str:
    return f"{p:.2g}"


#: How the campaign text names each quantity of the paper's protocol.
_PROTOCOL_WORDS = {"n_steps": "steps", "particles": "particles", "runs": "runs"}


def _campaign_text(fid: Fidelity) -> list[str]:
    c = fid.campaign
    what = (f"SLAM `{c.get('slam')}`" + (f", profile `{c['profile']}`" if c.get("profile") else "")
            + f", fov_bug = {str(bool(c.get('fov_bug'))).lower()}, {c.get('runs')} run(s), "
              f"{c.get('n_steps')} steps per case, {c.get('particles')} particles")
    lines = [f"This run: {what}."]
    if c.get("reduced"):
        paper = {k: (PAPER_PROTOCOL[k], what) for k, what in _PROTOCOL_WORDS.items()}
        short = [f"{c[k]} {what.removesuffix('s') if c[k] == 1 else what} instead of {n}"
                 for k, (n, what) in paper.items() if isinstance(c.get(k), int) and c[k] < n]
        lines += ["", f"**REDUCED configuration** ({', '.join(short)}): fewer steps, particles or runs than the "
                      f"paper's protocol ({', '.join(f'{n} {what}' for n, what in paper.values())})."]
        if any(isinstance(c.get(k), int) and c[k] < paper[k][0] for k in ("n_steps", "particles")):
            lines[-1] += (" Map errors grow with the length of a trace, so sizes are compared with the paper's "
                          "full-length runs only as an indication.")
        else:
            lines[-1] += (" Each case is run as the paper ran it; with fewer runs each cell has fewer values, so "
                          "the tests have less power and the intervals are wider.")
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
    t = fid.fidelity
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


def _rotation_evidence(ablation: AblationResult | None) -> list[str]:
    """The ablation's effects on the faulty rotation, one bullet per difference that acts on it."""
    if ablation is None:
        return []
    lines = []
    for point in _ROTATION_POINTS:
        r = ablation.row(point, _ROTATION)
        if r is None:
            continue
        sig = "significant" if r.p_holm < ablation.alpha else "not significant"
        lines.append(f"- {point}: with the paper's choice the faulty rotation's median error is "
                     f"{format_mm(r.paper_median_mm)} mm, with faultlab's alternative {format_mm(r.alternative_median_mm)} "
                     f"mm (paired median difference {r.diff_median_mm:.0f} mm [{r.diff_low_mm:.0f}, "
                     f"{r.diff_high_mm:.0f}], ratio {r.ratio_median:.2f}, p_Holm {r.p_holm:.2g}: {sig}).")
    if lines:
        lines = ["Evidence from the ablation (ablation.md; same cases and seeds, one difference at a time):",
                 *lines]
    return lines


def _rotation_text(fid: Fidelity, ablation: AblationResult | None = None) -> list[str]:
    t = fid.fidelity[fid.fidelity["variant"] == _ROTATION]
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
                for r in t.itertuples()) + ".",
            _per_suite_test_text(fid, t), *_rotation_evidence(ablation)]


def _per_suite_test_text(fid: Fidelity, t: pd.DataFrame) -> str:
    """The two-sample test of the faulty rotation per suite, in words."""
    return "Two-sample test per suite (Mann-Whitney U, Holm over the table): " + "; ".join(
        f"{suite_label(r.suite)}: p = {_p_text(r.p)}, adjusted {_p_text(r.p_holm)}, ratio of medians "
        f"{_ratio_text(r)}, {r.verdict}" for r in t.itertuples()) + "."


def _summary_blocks(fid: Fidelity) -> list[str]:
    reproduced = fid.cells(Verdict.REPRODUCED)
    differs = fid.cells(Verdict.DIFFERS)
    in_ci = fid.fidelity[fid.fidelity["paper_median_in_ci"]]
    return [f"Reproduced ({len(reproduced)} of {len(fid.fidelity)}): {_cells(reproduced)}.",
            f"Differs ({len(differs)}): {_cells(differs)}.",
            f"The paper's median lies within this run's interval ({len(in_ci)} of {len(fid.fidelity)}): "
            f"{_cells(in_ci)}."]


def fidelity_markdown(fid: Fidelity, ablation: AblationResult | None = None) -> str:
    """The page as Markdown (with the ablation's evidence on the faulty rotation if given)."""
    rotation = _rotation_text(fid, ablation)
    if rotation:
        head, body = rotation[:2], rotation[2:]
        rotation = head + _md_blocks(body)
    parts = ["# " + FIDELITY_TITLE, "", *_campaign_text(fid), "", _rule_text(fid), "",
             md_table(_display(fid)), "", *_md_blocks(_summary_blocks(fid)), *rotation]
    return "\n".join(parts).rstrip() + "\n"


def _md_blocks(blocks: list[str]) -> list[str]:
    """Paragraphs separated by blank lines; consecutive bullets stay one list."""
    out: list[str] = []
    for i, b in enumerate(blocks):
        out.append(b)
        nxt = blocks[i + 1] if i + 1 < len(blocks) else ""
        if not (b.startswith("- ") and nxt.startswith("- ")) and not (nxt.startswith("- ") and b.endswith(":")):
            out.append("")
    return out


def fidelity_pages(fid: Fidelity, ablation: AblationResult | None = None) -> list[Figure]:
    """The page(s) of ``report.pdf``: the table, then what ran, the rule and the statements."""
    rotation = _rotation_text(fid, ablation)
    blocks = [*[b for b in _campaign_text(fid) if b], _rule_text(fid), *_summary_blocks(fid)]
    if rotation:
        blocks += ["## " + rotation[0].removeprefix("## ")] + [b for b in rotation[1:] if b]
    plain = [b.replace("**", "").replace("`", "") for b in blocks]  # Markdown emphasis is not rendered
    return (table_pages(FIDELITY_TITLE, _display(fid), max_rows=16)
            + text_pages(FIDELITY_TITLE + ": what it says", plain))


def write_fidelity(fid: Fidelity, reports_dir: str | Path, ablation: AblationResult | None = None) -> FidelityFiles:
    """Write ``fidelity.csv``, ``fidelity.json`` and ``fidelity.md`` to ``reports_dir`` (created)."""
    d = fid.save(reports_dir)
    md = d / FIDELITY_MD
    md.write_text(fidelity_markdown(fid, ablation))
    return FidelityFiles(csv=d / FIDELITY_CSV, meta=d / FIDELITY_JSON, markdown=md)
