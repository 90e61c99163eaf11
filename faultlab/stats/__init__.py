"""Detection, rates, statistical oracle, suite comparison and parameter effects (Sec. VII).

The paper's detection rule (:class:`DetectionRule`, Sec. VII-A) turns each
faulty job and its baseline into an :class:`Outcome`; :func:`detection_rates`
and :func:`by_suite` give Table II's columns with confidence intervals, and
:func:`paper_table` recomputes Table II from the paper's raw data.  Beyond the
paper: :func:`false_alarm_rate`, :func:`oracle_detections`,
:func:`compare_suites` and :func:`parameter_effects`.
"""

from faultlab.stats.comparison import compare_suites, odds_ratio
from faultlab.stats.detection import (BASELINE, DetectionRule, Outcome, classify, detects, outcomes,
                                      pair_with_baseline)
from faultlab.stats.effects import NUMERIC_PARAMETERS, format_effects, parameter_effects
from faultlab.stats.oracle import oracle_detections
from faultlab.stats.paper import (PRINTED_BY_SUITE, RAW_CSV, REPORTED_CSV, PaperTable, load_paper_raw,
                                  load_paper_reported, paper_table, percent, resolve_data_path)
from faultlab.stats.rates import (FAULT_ORDER, SUITE_ORDER, by_suite, detection_rates, false_alarm_rate,
                                  proportion_ci)

__all__ = [
    "BASELINE", "DetectionRule", "Outcome", "detects", "pair_with_baseline", "classify", "outcomes",
    "proportion_ci", "detection_rates", "by_suite", "false_alarm_rate", "SUITE_ORDER", "FAULT_ORDER",
    "oracle_detections", "compare_suites", "odds_ratio", "parameter_effects", "format_effects",
    "NUMERIC_PARAMETERS", "PaperTable", "paper_table", "load_paper_raw", "load_paper_reported",
    "resolve_data_path", "percent", "PRINTED_BY_SUITE", "RAW_CSV", "REPORTED_CSV",
]
