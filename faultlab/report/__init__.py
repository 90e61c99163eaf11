"""faultlab.report: Table II of a run beside the paper's, figures, the PDF report and ``reproduce``.

The only layer that plots.  Reports render an :class:`faultlab.analysis.Analysis` of saved
results (:func:`build_report` analyses a results store and renders it); :func:`reproduce` runs
an experiment first.

>>> from faultlab.report import build_report                             # doctest: +SKIP
>>> from faultlab.report.reproduce import reproduce                      # doctest: +SKIP
>>> result = reproduce("experiments/paper.toml", quick=True)              # doctest: +SKIP
>>> files = build_report("results/paper-quick", "reports")                # doctest: +SKIP
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
    # the function ``reproduce`` is not re-exported: the name is its submodule's
    # (use ``from faultlab.report.reproduce import reproduce``)
    "ReproduceResult": "reproduce", "quick_overrides": "reproduce",
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
