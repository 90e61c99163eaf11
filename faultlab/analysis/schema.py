"""The tables of an :class:`~faultlab.analysis.Analysis`: every column named and typed once.

Each table has a :class:`TableSchema`: its name (the stem of its CSV file), a description, its
columns in order and the kind of each column.  The column names are the final ones: the report's
CSV files and renderers use them as they are.  Where a table is a statistic of
:mod:`faultlab.stats`, its columns are that function's public column constant.

Naming: a faulty variant is ``fault`` in the per-fault statistics (as :mod:`faultlab.stats`
names it) and ``variant`` in the rows of Table II (which include the baseline) and in the
detection-rate table, whose CSV (``reports/detection_rates.csv``) has been published with that
name.  ``source`` is :data:`THIS_RUN` or :data:`PAPER`.

Kinds: ``int`` (int64), ``Int`` (nullable Int64: empty where a value is missing), ``float``
(float64, NaN where undefined), ``str`` (text without carriage returns; empty rather than
missing) and ``bool``.
CSV files hold floats to :data:`faultlab.precision.SIGNIFICANT_DIGITS` significant digits (so that a
library release moving the last bits does not change a written table); :meth:`TableSchema.read_csv`
gives back exactly the values :meth:`TableSchema.to_csv` wrote.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np
import pandas as pd

from faultlab.analysis.effects import CAMPAIGN_EFFECT_COLUMNS
from faultlab.errors import ResultsError
from faultlab.precision import write_csv
from faultlab.space.case import PARAMETER_NAMES, VALUE_KEYS
from faultlab.stats.class_effects import CLASS_EFFECT_COLUMNS
from faultlab.stats.cases import (CASE_COMPARISON_COLUMNS, CASE_RATE_COLUMNS, CASE_VERDICT_COLUMNS,
                                  PAPER_COMPARISON_COLUMNS)
from faultlab.stats.comparison import COMPARISON_COLUMNS
from faultlab.stats.detection import OUTCOME_COLUMNS
from faultlab.stats.effects import EFFECT_COLUMNS
from faultlab.stats.paper import PAPER_BY_SUITE_COLUMNS, PAPER_RATE_COLUMNS
from faultlab.stats.pooling import CAMPAIGN_VERDICT_COLUMNS, SUITE_VERDICT_COLUMNS
from faultlab.stats.rates import BY_SUITE_COLUMNS, FALSE_ALARM_COLUMNS, RATE_COLUMNS
from faultlab.vocabulary import POWER_TEXT

__all__ = ["TableSchema", "KINDS", "THIS_RUN", "PAPER", "ALL_VARIANTS", "TABLES"] + [
    "JOBS", "CASES", "OUTCOMES", "DETECTION_RATES", "BY_SUITE", "FALSE_ALARMS", "ORACLE", "ORACLE_SUMMARY",
    "SUITE_COMPARISONS", "PARAMETER_EFFECTS", "TABLE2_CELLS", "PAPER_RATES", "PAPER_BY_SUITE", "COVERAGE",
    "RUNTIMES", "CASE_VERDICTS", "CASE_RATES", "SUITE_VERDICTS", "CASE_COMPARISONS", "REPLICA_FALSE_ALARMS", "PAPER_COMPARISONS",
    "CLASS_EFFECTS", "CAMPAIGN_EFFECTS", "CAMPAIGN_VERDICTS"]

#: ``source`` of rows from the analysed campaign.
THIS_RUN = "this run"
#: ``source`` of rows from the paper's replication data (``paper_repro/``).
PAPER = "paper"
#: ``variant`` of the row of :data:`RUNTIMES` that pools every variant.
ALL_VARIANTS = "(all)"

#: Kind -> pandas dtype.
KINDS: dict[str, str] = {"int": "int64", "Int": "Int64", "float": "float64", "str": "object", "bool": "bool"}

#: The kind a column name has wherever it appears (a table may override it, see ``detected``).
_KIND_OF: dict[str, str] = {
    **{c: "str" for c in ("source", "suite", "variant", "fault", "status", "baseline_status", "outcome",
                          "missed", "suite_a", "suite_b", "term", "note", "parameter", "counts", "uncovered",
                          "rule", "verdict", "reason", "family", "method", "alternative", "direction")},
    **{c: "float" for c in ("epv", "lr_chi2")},
    **{c: "int" for c in ("run", "case", "rep", "n_cases", "n_reps", "n_jobs", "not_detected", "crash",
                          "timeout", "baseline_failed", "k", "n", "k_incl", "n_incl", "n_pairs",
                          "detected_pairs", "flagged", "n_faulty", "n_baseline", "k_a", "n_a", "k_b", "n_b",
                          "n_detected", "n_tested", "computed_pct", "classes", "covered", "n_landmarks",
                          "detected", "n_judged", "n_detecting", "n_cannot_judge", "n_clusters")},
    **{c: "float" for c in ("rms_mm", "emd_mm", "baseline_rms_mm", "runtime_s", "rate", "rate_incl",
                            "median_faulty_mm", "median_baseline_mm", "u", "p", "p_mc_se", "p_min", "p_holm", "rate_a",
                            "rate_b", "risk_difference", "rd_low", "rd_high", "odds_ratio", "or_low", "or_high",
                            "coef", "std_err", "reported_pct", "paper_rate", "paper_printed_pct", "min_p_min",
                            "min_p_holm", "coverage", "median_s", "max_s", "total_s", "share", "mde_mm", "low",
                            "high", "design_effect", "difference", "detectable_difference", "median_diff_mm",
                            "median_low_mm", "median_high_mm", "ratio", "ratio_low", "ratio_high")},
    **{f"{b}{s}": "float" for b in ("wilson_low", "wilson_high", "cp_low", "cp_high") for s in ("", "_incl")},
    **{c: "bool" for c in ("haldane", "agrees")},
    **{c: "Int" for c in ("paper_k", "paper_n")},
    **{k: ("str" if k == "directionality" else "float") for k in VALUE_KEYS},
    **{f"class_{p}": "int" for p in PARAMETER_NAMES},
}


@dataclass(frozen=True)
class TableSchema:
    """Name, columns and column kinds of one table.

    Attributes
    ----------
    name : str
        Identifier of the table (an :class:`~faultlab.analysis.Analysis` field and the stem of
        its CSV file).
    description : str
        One sentence: what a row is.
    columns : tuple of str
        Column names, in order.
    kinds : tuple of str
        Kind of every column (keys of :data:`KINDS`).
    """

    name: str
    description: str
    columns: tuple[str, ...]
    kinds: tuple[str, ...]

    def __post_init__(self) -> None:
        if len(self.columns) != len(self.kinds) or len(set(self.columns)) != len(self.columns):
            raise ValueError(f"table {self.name}: columns and kinds do not match or repeat")
        bad = [k for k in self.kinds if k not in KINDS]
        if bad:
            raise ValueError(f"table {self.name}: unknown column kind {bad[0]!r}")

    @classmethod
    def define(cls, name: str, description: str, columns: Sequence[str], **kinds: str) -> "TableSchema":
        """A schema whose column kinds are the usual ones for their names, except ``kinds``."""
        columns = tuple(columns)
        unknown = [c for c in columns if c not in kinds and c not in _KIND_OF]
        if unknown:
            raise ValueError(f"table {name}: no kind for column {unknown[0]!r}")
        return cls(name, description, columns, tuple(kinds.get(c) or _KIND_OF[c] for c in columns))

    @property
    def dtypes(self) -> dict[str, str]:
        """Column -> pandas dtype."""
        return {c: KINDS[k] for c, k in zip(self.columns, self.kinds)}

    def empty(self) -> pd.DataFrame:
        """A table without rows."""
        return pd.DataFrame({c: pd.Series([], dtype=d) for c, d in self.dtypes.items()})

    def conform(self, frame: pd.DataFrame) -> pd.DataFrame:
        """The schema's columns of ``frame``, in order, each of its kind, with a fresh RangeIndex.

        Raises
        ------
        ResultsError
            A column is missing, or a value does not fit its kind (names the column).
        """
        missing = [c for c in self.columns if c not in frame.columns]
        if missing:
            raise ResultsError(f"table {self.name}: missing column(s) {', '.join(missing)}")
        out = {}
        for column, kind in zip(self.columns, self.kinds):
            out[column] = _cast(frame[column].reset_index(drop=True), kind, f"{self.name}.{column}")
        return pd.DataFrame(out, columns=list(self.columns))

    def to_csv(self, frame: pd.DataFrame, path: str | Path) -> Path:
        """Write ``frame`` (conformed first) as CSV: header, then one line per row (:func:`write_csv`)."""
        return write_csv(self.conform(frame), path)

    def read_csv(self, path: str | Path) -> pd.DataFrame:
        """Read a CSV written by :meth:`to_csv` back into exactly the frame that was written.

        Raises
        ------
        ResultsError
            Unreadable file, other columns than the schema's, or a value that does not fit
            its column's kind (names file, column and row).
        """
        path = Path(path)
        try:
            raw = pd.read_csv(path, dtype=str, keep_default_na=False, na_filter=False)
        except (OSError, pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError) as exc:
            raise ResultsError(f"{path}: cannot read table {self.name} ({exc})") from exc
        if tuple(raw.columns) != self.columns:
            raise ResultsError(f"{path}: columns {', '.join(raw.columns)} are not those of table {self.name} "
                               f"({', '.join(self.columns)})")
        out = {}
        for column, kind in zip(self.columns, self.kinds):
            try:
                out[column] = _parse(raw[column].tolist(), kind)
            except (ValueError, KeyError) as exc:
                raise ResultsError(f"{path}: column {column}: {exc}") from exc
        return pd.DataFrame(out, columns=list(self.columns))


def _cast(values: pd.Series, kind: str, where: str) -> pd.Series:
    if kind == "str":
        text = values.astype(object).where(values.notna(), "")
        if not all(type(v) is str for v in text):
            text = text.map(str)
        if any("\r" in v for v in text):  # CSV readers take a lone CR for a line break
            raise ResultsError(f"table column {where} holds a carriage return, which its CSV file cannot keep")
        return text
    if kind == "float":
        return values.astype("float64")
    if kind == "Int":
        return values.astype("Int64")
    if values.isna().any():
        raise ResultsError(f"table column {where} must not have missing values")
    return values.astype(KINDS[kind])


_BOOLS = {"True": True, "False": False}


def _parse(texts: list[str], kind: str) -> pd.Series:
    """Column values from the text pandas wrote (``float`` via Python's exact ``float``)."""
    if kind == "str":
        return pd.Series(texts, dtype=object)
    if kind == "float":
        return pd.Series(np.array([float(t) if t != "" else np.nan for t in texts], dtype=np.float64))
    if kind == "int":
        return pd.Series(np.array([int(t) for t in texts], dtype=np.int64))
    if kind == "Int":
        return pd.Series(pd.array([int(t) if t != "" else pd.NA for t in texts], dtype="Int64"))
    return pd.Series(np.array([_BOOLS[t] for t in texts], dtype=bool))


# --------------------------------------------------------------------------- the tables

_CASE_VALUES = tuple(VALUE_KEYS) + tuple(f"class_{p}" for p in PARAMETER_NAMES)

JOBS = TableSchema.define(
    "jobs", "One SLAM execution: this run's jobs, and the paper's raw RMS rows (rep 0, no EMD, no runtime).",
    ("source", "run", "suite", "case", "variant", "rep", "rms_mm", "emd_mm", "status", "runtime_s"))
CASES = TableSchema.define(
    "cases", "One test case of this run: its scenario values and the classes recorded for them.",
    ("run", "suite", "case", "n_landmarks") + _CASE_VALUES)
OUTCOMES = TableSchema.define(
    "outcomes", "One faulty job beside its baseline with its outcome class (faultlab.stats.outcomes).",
    ("source",) + OUTCOME_COLUMNS)
DETECTION_RATES = TableSchema.define(
    "detection_rates", "Per suite and fault of this run: outcome counts, detection rates with Wilson and "
    "Clopper-Pearson intervals (faultlab.stats.tabulate_rates), and the paper's figures beside.",
    ("suite", "variant") + RATE_COLUMNS[2:] + ("paper_k", "paper_n", "paper_rate", "paper_printed_pct"))
BY_SUITE = TableSchema.define(
    "by_suite", "Per suite of this run: the paper's 'by Suite' share of fault x run pairs detected "
    "(faultlab.stats.tabulate_by_suite).", BY_SUITE_COLUMNS)
FALSE_ALARMS = TableSchema.define(
    "false_alarms", "Per suite and pooled ('all'): how often the rule flags a baseline repetition against "
    "another (faultlab.stats.false_alarm_rate).", FALSE_ALARM_COLUMNS)
ORACLE = TableSchema.define(
    "oracle", "Per suite, run, case and fault: Mann-Whitney U of faulty vs baseline RMS over the "
    "repetitions, Holm-corrected (faultlab.stats.oracle_detections).",
    ("suite", "run", "case", "fault", "n_faulty", "n_baseline", "median_faulty_mm", "median_baseline_mm", "u",
     "p", "p_mc_se", "p_min", "p_holm", "detected"), detected="bool")
ORACLE_SUMMARY = TableSchema.define(
    "oracle_summary", "Per suite and fault: cases, tested cases, cases the oracle detects, smallest "
    "attainable p and smallest Holm-adjusted p.",
    ("suite", "fault", "n_cases", "n_tested", "n_detected", "min_p_min", "min_p_holm"))
SUITE_COMPARISONS = TableSchema.define(
    "suite_comparisons", "Per fault and pair of suites: Fisher's exact test, risk difference and odds "
    "ratio (faultlab.stats.compare_suite_rates).", COMPARISON_COLUMNS)
PARAMETER_EFFECTS = TableSchema.define(
    "parameter_effects", "Per fault and scenario parameter: odds ratio of detection per standard "
    "deviation (faultlab.stats.fit_effects); note rows for what was not fitted.", EFFECT_COLUMNS)
TABLE2_CELLS = TableSchema.define(
    "table2_cells", "One RMS cell of Table II (one SLAM repetition) of this run or the paper: the error "
    "(NaN unless ok), the job's status and whether the case detects the fault.",
    ("source", "suite", "variant", "run", "case", "rms_mm", "status", "detected"), detected="bool")
PAPER_RATES = TableSchema.define(
    "paper_rates", "Per suite and fault: the rule applied to the paper's raw data beside the printed "
    "'Detected Faults' percentage (faultlab.stats.paper_table).", PAPER_RATE_COLUMNS)
PAPER_BY_SUITE = TableSchema.define(
    "paper_by_suite", "Per suite: the paper's 'by Suite' share from its raw data beside the printed one "
    "(faultlab.stats.paper_table).", PAPER_BY_SUITE_COLUMNS)
COVERAGE = TableSchema.define(
    "coverage", "Per evaluation run (empty: all runs pooled), suite and parameter of Table I (and "
    "'overall'): classes covered by the suite's cases (faultlab.space.coverage).",
    ("run", "suite", "parameter", "classes", "covered", "coverage", "counts", "uncovered"), run="Int")
RUNTIMES = TableSchema.define(
    "runtimes", "Per variant of this run (and '(all)'): jobs and SLAM execution times, s.",
    ("variant", "n_jobs", "median_s", "max_s", "total_s"))

CASE_VERDICTS = TableSchema.define(
    "case_verdicts", "Per suite, run, case and fault (the baseline_replica A/A control included): the verdict "
    "of the campaign's rule over the case's K repetitions, the exact paired test's p, Holm within the family, "
    "the smallest detectable shift (faultlab.stats.cases.rule_verdicts).", CASE_VERDICT_COLUMNS,
    p_holm="float", p="float", paper_k="Int", test="str")
CASE_RATES = TableSchema.define(
    "case_rates", "Per suite and fault: detected / judged cases (cases are the unit; cannot-judge cases "
    "counted apart) with Clopper-Pearson and Wilson intervals (faultlab.stats.cases.case_rates).",
    CASE_RATE_COLUMNS, k="int", n="int")
SUITE_VERDICTS = TableSchema.define(
    "suite_verdicts", "Per suite, run and fault: the suite-level decision over the suite run's cases by the "
    "exact sign-flip tests whatever the campaign's rule -- the per-case minimum at alpha / n (detected_min) and, "
    "beside it, combined with the pooled test over the cases' mean log ratios, each at alpha / 2 "
    "(detected_combined), each with its smallest attainable p and a verdict that says cannot_judge where no "
    "outcome could reach the level (faultlab.stats.pooling.suite_verdicts).", SUITE_VERDICT_COLUMNS,
    run="int", n_cases="int", n_tested="int", n_crashed="int", n_exact="int", min_p="float", case_p_min="float",
    pooled_p="float", pooled_p_min="float", pooled_verdict="str", detected_min="bool", by_case="bool",
    by_pool="bool", detected_combined="bool")
CASE_COMPARISONS = TableSchema.define(
    "case_comparisons", "Per fault and pair of suites: cases as units, runs as clusters (binomial GEE, "
    "exchangeable, robust SEs; cluster bootstrap where GEE cannot fit), Holm within the fault "
    "(faultlab.stats.cases.compare_suites_by_case).", CASE_COMPARISON_COLUMNS)
REPLICA_FALSE_ALARMS = TableSchema.define(
    "replica_false_alarms", "Per rule and suite (and 'all'): the share of baseline_replica-vs-baseline "
    "pairs flagged (empirical false-alarm rate), interval clustered by case (faultlab.stats.clustered_rate).",
    ("rule", "suite", "n_cases", "n_pairs", "flagged", "rate", "low", "high", "design_effect"))
PAPER_COMPARISONS = TableSchema.define(
    "paper_comparisons", "Per suite and fault with a printed paper figure: paper k/n vs this run's detected / "
    f"judged cases, Boschloo's exact test, smallest detectable difference at {POWER_TEXT} power, verdict "
    "(faultlab.stats.cases.compare_with_paper).", PAPER_COMPARISON_COLUMNS, k="int", n="int", paper_k="int",
    paper_n="int")

CLASS_EFFECTS = TableSchema.define(
    "class_effects", "Per fault and class indicator of a scenario parameter: logistic regression of the case "
    "verdicts (ML, Firth where separated), the parameter's LR test with Holm over the fault's parameters, events "
    "per predictor; a (model) row where too few data (faultlab.stats.class_effects.fit_class_effects).",
    CLASS_EFFECT_COLUMNS, df="int")
CAMPAIGN_EFFECTS = TableSchema.define(
    "campaign_effects", "Per continuous response (the baseline's difficulty, each fault's effect size): its mean "
    "over the cases with a t interval, and the cluster-robust regression per parameter where the campaign has "
    "enough cases per coefficient, else a (size) row saying what it would need "
    "(faultlab.analysis.effects.campaign_effects).", CAMPAIGN_EFFECT_COLUMNS, response="str", estimate="float")
CAMPAIGN_VERDICTS = TableSchema.define(
    "campaign_verdicts", "Per fault: the campaign-level verdict over all its cases -- the exact sign-flip test "
    "over the cases' mean log ratios (the case is the unit), Holm over the faults, the geometric-mean factor "
    "with the interval that inverts the test; cannot_judge where the smallest attainable p exceeds alpha "
    "(faultlab.stats.pooling.campaign_verdicts).", CAMPAIGN_VERDICT_COLUMNS, test="str", alpha="float",
    n_cases="int", n_tested="int", n_crashed="int", n_exact="int", n_draws="int", mean_log_ratio="float",
    mean_log_ratio_low="float", mean_log_ratio_high="float", mc_se="float")

#: Every table of an Analysis, in the order they are saved.
TABLES: tuple[TableSchema, ...] = (JOBS, CASES, OUTCOMES, DETECTION_RATES, BY_SUITE, FALSE_ALARMS, ORACLE,
                                   ORACLE_SUMMARY, SUITE_COMPARISONS, PARAMETER_EFFECTS, TABLE2_CELLS,
                                   PAPER_RATES, PAPER_BY_SUITE, COVERAGE, RUNTIMES, CASE_VERDICTS, CASE_RATES,
                                   SUITE_VERDICTS, CASE_COMPARISONS, REPLICA_FALSE_ALARMS, PAPER_COMPARISONS, CLASS_EFFECTS,
                                   CAMPAIGN_EFFECTS, CAMPAIGN_VERDICTS)
