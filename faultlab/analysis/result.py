"""One analysis of a campaign: every statistic computed once, from the results and the stored rule.

:func:`analyse` reads a results store; :meth:`Analysis.from_frame` takes a results frame and its
metadata.  Both classify every faulty job once (:func:`faultlab.stats.outcomes`, with the
detection rule stored with the campaign) and derive every table from that classification:
detection rates with confidence intervals and "by Suite" (Table II, Sec. VII-D), false alarms,
the statistical oracle, suite comparisons, parameter effects and the continuous effects
(:func:`faultlab.analysis.effects.campaign_effects`; beyond the paper), Table II's
cells, coverage (Sec. V) and the paper's own figures recomputed from its raw data
(:func:`faultlab.stats.paper_table`).  Reports, figures and commands render an
:class:`Analysis`; they never compute a statistic themselves.

An Analysis is saved as one CSV per table plus ``analysis.json`` (rule, confidence level,
options, the store's metadata, notes) and loads back equal, table for table
(:meth:`Analysis.save`, :meth:`Analysis.load`).

To add a statistic: define its table in :mod:`faultlab.analysis.schema` (and add it to
``TABLES``), add a field of that name here and compute it in :meth:`Analysis.from_frame`;
:class:`Note` records, under the table's name, why it could not be computed.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Callable, Mapping, Sequence

import numpy as np
import pandas as pd

from faultlab.analysis.effects import campaign_effects
from faultlab.stats.metadata import (adaptive_summary, count_expected_jobs, judged_metric, metrics_note,
                                        read_rule, read_space)
from faultlab.analysis.schema import (
    BY_SUITE,
    CAMPAIGN_EFFECTS,
    CAMPAIGN_VERDICTS,
    CASE_COMPARISONS,
    CASE_RATES,
    CLASS_EFFECTS,
    CASE_VERDICTS,
    COVERAGE,
    FALSE_ALARMS,
    JOBS,
    ORACLE,
    OUTCOMES,
    PAPER,
    PAPER_BY_SUITE,
    PAPER_RATES,
    PAPER_COMPARISONS,
    PARAMETER_EFFECTS,
    REPLICA_FALSE_ALARMS,
    SUITE_COMPARISONS,
    SUITE_VERDICTS,
    TABLE2_CELLS,
    TABLES,
    THIS_RUN,
    TableSchema,
)
from faultlab.analysis.tables import (
    case_table,
    coverage_table,
    detection_rate_table,
    job_table,
    oracle_summary_table,
    outcome_table,
    runtime_table,
    table2_cell_table,
)
from faultlab.errors import ConfigError, FaultlabError, ResultsError
from faultlab.runner.store import load_metadata, load_results
from faultlab.stats.cases import (case_rates, compare_suites_by_case, compare_with_paper, replica_false_alarms,
                                  rule_verdicts)
from faultlab.stats.class_effects import fit_class_effects
from faultlab.stats.comparison import compare_suite_rates
from faultlab.stats.detection import DetectionRule, outcomes
from faultlab.stats.effects import fit_effects, validate_parameters
from faultlab.stats.oracle import oracle_detections
from faultlab.stats.paper import RAW_CSV, REPORTED_CSV, PaperTable, data_label, paper_table, resolve_data_path
from faultlab.stats.pooling import campaign_verdicts, suite_verdicts
from faultlab.stats.rates import false_alarm_rate, find_identical_faults, tabulate_by_suite, tabulate_rates
from faultlab.space.case import PARAMETER_NAMES
from faultlab.vocabulary import DEFAULT_ALPHA, REPLICA, SUITE_ORDER, JobStatus, ordered

__all__ = ["Analysis", "Note", "analyse", "FORMAT_VERSION", "JSON_FILE", "BEYOND_THE_PAPER"]

#: Version of the saved form (``analysis.json`` + CSV files).
FORMAT_VERSION = 2
#: File of the scalars, options, metadata and notes of a saved Analysis.
JSON_FILE = "analysis.json"
#: Tables of the statistics beyond the paper; a :class:`Note` under one of these names says why
#: the table holds nothing to show.
BEYOND_THE_PAPER: tuple[str, ...] = ("false_alarms", "oracle", "suite_comparisons", "parameter_effects",
                                      "campaign_effects", "case_verdicts", "case_rates", "suite_verdicts", "case_comparisons",
                                      "replica_false_alarms", "paper_comparisons", "class_effects",
                                      "campaign_verdicts")


@dataclass(frozen=True)
class Note:
    """Something the analysis could not do, or a caveat, and why.

    Attributes
    ----------
    topic : str
        A table name (e.g. ``"oracle"``) or ``"rule"``, ``"metric"``, ``"equivalent_faults"``,
        ``"paper"``, ``"campaign"``.
    text : str
        One or two sentences, for the reader of a report.
    """

    topic: str
    text: str

    def __str__(self) -> str:
        return self.text


@dataclass(frozen=True, eq=False)
class Analysis:
    """Every statistic of one campaign, computed once (see the module docstring).

    Scalars
    -------
    rule : DetectionRule
        The detection rule stored with the campaign (the paper's when none is stored).
    alpha : float
        1 - confidence level of every interval and the family-wise level of the oracle.
    rep : int
        The SLAM repetition of Table II's RMS cells, detection rates and "by Suite" (one pair per case, as in the paper).
    parameters : tuple of str or None
        The predictors of the parameter effects (None: every scenario parameter).
    metadata : dict
        The results store's metadata (:func:`faultlab.runner.load_metadata`), JSON-shaped.
    equivalent_faults : tuple of str
        Faults whose every result equals the baseline's (:func:`faultlab.stats.find_identical_faults`).
    paper_raw, paper_reported : str or None
        The paper's data files the paper tables were computed from, named without a machine path
        (:func:`faultlab.stats.paper.data_label`; None: no paper data).
    notes : tuple of Note
        What could not be computed, and why; caveats.

    Tables (columns in :mod:`faultlab.analysis.schema`)
    ------
    jobs, cases, outcomes, detection_rates, by_suite, false_alarms, oracle, oracle_summary,
    suite_comparisons, parameter_effects, table2_cells, paper_rates, paper_by_suite, coverage,
    runtimes, case_verdicts, case_rates, suite_verdicts, case_comparisons, replica_false_alarms, paper_comparisons,
    class_effects, campaign_effects, campaign_verdicts : DataFrame
        Treat them as read-only.
    """

    rule: DetectionRule
    alpha: float
    rep: int
    parameters: tuple[str, ...] | None
    metadata: dict
    equivalent_faults: tuple[str, ...]
    paper_raw: str | None
    paper_reported: str | None
    notes: tuple[Note, ...]
    jobs: pd.DataFrame
    cases: pd.DataFrame
    outcomes: pd.DataFrame
    detection_rates: pd.DataFrame
    by_suite: pd.DataFrame
    false_alarms: pd.DataFrame
    oracle: pd.DataFrame
    oracle_summary: pd.DataFrame
    suite_comparisons: pd.DataFrame
    parameter_effects: pd.DataFrame
    table2_cells: pd.DataFrame
    paper_rates: pd.DataFrame
    paper_by_suite: pd.DataFrame
    coverage: pd.DataFrame
    runtimes: pd.DataFrame
    case_verdicts: pd.DataFrame
    case_rates: pd.DataFrame
    suite_verdicts: pd.DataFrame
    case_comparisons: pd.DataFrame
    replica_false_alarms: pd.DataFrame
    paper_comparisons: pd.DataFrame
    class_effects: pd.DataFrame
    campaign_effects: pd.DataFrame
    campaign_verdicts: pd.DataFrame

    # ------------------------------------------------------------------ construction

    @classmethod
    def from_frame(cls, results: pd.DataFrame, metadata: Mapping | None = None, *, alpha: float = DEFAULT_ALPHA,
                   paper: bool = True, paper_raw: str | Path | None = None,
                   paper_reported: str | Path | None = None, rep: int | None = None,
                   parameters: Sequence[str] | None = None, metric: str | None = None) -> "Analysis":
        """Analyse a results frame.

        Parameters
        ----------
        results : DataFrame
            One row per job, :data:`faultlab.runner.RESULT_COLUMNS` (as :func:`faultlab.runner.load_results`).
        metadata : mapping, optional
            The store's metadata; its ``detection`` entry is the rule every job is judged by.
        alpha : float
            1 - confidence level of the intervals.
        paper : bool
            Compute the paper's figures from its data (:func:`faultlab.stats.paper_table`) with
            the same rule, to compare with.
        paper_raw, paper_reported : path, optional
            The paper's data; default ``paper_repro/`` (:func:`faultlab.stats.resolve_data_path`).
        rep : int, optional
            The SLAM repetition shown in Table II's RMS cells; default the smallest stored.
        parameters : sequence of str, optional
            Predictors of the parameter effects (:func:`faultlab.stats.fit_effects`); default all.
        metric : {"rms", "emd", "ate"}, optional
            The metric of the per-case verdicts; default the experiment's
            (:func:`faultlab.stats.metadata.judged_metric`).

        Raises
        ------
        ResultsError
            No rows, no rows of repetition ``rep``, a missing column, an invalid stored rule, or
            ``metric`` not recorded by the campaign (its ``metrics`` option).
        ConfigError
            ``alpha`` outside (0, 1) or an unknown parameter.
        """
        _check_input(results, alpha)
        metadata = _json_shaped(dict(metadata or {}))
        metric = judged_metric(metadata, metric)
        rep = _shown_repetition(results, rep)
        parameters = None if parameters is None else validate_parameters(parameters)
        rule, stored = read_rule(metadata)
        pairs = outcomes(results, rule=rule)  # every faulty job classified, once
        # The paper's protocol judges one SLAM pair per case: its tables (Table II's rates, "by Suite",
        # Fisher comparisons, parameter effects) take the shown repetition only, so that they do not
        # change with K; the K repetitions enter the case-level verdicts.  The A/A replica is no fault:
        # its flags are the false alarms, reported apart.
        shown = pairs[(pairs["rep"].astype(int) == rep) & (pairs["fault"] != REPLICA)]
        rates = tabulate_rates(shown, alpha=alpha)
        equivalent = tuple(find_identical_faults(pairs[pairs["fault"] != REPLICA]))
        paper_tab, paper_note = _paper(paper, paper_raw, paper_reported, rule=rule, alpha=alpha)
        cases = case_table(results)
        coverage, coverage_note = _coverage(cases, metadata)
        beyond, beyond_notes = _beyond_the_paper(results, shown, rates, rule=rule, alpha=alpha,
                                                 parameters=parameters, n_reps=results["rep"].nunique())
        by_case, case_notes = _case_tables(results, pairs, metadata, rule=rule, alpha=alpha, paper=paper_tab,
                                           cases=cases, parameters=parameters, metric=metric)
        effects, effects_note = _guarded(
            CAMPAIGN_EFFECTS, lambda: campaign_effects(results, metric=metric, rule=rule, alpha=alpha),
            "Continuous effects", (FaultlabError, ValueError, np.linalg.LinAlgError))
        notes = (_rule_notes(metadata, stored, rule, metric) + _equivalence_notes(equivalent) + [paper_note]
                 + _completeness_notes(metadata, len(results)) + [coverage_note] + beyond_notes + case_notes
                 + [effects_note])
        return cls(
            rule=rule, alpha=float(alpha), rep=rep, parameters=parameters, metadata=metadata,
            equivalent_faults=equivalent,
            paper_raw=None if paper_tab is None else data_label(paper_tab.raw_path),
            paper_reported=None if paper_tab is None else data_label(paper_tab.reported_path),
            notes=tuple(n for n in notes if n is not None),
            cases=cases,
            detection_rates=detection_rate_table(rates, None if paper_tab is None else paper_tab.rates),
            by_suite=BY_SUITE.conform(tabulate_by_suite(shown, alpha=alpha)),
            coverage=coverage,
            runtimes=runtime_table(results),
            campaign_effects=effects,
            **_per_source_tables(results, pairs, paper_tab, rep=rep),
            **beyond,
            **by_case,
        )

    # ------------------------------------------------------------------ derived views

    @property
    def has_paper(self) -> bool:
        """Whether the paper's figures were computed (its data was found)."""
        return self.paper_raw is not None

    @property
    def this_run_jobs(self) -> pd.DataFrame:
        """The rows of :attr:`jobs` of the analysed campaign."""
        return self.jobs[self.jobs["source"] == THIS_RUN]

    @property
    def n_rows(self) -> int:
        """Result rows (jobs) of the analysed campaign."""
        return len(self.this_run_jobs)

    @property
    def n_reps(self) -> int:
        """Distinct SLAM repetitions in the results."""
        return int(self.this_run_jobs["rep"].nunique())

    @property
    def status_counts(self) -> dict[str, int]:
        """Jobs per status (ok, crash, timeout), every status listed."""
        counts = self.this_run_jobs["status"].value_counts()
        return {s.value: int(counts.get(s.value, 0)) for s in JobStatus}

    @property
    def cases_per_run(self) -> dict[str, int]:
        """Per suite (Table II order), the largest number of cases it has in one run."""
        per = self.cases.groupby(["suite", "run"]).size().groupby("suite").max()
        return {s: int(per[s]) for s in ordered(per.index, SUITE_ORDER)}

    @property
    def expected_jobs(self) -> int | None:
        """Jobs of the complete campaign, from the stored experiment (None if it does not say)."""
        return count_expected_jobs(self.metadata)

    @property
    def paper_table(self) -> PaperTable | None:
        """The paper's Table II as :func:`faultlab.stats.paper_table` gives it (None without paper data)."""
        if not self.has_paper:
            return None
        jobs = self.jobs[self.jobs["source"] == PAPER]
        results = jobs[["run", "suite", "case", "variant", "rep", "rms_mm", "status"]].reset_index(drop=True)
        oc = self.outcomes[self.outcomes["source"] == PAPER].drop(columns="source").reset_index(drop=True)
        return PaperTable(rule=self.rule, results=results, outcomes=oc, rates=self.paper_rates,
                          by_suite=self.paper_by_suite, raw_path=self.paper_raw, reported_path=self.paper_reported)

    def notes_on(self, *topics: str) -> tuple[Note, ...]:
        """The notes on any of ``topics``."""
        return tuple(n for n in self.notes if n.topic in topics)

    def table(self, name: str) -> pd.DataFrame:
        """The table called ``name`` (a :data:`~faultlab.analysis.schema.TABLES` name)."""
        if name not in _TABLE_NAMES:
            raise KeyError(f"an Analysis has no table {name!r}; tables: {', '.join(_TABLE_NAMES)}")
        return getattr(self, name)

    def equals(self, other: "Analysis") -> bool:
        """Same scalars, metadata, notes and tables (NaN equal to NaN, dtypes included)."""
        if not isinstance(other, Analysis):
            return False
        return (self._scalars() == other._scalars()
                and all(getattr(self, s.name).equals(getattr(other, s.name)) for s in TABLES))

    # ------------------------------------------------------------------ saving

    def save(self, directory: str | Path) -> Path:
        """Write one CSV per table and :data:`JSON_FILE` into ``directory`` (created); returns it."""
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        for schema in TABLES:
            schema.to_csv(getattr(self, schema.name), directory / f"{schema.name}.csv")
        text = json.dumps(self._scalars(), indent=1, sort_keys=True, allow_nan=True)
        (directory / JSON_FILE).write_text(text + "\n", encoding="utf-8")
        return directory

    @classmethod
    def load(cls, directory: str | Path) -> "Analysis":
        """Read an Analysis written by :meth:`save`.

        A table added to the saved form after ``directory`` was written (``campaign_effects``) loads
        empty, with a :class:`Note` under its name saying so.

        Raises
        ------
        ResultsError
            Missing or malformed files (names the file).
        """
        directory = Path(directory)
        path = directory / JSON_FILE
        try:
            data = json.loads(path.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise ResultsError(f"{path}: cannot read a saved analysis ({exc})") from exc
        if not isinstance(data, dict) or data.get("format") != FORMAT_VERSION:
            raise ResultsError(f"{path}: not a saved analysis of format {FORMAT_VERSION}")
        try:
            scalars = dict(
                rule=DetectionRule(**data["rule"]), alpha=float(data["alpha"]), rep=int(data["rep"]),
                parameters=None if data["parameters"] is None else tuple(data["parameters"]),
                metadata=_portable_metadata(data["metadata"]), equivalent_faults=tuple(data["equivalent_faults"]),
                # analyses saved with machine paths load with portable names
                paper_raw=None if data["paper_raw"] is None else data_label(data["paper_raw"]),
                paper_reported=None if data["paper_reported"] is None else data_label(data["paper_reported"]),
                notes=tuple(Note(n["topic"], n["text"]) for n in data["notes"]))
        except (KeyError, TypeError, ValueError, FaultlabError) as exc:
            raise ResultsError(f"{path}: malformed saved analysis ({type(exc).__name__}: {exc})") from exc
        tables, later = {}, []
        for s in TABLES:
            path = directory / f"{s.name}.csv"
            if s.name in _LATER_TABLES and not path.exists():  # saved before the table existed
                tables[s.name] = s.empty()
                later.append(Note(s.name, _LATER_TABLES[s.name]))
            else:
                tables[s.name] = s.read_csv(path)
        return cls(**(scalars | {"notes": scalars["notes"] + tuple(later)}), **tables)

    def _scalars(self) -> dict:
        """Everything but the tables, JSON-shaped."""
        return {
            "format": FORMAT_VERSION,
            "rule": self.rule.to_dict(),
            "alpha": self.alpha,
            "rep": self.rep,
            "parameters": None if self.parameters is None else list(self.parameters),
            "metadata": _portable_metadata(self.metadata),  # what is saved names no machine path
            "equivalent_faults": list(self.equivalent_faults),
            "paper_raw": self.paper_raw,
            "paper_reported": self.paper_reported,
            "notes": [{"topic": n.topic, "text": n.text} for n in self.notes],
        }


_TABLE_NAMES = tuple(s.name for s in TABLES)
#: Tables added to the saved form after its format version: a directory saved before one existed loads
#: with that table empty and this note under its name.
_LATER_TABLES: dict[str, str] = {
    "campaign_effects": "Continuous effects: not available (this analysis was saved before they were part of it; "
                        "analyse the results store again to compute them).",
    "campaign_verdicts": "Campaign-level verdicts: not available (this analysis was saved before they were part "
                         "of it; analyse the results store again to compute them)."}
assert set(_TABLE_NAMES) <= {f.name for f in fields(Analysis)}, "every table of the schema is an Analysis field"


def analyse(results_dir: str | Path, *, alpha: float = DEFAULT_ALPHA, paper: bool = True,
            paper_raw: str | Path | None = None, paper_reported: str | Path | None = None,
            rep: int | None = None, parameters: Sequence[str] | None = None,
            metric: str | None = None) -> Analysis:
    """Analyse the results store of a campaign (:meth:`Analysis.from_frame` of its rows and metadata).

    Parameters
    ----------
    results_dir : path
        Output directory of :func:`faultlab.runner.run_experiment` (or its results.sqlite).
    alpha, paper, paper_raw, paper_reported, rep, parameters, metric
        As for :meth:`Analysis.from_frame`.

    Raises
    ------
    ResultsError
        No results store at ``results_dir``, or it holds no rows.
    """
    metadata = load_metadata(results_dir)
    results = load_results(results_dir)
    if results.empty:
        raise ResultsError(f"the results store at {results_dir} holds no rows yet: nothing to analyse")
    return Analysis.from_frame(results, metadata, alpha=alpha, paper=paper, paper_raw=paper_raw,
                               paper_reported=paper_reported, rep=rep, parameters=parameters,
                               metric=metric)


# --------------------------------------------------------------------------- parts of from_frame

_EQUIVALENT_NOTE = ("{}: every result is identical to the baseline's, so in this campaign the fault never "
                    "changed the SLAM's output (an equivalent mutant here); its 0 % detection rate says nothing "
                    "about the suites. Check it with `python -m faultlab faults --check`.")


def _json_shaped(value):
    """``value`` as JSON gives it back (tuples become lists, numpy scalars Python numbers)."""
    def default(v):
        if isinstance(v, np.generic):
            return v.item()
        if isinstance(v, Path):
            return str(v)
        raise TypeError(f"metadata value {v!r} ({type(v).__name__}) cannot be saved as JSON")

    return json.loads(json.dumps(value, default=default, allow_nan=True))


def _portable_metadata(metadata: dict) -> dict:
    """``metadata`` with its store ``path`` free of machine paths.

    An absolute path becomes relative to the working directory when it lies below it, else its
    last two parts (``<results directory>/results.sqlite``).
    """
    path = metadata.get("path")
    if not isinstance(path, str) or not Path(path).is_absolute():
        return metadata
    p = Path(path)
    try:
        portable = p.relative_to(Path.cwd())
    except ValueError:
        portable = Path(*p.parts[-2:])
    return metadata | {"path": portable.as_posix()}


def _check_input(results: pd.DataFrame, alpha: float) -> None:
    if not (isinstance(alpha, float | int) and 0 < alpha < 1):
        raise ConfigError(f"analysis: alpha must lie in (0, 1), got {alpha!r}")
    if results is None or len(results) == 0:
        raise ResultsError("the results hold no rows: nothing to analyse")


def _shown_repetition(results: pd.DataFrame, rep: int | None) -> int:
    """The SLAM repetition Table II shows: ``rep``, by default the smallest stored."""
    reps = sorted(set(results["rep"].astype(int)))
    rep = reps[0] if rep is None else int(rep)
    if rep not in reps:
        raise ResultsError(f"no results for SLAM repetition {rep}; the store has {reps}")
    return rep


def _per_source_tables(results: pd.DataFrame, pairs: pd.DataFrame, paper: PaperTable | None, *,
                       rep: int) -> dict[str, pd.DataFrame]:
    """Tables with rows of this run and of the paper (``source``), and the paper's own figures."""
    jobs = [job_table(results, source=THIS_RUN)]
    oc = [outcome_table(pairs, source=THIS_RUN)]
    cells = [table2_cell_table(results, pairs, source=THIS_RUN, rep=rep)]
    if paper is not None:
        jobs.append(job_table(paper.results, source=PAPER))
        oc.append(outcome_table(paper.outcomes, source=PAPER))
        cells.append(table2_cell_table(paper.results, paper.outcomes, source=PAPER, rep=0))
    return {
        "jobs": JOBS.conform(pd.concat(jobs, ignore_index=True)),
        "outcomes": OUTCOMES.conform(pd.concat(oc, ignore_index=True)),
        "table2_cells": TABLE2_CELLS.conform(pd.concat(cells, ignore_index=True)),
        "paper_rates": PAPER_RATES.empty() if paper is None else PAPER_RATES.conform(paper.rates),
        "paper_by_suite": PAPER_BY_SUITE.empty() if paper is None else PAPER_BY_SUITE.conform(paper.by_suite),
    }


def _case_tables(results: pd.DataFrame, rms_pairs: pd.DataFrame, metadata: Mapping, *, rule: DetectionRule,
                 alpha: float, cases: pd.DataFrame, parameters, metric: str,
                 paper: PaperTable | None) -> tuple[dict, list[Note]]:
    """The case-level tables: verdicts by the stored rule on ``metric``, rates and suite comparisons over
    cases, the A/A false alarms and the two-sample comparison with the paper's printed figures."""
    col = f"{metric}_mm"
    # the paper's thresholds on the campaign's metric (Table II stays on RMS, as in the paper)
    pairs = rms_pairs if metric == "rms" else outcomes(results.assign(rms_mm=results[col]), rule=rule)
    notes = []
    verdicts, v_note = _guarded(CASE_VERDICTS, lambda: rule_verdicts(results, pairs, rule=rule, metric=metric),
                                "Per-case verdicts")
    test = (f"{rule.test_name} over the K repetitions on the {metric.upper()} error, "
            f"Holm within the family '{rule.family}', alpha = {rule.alpha:g}" if rule.statistical else
            f"the paper's thresholds ({rule.abs_mm:g} mm and {100 * rule.rel:g} %) on the {metric.upper()} error "
            f"per repetition, a case detected when a strict majority of its judged repetitions detect")
    faults = verdicts[verdicts["fault"] != REPLICA]
    n_cj = int((faults["verdict"] == "cannot_judge").sum())
    notes.append(Note("verdicts", f"Per-case verdicts by the campaign's rule ({rule.rule}): {test}; a crash "
                                       f"or timeout of the faulty variant alone counts as detected; {n_cj} of "
                                       f"{len(faults)} (case, fault) pairs cannot be judged (baseline failed or too "
                                       f"few pairs) and are counted apart, never as misses."))
    if v_note is not None:
        notes.append(v_note)
    rates, r_note = _guarded(CASE_RATES, lambda: case_rates(faults, alpha=alpha), "Case-level rates")
    sv, s_note = _guarded(SUITE_VERDICTS, lambda: suite_verdicts(results[results["variant"] != REPLICA], alpha=rule.alpha,
                                                                 metric=metric, direction=rule.direction),
                          "Suite-level verdicts")
    cv, cv_note = _guarded(CAMPAIGN_VERDICTS, lambda: campaign_verdicts(results, alpha=rule.alpha, metric=metric,
                                                                        direction=rule.direction),
                           "Campaign-level verdicts")
    cmp, c_note = _guarded(CASE_COMPARISONS, lambda: compare_suites_by_case(faults), "Case-level suite comparisons")
    if c_note is None and (cmp["method"] == "degenerate").any():
        c_note = Note("case_comparisons", f"{int((cmp['method'] == 'degenerate').sum())} degenerate comparison(s) "
                                          "(0/n vs 0/m or n/n vs m/m) carry no information and are left out of the "
                                          "Holm family.")
    if c_note is None and (cmp["method"] == "cluster_bootstrap").any():
        c_note = Note("case_comparisons", "GEE could not fit some comparisons (separation or one cluster): "
                                          "those use a cluster bootstrap over runs (method column).")
    fa, f_note = _guarded(REPLICA_FALSE_ALARMS,
                          lambda: replica_false_alarms(results, pairs, rule=rule, metric=metric, alpha=alpha),
                          "A/A false alarms")
    if f_note is None and fa.empty:
        f_note = Note("replica_false_alarms", f"A/A false alarms: the campaign has no '{REPLICA}' variant; add it "
                                              "(or run `faultlab calibrate`) to measure the rules' false-alarm "
                                              "rates.")
    pc = PAPER_COMPARISONS.empty()
    p_note = None
    if paper is not None and not rates.empty:
        pr = paper.rates.dropna(subset=["reported_pct"])
        printed = pd.DataFrame({"suite": pr["suite"], "fault": pr["fault"], "paper_n": pr["n"].astype(int),
                                "paper_k": (pr["reported_pct"].astype(float) / 100 * pr["n"]).round().astype(int)})
        pc, p_note = _guarded(PAPER_COMPARISONS, lambda: compare_with_paper(printed, rates, alpha=alpha),
                              "Comparison with the paper")
    names = [p for p in PARAMETER_NAMES if f"class_{p}" in cases.columns]  # every Table I parameter, by class
    eff, e_note = _guarded(CLASS_EFFECTS, lambda: fit_class_effects(faults, cases, names), "Class effects",
                           (FaultlabError, ValueError, np.linalg.LinAlgError))
    notes += [n for n in (r_note, s_note, cv_note, c_note, f_note, p_note, e_note) if n is not None]
    tables = {"case_verdicts": verdicts, "case_rates": rates, "suite_verdicts": sv, "campaign_verdicts": cv,
              "case_comparisons": cmp,
              "replica_false_alarms": fa, "paper_comparisons": pc, "class_effects": eff}
    return tables, notes


def _equivalence_notes(equivalent: tuple[str, ...]) -> list[Note]:
    return [Note("equivalent_faults", _EQUIVALENT_NOTE.format(", ".join(equivalent)))] if equivalent else []


def _rule_notes(metadata: Mapping, rule_stored: bool, rule: DetectionRule, metric: str) -> list[Note]:
    notes = []
    if not rule_stored:
        notes.append(Note("rule", f"the results metadata stores no detection rule; the paper's is used "
                                  f"({rule.describe()})."))
    recorded = metrics_note(metadata)
    if recorded is not None:
        notes.append(Note("metric", recorded))
    if metric != "rms":
        used = "the primary metric" if metric == metadata.get("metric") else repr(metric)
        lead = ("the experiment's primary metric is" if metric == metadata.get("metric")
                else "the analysis was asked to judge by")
        notes.append(Note("metric", f"{lead} {metric!r}; Table II and the per-job detection figures use the "
                                    "Kabsch-aligned RMS error, as the paper does; the per-case verdicts, case "
                                    f"rates and case comparisons use {used}."))
    return notes


def _completeness_notes(metadata: Mapping, n_rows: int) -> list[Note]:
    expected = count_expected_jobs(metadata)
    adaptive = adaptive_summary(metadata)
    notes = [Note("campaign", adaptive)] if adaptive else []
    if expected is not None and n_rows < expected:
        notes.append(Note("campaign", f"the campaign is incomplete: {n_rows} of {expected} jobs are stored "
                                      "(resume it with the same command)."))
    return notes


def _paper(wanted: bool, raw, reported, *, rule: DetectionRule, alpha: float) -> tuple[PaperTable | None, Note | None]:
    if not wanted:
        return None, None
    try:
        table = paper_table(resolve_data_path(raw, RAW_CSV), resolve_data_path(reported, REPORTED_CSV),
                            rule=rule, alpha=alpha)
    except ResultsError as exc:
        return None, Note("paper", f"the paper's data was not found, so nothing is compared with it ({exc}).")
    return table, None


def _coverage(cases: pd.DataFrame, metadata: Mapping) -> tuple[pd.DataFrame, Note | None]:
    try:
        space = read_space(metadata)
    except FaultlabError as exc:
        return COVERAGE.empty(), Note("coverage", f"coverage tables left out: the stored parameter space is "
                                                  f"invalid ({exc})")
    return coverage_table(cases, space), None


def _guarded(schema: TableSchema, compute: Callable[[], pd.DataFrame], what: str,
             errors: tuple[type[BaseException], ...] = (FaultlabError,)) -> tuple[pd.DataFrame, Note | None]:
    """A statistic's table, or an empty one and a note naming the error."""
    try:
        return schema.conform(compute()), None
    except errors as exc:
        return schema.empty(), Note(schema.name, f"{what}: not available ({exc}).")


def _beyond_the_paper(results: pd.DataFrame, pairs: pd.DataFrame, rates: pd.DataFrame, *, rule: DetectionRule,
                      alpha: float, parameters, n_reps: int) -> tuple[dict, list[Note]]:
    """False alarms, the oracle, suite comparisons and parameter effects, with a note where one says nothing."""
    fa, fa_note = _guarded(FALSE_ALARMS, lambda: false_alarm_rate(results, rule=rule, alpha=alpha), "False alarms")
    if fa_note is None and int(fa["n_pairs"].sum()) == 0:
        fa_note = Note("false_alarms", f"False alarms of the paper's rule: need at least 2 SLAM repetitions per "
                                       f"case (this run has {n_reps}); run an experiment with repetitions >= 2.")
    needs_reps = Note("oracle", f"Statistical oracle (one-sided Mann-Whitney U over the K repetitions, Holm): "
                                f"needs repetitions >= 2 per case (this run has {n_reps}).")
    if n_reps < 2:  # one value per side: nothing to test
        orc, orc_note = ORACLE.empty(), needs_reps
    else:
        orc, orc_note = _guarded(ORACLE, lambda: oracle_detections(results, alpha=alpha), "Statistical oracle")
        tested = orc[orc["p"].notna()]
        if orc_note is None and (tested.empty or int(tested["n_baseline"].max()) < 2):
            orc_note = needs_reps
    cmp, cmp_note = _guarded(SUITE_COMPARISONS, lambda: compare_suite_rates(rates, alpha=alpha), "Suite comparisons")
    if cmp_note is None and n_reps > 1:
        cmp_note = Note("suite_comparisons", f"Suite comparisons (Fisher's exact test), detection rates, 'by Suite' "
                                             f"and parameter effects follow the paper's protocol: one SLAM pair per "
                                             f"case, the shown repetition of the K = {n_reps}; the case-level "
                                             "verdicts use all K repetitions, and their comparisons treat cases as "
                                             "units with runs as clusters.")
    if cmp_note is None and cmp.empty:
        cmp_note = Note("suite_comparisons", "Suite comparisons (Fisher's exact test): no suite pair with usable "
                                             "jobs.")
    eff, eff_note = _guarded(PARAMETER_EFFECTS, lambda: fit_effects(pairs, alpha=alpha, parameters=parameters),
                             "Parameter effects", (FaultlabError, ValueError, np.linalg.LinAlgError))
    if eff_note is None and eff.empty:
        eff_note = Note("parameter_effects", "Parameter effects: no faulty jobs.")
    tables = {"false_alarms": fa, "oracle": orc, "oracle_summary": oracle_summary_table(orc),
              "suite_comparisons": cmp, "parameter_effects": eff}
    return tables, [n for n in (fa_note, orc_note, cmp_note, eff_note) if n is not None]
