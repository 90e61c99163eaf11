"""faultlab.report: Table II of a run beside the paper's, figures and the PDF report.

The only layer that plots, and it only renders: reports render an
:class:`faultlab.analysis.Analysis` of saved results (:func:`build_report` analyses a results
store and renders it); campaigns run in :mod:`faultlab.campaigns`.

>>> from faultlab.campaigns.reproduce import reproduce                   # doctest: +SKIP
>>> from faultlab.report import rebuild_report                           # doctest: +SKIP
>>> run = reproduce("experiments/paper.toml", quick=True)                 # doctest: +SKIP
>>> files = rebuild_report(run.out, run.reports)                          # doctest: +SKIP
"""

import importlib

#: Public name -> submodule.  Imported on first use, so that importing one submodule (e.g.
#: ``faultlab.report.casefig`` for ``generate``) does not pull in seaborn and statsmodels.
_EXPORTS = {
    "TableFiles": "tables", "table2_frame": "tables", "table2_csv_frame": "tables",
    "table2_markdown": "tables", "table2_latex": "tables", "detection_markdown": "tables",
    "detection_records": "tables", "write_tables": "tables", "round_mm": "tables",
    "Verdict": "comparison", "Statement": "comparison", "Comparison": "comparison",
    "compare_with_paper": "comparison",
    "detection_rate_figure": "figures", "rms_distribution_figure": "figures",
    "plot_case": "casefig", "plot_suite": "casefig", "save_case_png": "casefig",
    "PdfReport": "pdf", "text_pages": "pdf", "table_pages": "pdf", "write_pdf": "pdf",
    "ReportFiles": "build", "build_report": "build", "render_report": "build",
    "RebuiltReport": "reproduce", "rebuild_report": "reproduce",
}


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(f"faultlab.report.{_EXPORTS[name]}"), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'faultlab.report' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


__all__ = list(_EXPORTS)
