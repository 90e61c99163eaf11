"""faultlab.analysis: one Analysis of a campaign, computed once, that every report renders.

>>> from faultlab.analysis import analyse                          # doctest: +SKIP
>>> a = analyse("results/paper")                                    # doctest: +SKIP
>>> a.detection_rates[["suite", "variant", "k", "n", "rate"]]       # doctest: +SKIP
>>> a.save("analysis/paper"); Analysis.load("analysis/paper")       # doctest: +SKIP

The analysis layer sits between the campaign (:mod:`faultlab.runner`) and the reports: it reads
saved results and their metadata, judges them by the detection rule stored with the campaign
and computes every statistic with :mod:`faultlab.stats`.  It never plots and never imports the
report or command-line layers.
"""

import importlib

#: Public name -> submodule.  Submodules load on first use (PEP 562), so importing
#: faultlab.analysis (e.g. by the command line) does not import statsmodels.
_EXPORTS = {
    "result": ["Analysis", "Note", "analyse", "BEYOND_THE_PAPER", "FORMAT_VERSION", "JSON_FILE"],
    "schema": ["TableSchema", "TABLES", "THIS_RUN", "PAPER", "ALL_VARIANTS"],
    "campaign": ["read_rule", "read_space", "count_expected_jobs"],
}
_MODULE_OF = {name: module for module, names in _EXPORTS.items() for name in names}

__all__ = [name for names in _EXPORTS.values() for name in names]


def __getattr__(name: str):
    module = _MODULE_OF.get(name)
    if module is None:
        raise AttributeError(f"module 'faultlab.analysis' has no attribute {name!r}")
    value = getattr(importlib.import_module(f"faultlab.analysis.{module}"), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
