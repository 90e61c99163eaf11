"""The tables of an Analysis that arrange results and statistics (one function per table).

Each function returns a frame with exactly its :mod:`faultlab.analysis.schema` columns.  The
statistics themselves come from :mod:`faultlab.stats`; these functions pick, join and count.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from faultlab.analysis.schema import (
    ALL_VARIANTS,
    CASES,
    COVERAGE,
    DETECTION_RATES,
    JOBS,
    ORACLE_SUMMARY,
    OUTCOMES,
    RUNTIMES,
    TABLE2_CELLS,
)
from faultlab.space import CaseSpec, ParameterSpace, coverage
from faultlab.space.case import PARAMETER_NAMES, VALUE_KEYS
from faultlab.vocabulary import BASELINE, PAPER_FAULTS, SUITE_ORDER, JobStatus, Outcome, ordered

__all__ = ["job_table", "case_table", "outcome_table", "detection_rate_table", "table2_cell_table",
           "oracle_summary_table", "coverage_table", "runtime_table", "case_spec"]

_CELL_KEY = ["suite", "variant", "run", "case"]


def job_table(results: pd.DataFrame, *, source: str) -> pd.DataFrame:
    """:data:`~faultlab.analysis.schema.JOBS` rows of ``results`` (missing EMD / runtime: NaN)."""
    frame = results.assign(source=source)
    for column in ("emd_mm", "runtime_s"):
        if column not in frame.columns:
            frame[column] = np.nan
    return JOBS.conform(frame)


def case_table(results: pd.DataFrame) -> pd.DataFrame:
    """:data:`~faultlab.analysis.schema.CASES`: one row per (run, suite, case), from its first job."""
    cases = results.drop_duplicates(["run", "suite", "case"])
    order = {s: i for i, s in enumerate(ordered(cases["suite"], SUITE_ORDER))}
    cases = cases.assign(_suite=cases["suite"].map(order)).sort_values(["run", "_suite", "case"], kind="stable")
    return CASES.conform(cases)


def outcome_table(pairs: pd.DataFrame, *, source: str) -> pd.DataFrame:
    """:data:`~faultlab.analysis.schema.OUTCOMES` rows of :func:`faultlab.stats.outcomes`' table."""
    return OUTCOMES.conform(pairs.assign(source=source))


def detection_rate_table(rates: pd.DataFrame, paper_rates: pd.DataFrame | None) -> pd.DataFrame:
    """:data:`~faultlab.analysis.schema.DETECTION_RATES`: this run's rates, the paper's beside.

    Parameters
    ----------
    rates : DataFrame
        :func:`faultlab.stats.tabulate_rates` of this run.
    paper_rates : DataFrame or None
        :attr:`faultlab.stats.PaperTable.rates`; its ``detected, n, rate, reported_pct`` become
        ``paper_k, paper_n, paper_rate, paper_printed_pct`` (missing where the paper has no
        such row, or no paper data is given).
    """
    frame = rates.rename(columns={"fault": "variant"})
    if paper_rates is None:
        paper = pd.DataFrame(columns=["suite", "variant", "paper_k", "paper_n", "paper_rate", "paper_printed_pct"])
    else:
        paper = pd.DataFrame({"suite": paper_rates["suite"], "variant": paper_rates["fault"],
                              "paper_k": paper_rates["detected"], "paper_n": paper_rates["n"],
                              "paper_rate": paper_rates["rate"], "paper_printed_pct": paper_rates["reported_pct"]})
    frame = frame.merge(paper.astype({"suite": object, "variant": object}), on=["suite", "variant"], how="left")
    return DETECTION_RATES.conform(frame)


