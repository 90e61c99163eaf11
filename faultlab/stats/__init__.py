"""Detection, rates, statistical oracle, suite comparison and parameter effects (Sec. VII).

The paper's detection rule (:class:`DetectionRule`, Sec. VII-A) turns each
faulty job and its baseline into an :class:`Outcome`; :func:`detection_rates`
and :func:`by_suite` give Table II's columns with confidence intervals, and
:func:`paper_table` recomputes Table II from the paper's raw data.  Beyond the
paper: :func:`false_alarm_rate`, :func:`oracle_detections`,
:func:`compare_suites` and :func:`parameter_effects`.

Each statistic that starts from the classified jobs also comes as a function of
:func:`outcomes`' table (:func:`tabulate_rates`, :func:`tabulate_by_suite`,
:func:`compare_suite_rates`, :func:`fit_effects`, :func:`find_identical_faults`),
so :mod:`faultlab.analysis` classifies every job once and derives the rest.
"""

from faultlab.lazy import lazy_exports

#: Public name -> submodule that defines it.  Submodules load on first use
#: (PEP 562), so importing faultlab.stats (e.g. by the CLI) stays cheap.
_EXPORTS = {
    "cases": ["CASE_VERDICT_COLUMNS", "CASE_RATE_COLUMNS", "CASE_COMPARISON_COLUMNS", "PAPER_COMPARISON_COLUMNS",
              "REPLICA_FALSE_ALARM_COLUMNS", "rule_verdicts", "case_rates", "compare_suites_by_case",
              "compare_with_paper", "replica_false_alarms", "holm_within", "gee_suite_test",
              "detectable_difference"],
    "class_effects": ["CLASS_EFFECT_COLUMNS", "MIN_EPV", "fit_class_effects"],
    "verdict": ["Verdict", "case_verdicts", "EQUIVALENCE_MARGIN_REL", "EQUIVALENCE_MARGIN_MM"],
    "pooling": ["COMBINATIONS", "DEFAULT_COMBINATION", "case_log_ratio_means", "pooled_pvalues", "suite_decisions",
                "pooling_power"],
    "calibration": ["CalibrationStatus", "CalibrationCheck", "false_alarm_rates", "check_calibration"],
    "comparison": ["COMPARISON_COLUMNS", "compare_suite_rates", "compare_suites", "odds_ratio"],
    "detection": ["DetectionRule", "KEY_COLUMNS", "OUTCOME_COLUMNS", "classify", "detects", "outcomes",
                  "pair_with_baseline"],
    "effects": ["EFFECT_COLUMNS", "NUMERIC_PARAMETERS", "fit_effects", "format_effects", "parameter_effects",
                "validate_parameters"],
    "metadata": ["read_rule", "read_space", "count_expected_jobs", "adaptive_summary", "judged_metric"],
    "oracle": ["oracle_detections"],
    "paper": ["PAPER_BY_SUITE_COLUMNS", "PAPER_RATE_COLUMNS", "PRINTED_BY_SUITE", "RAW_CSV", "REPORTED_CSV",
              "PaperTable", "load_paper_raw", "load_paper_reported", "paper_table", "percent",
              "resolve_data_path"],
    "rates": ["BY_SUITE_COLUMNS", "FALSE_ALARM_COLUMNS", "RATE_COLUMNS", "by_suite", "detection_rates",
              "false_alarm_rate", "find_identical_faults", "proportion_ci", "suspected_equivalent_faults",
              "tabulate_by_suite", "tabulate_rates"],
}

__getattr__, __dir__, __all__ = lazy_exports(__name__, _EXPORTS)
