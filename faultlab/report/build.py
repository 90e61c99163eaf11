"""Build the report of a finished (or partial) campaign from its saved results only.

:func:`build_report` analyses a results store once (:func:`faultlab.analysis.analyse`) and
renders the Analysis (:func:`render_report`): the tables, the comparison with the paper and
``report.pdf``.  It never runs a SLAM, never generates a case and never writes to the results
store: ``python -m faultlab report RESULTS`` rebuilds a report at any time.  Given the comparison
with the paper's raw data (:func:`faultlab.analysis.fidelity.fidelity`) and the ablation of the paper
profile's differences (:func:`faultlab.analysis.ablation.ablation`), computed once by the caller,
``report.pdf`` also gets their pages after the comparison with the paper.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from matplotlib.figure import Figure

from faultlab import __version__
from faultlab.analysis import BEYOND_THE_PAPER, Analysis, analyse
from faultlab.analysis.ablation import AblationResult
from faultlab.analysis.fidelity import Fidelity
from faultlab.report.ablation import ablation_pages
from faultlab.report.comparison import Comparison, compare_with_paper
from faultlab.report.fidelity import fidelity_pages
from faultlab.report.pages import (
    MAX_PICTURED_RUNS,
    REPORT_TITLE,
    beyond_pages,
    case_pages,
    comparison_pages,
    coverage_pages,
    figure_pages,
    metadata_pages,
    rates_pages,
    summary_pages,
    table2_pages,
    title_pages,
)
from faultlab.report.pdf import PdfReport, write_pdf
from faultlab.report.tables import write_tables
from faultlab.runner.store import results_path
from faultlab.vocabulary import DEFAULT_ALPHA

__all__ = ["ReportFiles", "build_report", "render_report", "MAX_PICTURED_RUNS"]


@dataclass(frozen=True)
class ReportFiles:
    """What :func:`build_report` wrote.

    Attributes
    ----------
    reports_dir : Path
    table2_csv, table2_md, table2_tex, detection_csv, detection_md, comparison_md : Path
    pdf : Path or None
        ``report.pdf``; None when the report was written without it (``pdf=False``).
    n_pages : int
        Pages of ``report.pdf`` (0 without it).
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
    pdf: Path | None
    n_pages: int
    page_titles: tuple[str, ...]
    comparison: Comparison
    n_rows: int
    notes: tuple[str, ...] = ()

    @property
    def files(self) -> list[Path]:
        return [p for p in (self.table2_csv, self.table2_md, self.table2_tex, self.detection_csv,
                            self.detection_md, self.comparison_md, self.pdf) if p is not None]

    def __str__(self) -> str:
        lines = [f"report written to {self.reports_dir} ({self.n_rows} result rows):"]
        lines += [f"  {p}" for p in self.files if p != self.pdf]
        lines.append(f"  {self.pdf} ({self.n_pages} pages)" if self.pdf is not None else "  (no PDF: pdf=False)")
        lines.append(self.comparison.summary())
        lines += [f"note: {n}" for n in self.notes]
        return "\n".join(lines)


def build_report(results_dir: str | Path, reports_dir: str | Path, *, alpha: float = DEFAULT_ALPHA,
                 range_factor: float = 2.0, paper_raw: str | Path | None = None,
                 paper_reported: str | Path | None = None, fidelity: Fidelity | None = None,
                 ablation: AblationResult | None = None, pdf: bool = True) -> ReportFiles:
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
    fidelity : Fidelity, optional
        The map errors against the paper's raw data: rendered as pages of ``report.pdf``.
    ablation : AblationResult, optional
        The effects of the paper profile's differences: rendered as pages of ``report.pdf``.
    pdf : bool
        Write ``report.pdf`` (False: the tables and the comparison only, in a fraction of the time).

    Returns
    -------
    ReportFiles

    Raises
    ------
    ResultsError
        No results store at ``results_dir``, or it holds no rows.
    """
    analysis = analyse(results_dir, alpha=alpha, paper_raw=paper_raw, paper_reported=paper_reported)
    return render_report(analysis, reports_dir, store_dir=results_dir, range_factor=range_factor,
                         fidelity=fidelity, ablation=ablation, pdf=pdf)


def render_report(analysis: Analysis, reports_dir: str | Path, *, store_dir: str | Path | None = None,
                  range_factor: float = 2.0, fidelity: Fidelity | None = None,
                  ablation: AblationResult | None = None, pdf: bool = True) -> ReportFiles:
    """Write the report of an Analysis (e.g. one loaded with :meth:`Analysis.load`).

    Parameters
    ----------
    analysis : Analysis
    reports_dir : path
        Where to write (created).
    store_dir : path, optional
        The results store whose saved test cases are pictured; default the store the analysis
        was made from (its metadata's ``path``).  Cases that cannot be read are noted.
    range_factor, fidelity, ablation, pdf
        As for :func:`build_report`.
    """
    reports_dir = Path(reports_dir)
    tables = write_tables(analysis, reports_dir)
    comparison = compare_with_paper(analysis, range_factor=range_factor)
    comparison_md = reports_dir / "comparison.md"
    comparison_md.write_text(comparison.markdown(), encoding="utf-8")
    general = [n.text for n in analysis.notes if n.topic not in BEYOND_THE_PAPER]
    files = dict(reports_dir=reports_dir, table2_csv=tables.table2_csv, table2_md=tables.table2_md,
                 table2_tex=tables.table2_tex, detection_csv=tables.detection_csv, detection_md=tables.detection_md,
                 comparison_md=comparison_md, comparison=comparison, n_rows=analysis.n_rows)
    if not pdf:
        return ReportFiles(**files, pdf=None, n_pages=0, page_titles=(), notes=tuple(general))
    pictures, seeds, picture_notes = case_pages(_store_dir(analysis, store_dir), analysis)
    notes = general + picture_notes
    extra = ((fidelity_pages(fidelity, ablation) if fidelity is not None else [])
             + (ablation_pages(ablation) if ablation is not None else []))
    pages = (summary_pages(analysis, comparison) + title_pages(analysis, comparison, notes)
             + _body_pages(analysis, comparison, pictures, extra)
             + metadata_pages(analysis, seeds))
    written = _write_pdf(analysis, reports_dir, pages)
    return ReportFiles(**files, pdf=written.path, n_pages=written.n_pages, page_titles=written.titles,
                       notes=tuple(notes))


def _store_dir(analysis: Analysis, store_dir: str | Path | None) -> Path:
    if store_dir is not None:
        return results_path(store_dir).parent
    return Path(analysis.metadata.get("path", ".")).parent


def _body_pages(analysis: Analysis, comparison: Comparison, pictures: list[Figure],
                fidelity: list[Figure]) -> list[Figure]:
    """Every page between the title and the metadata, in reading order (``fidelity``: the pages on the
    paper's raw data and the ablation, after the comparison with the paper)."""
    return (table2_pages(analysis) + rates_pages(analysis) + comparison_pages(comparison) + fidelity
            + figure_pages(analysis) + pictures + coverage_pages(analysis) + beyond_pages(analysis))


def _write_pdf(analysis: Analysis, reports_dir: Path, pages: list[Figure]) -> PdfReport:
    meta = analysis.metadata
    return write_pdf(reports_dir / "report.pdf", pages, title=REPORT_TITLE,
                     subject=f"experiment {meta.get('experiment_source', '')} "
                             f"hash {meta.get('experiment_hash', '')}",
                     footer=f"faultlab {__version__}")