def table2_cell_table(results: pd.DataFrame, pairs: pd.DataFrame, *, source: str, rep: int) -> pd.DataFrame:
    """:data:`~faultlab.analysis.schema.TABLE2_CELLS` of SLAM repetition ``rep``.

    Parameters
    ----------
    results : DataFrame
        Every job (baseline and faulty) of one source.
    pairs : DataFrame
        :func:`faultlab.stats.outcomes` of ``results``.
    """
    jobs = results[results["rep"] == rep]
    cells = jobs[_CELL_KEY + ["rms_mm", "status"]].copy()
    cells["rms_mm"] = np.where(cells["status"] == JobStatus.OK.value, cells["rms_mm"], np.nan)
    hit = pairs.loc[pairs["rep"] == rep, ["suite", "fault", "run", "case"]].rename(columns={"fault": "variant"})
    hit["detected"] = (pairs.loc[pairs["rep"] == rep, "outcome"] == Outcome.DETECTED.value).to_numpy()
    cells = cells.merge(hit, on=_CELL_KEY, how="left")
    cells["detected"] = cells["detected"].astype("boolean").fillna(False).astype(bool)
    return TABLE2_CELLS.conform(cells.assign(source=source))


def oracle_summary_table(oracle: pd.DataFrame) -> pd.DataFrame:
    """:data:`~faultlab.analysis.schema.ORACLE_SUMMARY` of :func:`faultlab.stats.oracle_detections`."""
    if oracle.empty:
        return ORACLE_SUMMARY.empty()
    g = oracle.groupby(["suite", "fault"], sort=False)
    summary = pd.DataFrame({
        "n_cases": g.size(),
        "n_tested": g["p"].count(),
        "n_detected": g["detected"].sum(),
        "min_p_min": g["p_min"].min(),
        "min_p_holm": g["p_holm"].min(),
    }).reset_index()
    return ORACLE_SUMMARY.conform(summary)


def case_spec(row) -> CaseSpec:
    """The :class:`~faultlab.space.CaseSpec` of a :data:`~faultlab.analysis.schema.CASES` row."""
    values = {k: (str(row[k]) if k == "directionality" else float(row[k])) for k in VALUE_KEYS}
    classes = {p: int(row[f"class_{p}"]) for p in PARAMETER_NAMES}
    return CaseSpec(values=values, classes=classes)


def coverage_table(cases: pd.DataFrame, space: ParameterSpace) -> pd.DataFrame:
    """:data:`~faultlab.analysis.schema.COVERAGE` of every run's suites, and pooled over the runs.

    Every case's values are classified against ``space`` (Sec. V), so the classes recorded
    in the results are not trusted.  Rows of one run (``run``), then of all runs pooled
    (``run`` missing) when there is more than one run.
    """
    runs = sorted(int(r) for r in cases["run"].unique())
    groups = [(run, cases[cases["run"] == run]) for run in runs]
    if len(runs) > 1:
        groups.append((pd.NA, cases))
    parts = []
    for run, sub in groups:
        for suite in ordered(sub["suite"], SUITE_ORDER):
            specs = [case_spec(row) for row in sub[sub["suite"] == suite].to_dict("records")]
            parts.append(coverage(specs, space).table().assign(run=run, suite=suite))
    if not parts:
        return COVERAGE.empty()
    return COVERAGE.conform(pd.concat(parts, ignore_index=True))


def runtime_table(results: pd.DataFrame) -> pd.DataFrame:
    """:data:`~faultlab.analysis.schema.RUNTIMES`: per variant (baseline, paper faults, others) and
    over every job (:data:`~faultlab.analysis.schema.ALL_VARIANTS`)."""
    rows = []
    variants = ordered(results["variant"].astype(str), (BASELINE,) + PAPER_FAULTS)
    for variant, jobs in [(v, results[results["variant"] == v]) for v in variants] + [(ALL_VARIANTS, results)]:
        rt = jobs["runtime_s"].astype(float)
        rows.append({"variant": variant, "n_jobs": len(rt), "median_s": rt.median(), "max_s": rt.max(),
                     "total_s": rt.sum()})
    return RUNTIMES.conform(pd.DataFrame(rows))
