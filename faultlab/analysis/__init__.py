"""faultlab.analysis: one Analysis of a campaign, computed once, that every report renders.

>>> from faultlab.analysis import analyse                          # doctest: +SKIP
>>> a = analyse("results/paper")                                    # doctest: +SKIP
>>> a.detection_rates[["suite", "variant", "k", "n", "rate"]]       # doctest: +SKIP
>>> a.save("analysis/paper"); Analysis.load("analysis/paper")       # doctest: +SKIP

The analysis layer sits between the campaigns (:mod:`faultlab.campaigns`, on :mod:`faultlab.runner`)
and the reports: it reads saved results and their metadata, judges them by the detection rule
stored with the campaign and computes every statistic with :mod:`faultlab.stats`.  It never runs a
campaign, never plots and never imports the report or command-line layers.
"""

from faultlab.lazy import lazy_exports

#: Public name -> submodule.  Submodules load on first use (PEP 562), so importing
#: faultlab.analysis (e.g. by the command line) does not import statsmodels.
_EXPORTS = {
    "result": ["Analysis", "Note", "analyse", "BEYOND_THE_PAPER", "FORMAT_VERSION", "JSON_FILE"],
    "schema": ["TableSchema", "TABLES", "THIS_RUN", "PAPER", "ALL_VARIANTS"],
    "replay": ["AdaptiveReplay", "replay_adaptive"],
}

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
