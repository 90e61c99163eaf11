"""The report of the paper's protocol: Table II, detection rates, fidelity and the PDF from a saved store.

:func:`rebuild_report` renders what :func:`faultlab.campaigns.reproduce.reproduce` stored (and
``faultlab report RESULTS`` re-renders any saved store): the tables and the PDF with
:func:`faultlab.report.build.build_report`, and the comparison of the map errors with the paper's
raw data (:mod:`faultlab.report.fidelity`), computed once for both.  Nothing runs here.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from faultlab.analysis.ablation import AblationResult
from faultlab.analysis.fidelity import fidelity
from faultlab.report.build import ReportFiles, build_report
from faultlab.report.fidelity import FidelityFiles, write_fidelity

__all__ = ["RebuiltReport", "rebuild_report"]


@dataclass(frozen=True)
class RebuiltReport:
    """What :func:`rebuild_report` wrote: the report and the comparison with the paper's raw data."""

    report: ReportFiles
    fidelity: FidelityFiles

    def __str__(self) -> str:
        return "\n".join([str(self.report), str(self.fidelity)])


def rebuild_report(results: str | Path, reports: str | Path, *,
                   ablation: AblationResult | None = None, pdf: bool = True) -> RebuiltReport:
    """Write the report of saved results (tables, fidelity.csv/.md, report.pdf), running nothing.

    The ablation's pages only when its result is given (its arms are separate campaigns:
    ``reproduce --ablation`` resumes them); ``pdf=False`` writes the tables without ``report.pdf``.

    Raises
    ------
    ResultsError
        No results store at ``results``, or it holds no rows.
    """
    fid = fidelity(results)  # computed once, rendered as fidelity.md and as pages of report.pdf
    report = build_report(results, reports, fidelity=fid, ablation=ablation, pdf=pdf)
    return RebuiltReport(report=report, fidelity=write_fidelity(fid, reports, ablation))
