"""How close a campaign's map errors are to the paper's: its RMS distributions against the raw data.

For every suite and variant of Table II, the RMS errors of this campaign (one value per run and
case, repetition ``rep``, jobs that finished) are compared with the paper's raw RMS errors
(``paper_repro/paper_table2_rms.csv``: 3 runs x 5 cases = 15 values per cell).

The test is the two-sided Mann-Whitney U test (:func:`scipy.stats.mannwhitneyu`, exact p-values
when both samples are small and untied).  Map errors span orders of magnitude within one cell
(the paper's systematic baseline runs from 40 mm to 5.6 m), so a rank test that asks whether one
sample tends to be larger than the other fits the question "are the errors of the same size"
without assuming a distribution.  The alternatives fit worse with 15 against 15 values: the
two-sample Kolmogorov-Smirnov statistic takes few distinct values, so its p-values are coarse and
it has less power against a shift in size; scipy's Anderson-Darling k-sample p-values are clipped
to [0.001, 0.25], which breaks a multiplicity correction.

The size of a difference is the ratio of the medians, this run's over the paper's, with a
percentile bootstrap interval (each sample resampled on its own, ``n_boot`` times, from an
explicit ``rng``).  The verdict of a cell, with ``alpha`` and ``factor`` stated in the result:

- **differs** when the Holm-adjusted p-value (over every cell of the table) is below ``alpha``;
- **reproduced** when it does not differ, both samples have at least ``min_n`` values (a bootstrap of
  fewer says little) *and* the ratio's interval lies within [1 / ``factor``, ``factor``]: the
  medians agree within that factor at the stated confidence;
- **inconclusive** otherwise: no difference shown, but the data allow one larger than ``factor``.

``paper_median_in_ci`` says whether the paper's median lies within the bootstrap interval of this
run's median: the figures of Table II this run reproduces within its own uncertainty.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import Mapping

import numpy as np
import pandas as pd
from scipy.stats import mannwhitneyu

from faultlab.analysis.bundle import TableBundle
from faultlab.analysis.schema import TableSchema
from faultlab.errors import ConfigError, ResultsError
from faultlab.runner.store import load_metadata, load_results
from faultlab.inference.intervals import bootstrap_medians
from faultlab.inference.multiplicity import holm
from faultlab.stats.paper import RAW_CSV, load_paper_raw, resolve_data_path
from faultlab.vocabulary import BASELINE, DEFAULT_ALPHA, PAPER_FAULTS, PAPER_PROTOCOL, SUITE_ORDER, JobStatus

__all__ = ["Verdict", "Fidelity", "FIDELITY", "FIDELITY_CSV", "FIDELITY_JSON", "DEFAULT_FACTOR",
           "DEFAULT_N_BOOT", "DEFAULT_MIN_N", "compare_distributions", "compare_with_paper", "fidelity"]

#: Default factor of the "reproduced" verdict: the medians' ratio interval within [1/2, 2].
DEFAULT_FACTOR = 2.0
#: Default smallest sample (each side) a "reproduced" verdict needs.
DEFAULT_MIN_N = 5
#: Default bootstrap resamples.
DEFAULT_N_BOOT = 4000
#: The metadata file under a report or analysis directory (the table is ``<FIDELITY.name>.csv``).
FIDELITY_JSON = "fidelity.json"


class Verdict(StrEnum):
    """The verdict of one cell (see the module docstring for the rule)."""

    REPRODUCED = "reproduced"
    DIFFERS = "differs"
    INCONCLUSIVE = "inconclusive"


#: One row per suite and variant of Table II.
FIDELITY = TableSchema(
    "fidelity",
    "per suite and variant: this run's RMS errors against the paper's raw ones (Mann-Whitney U, Holm, "
    "bootstrap ratio of medians)",
    ("suite", "variant", "n", "paper_n", "min_mm", "max_mm", "paper_min_mm", "paper_max_mm", "median_mm",
     "median_low_mm", "median_high_mm", "paper_median_mm", "paper_median_in_ci", "ratio", "ratio_low",
     "ratio_high", "u", "p", "p_holm", "verdict"),
    ("str", "str", "int", "int", "float", "float", "float", "float", "float", "float", "float", "float", "bool",
     "float", "float", "float", "float", "float", "float", "str"))
#: The table's file under a report or analysis directory.
FIDELITY_CSV = f"{FIDELITY.name}.csv"


@dataclass(frozen=True, eq=False)
class Fidelity(TableBundle):
    """This campaign's RMS distributions compared with the paper's raw data (saved as
    ``fidelity.csv`` and ``fidelity.json``, see :class:`~faultlab.analysis.bundle.TableBundle`).

    Attributes
    ----------
    alpha : float
        Family-wise level of the Holm-adjusted tests and 1 - confidence of the intervals.
    factor : float
        The "reproduced" verdict needs the medians' ratio interval within [1/factor, factor].
    min_n : int
        ... and at least ``min_n`` values on each side.
    n_boot : int
        Bootstrap resamples.
    seed : int
        The seed of the bootstrap generator.
    campaign : dict
        What ran: ``profile``, ``fov_bug``, ``n_steps``, ``particles``, ``runs``, ``reduced`` (fewer
        steps, particles or runs than the paper's protocol), from the results' metadata.
    fidelity : DataFrame
        :data:`FIDELITY` columns.
    """

    alpha: float
    factor: float
    min_n: int
    n_boot: int
    seed: int
    campaign: dict
    fidelity: pd.DataFrame

    def cells(self, verdict: Verdict | str) -> pd.DataFrame:
        """The rows with ``verdict``."""
        return self.fidelity[self.fidelity["verdict"] == str(verdict)]

    TABLES = (FIDELITY.name,)
    SCHEMAS = (FIDELITY,)
    META_FILE = FIDELITY_JSON
    WHAT = "fidelity comparison"
    META_FIELDS = {"alpha": float, "factor": float, "min_n": int, "n_boot": int, "seed": int, "campaign": dict}


def _check(alpha: float, factor: float, n_boot: int, min_n: int) -> None:
    if isinstance(min_n, bool) or not isinstance(min_n, int) or min_n < 1:
        raise ConfigError(f"min_n must be a positive integer, got {min_n!r}")
    if not 0.0 < alpha < 1.0:
        raise ConfigError(f"alpha must lie in (0, 1), got {alpha!r}")
    if not factor > 1.0:
        raise ConfigError(f"factor must be greater than 1, got {factor!r}")
    if isinstance(n_boot, bool) or not isinstance(n_boot, int) or n_boot < 100:
        raise ConfigError(f"n_boot must be an integer >= 100, got {n_boot!r}")


def compare_distributions(x, y, *, n_boot: int = DEFAULT_N_BOOT, alpha: float = DEFAULT_ALPHA,
                          rng: np.random.Generator) -> dict:
    """One cell: sample ``x`` (this run) against ``y`` (the paper), without the multiplicity step.

    Parameters
    ----------
    x, y : array_like, shape (n,), (m,)
        Positive map errors, mm; each needs at least one value.
    n_boot : int
    alpha : float
        The intervals are (1 - alpha) percentile intervals.
    rng : numpy.random.Generator
        The bootstrap's only randomness (``x`` is resampled first, then ``y``).

    Returns
    -------
    dict
        ``n, paper_n, min_mm, max_mm, paper_min_mm, paper_max_mm, median_mm, median_low_mm,
        median_high_mm, paper_median_mm, paper_median_in_ci, ratio, ratio_low, ratio_high, u, p``
        (``u`` is scipy's U statistic of ``x``; ``p`` two-sided).
    """
    x = np.asarray(x, dtype=float)
    y = np.asarray(y, dtype=float)
    if x.size == 0 or y.size == 0:
        raise ResultsError("compare_distributions: both samples need at least one value")
    if np.any(~np.isfinite(x)) or np.any(~np.isfinite(y)) or np.any(x <= 0) or np.any(y <= 0):
        raise ResultsError("compare_distributions: map errors must be finite and positive")
    res = mannwhitneyu(x, y, alternative="two-sided")
    mx, my = bootstrap_medians(x, replicates=n_boot, rng=rng), bootstrap_medians(y, replicates=n_boot, rng=rng)
    q = [100 * alpha / 2, 100 * (1 - alpha / 2)]
    lo, hi = np.percentile(mx, q)
    rlo, rhi = np.percentile(mx / my, q)
    py = float(np.median(y))
    return {"n": int(x.size), "paper_n": int(y.size), "min_mm": float(x.min()), "max_mm": float(x.max()),
            "paper_min_mm": float(y.min()), "paper_max_mm": float(y.max()), "median_mm": float(np.median(x)),
            "median_low_mm": float(lo), "median_high_mm": float(hi), "paper_median_mm": py,
            "paper_median_in_ci": bool(lo <= py <= hi), "ratio": float(np.median(x) / py),
            "ratio_low": float(rlo), "ratio_high": float(rhi), "u": float(res.statistic), "p": float(res.pvalue)}


def _verdict(p_holm: float, ratio_low: float, ratio_high: float, n: int, *, alpha: float, factor: float,
             min_n: int) -> Verdict:
    """``n``: the smaller sample's size."""
    if p_holm < alpha:
        return Verdict.DIFFERS
    if n >= min_n and 1.0 / factor <= ratio_low and ratio_high <= factor:
        return Verdict.REPRODUCED
    return Verdict.INCONCLUSIVE


def compare_with_paper(results: pd.DataFrame, paper: pd.DataFrame, *, metadata: Mapping | None = None,
                       alpha: float = DEFAULT_ALPHA, factor: float = DEFAULT_FACTOR, min_n: int = DEFAULT_MIN_N,
                       n_boot: int = DEFAULT_N_BOOT, seed: int = 0, rep: int | None = None) -> Fidelity:
    """Compare every suite and variant both frames have (see the module docstring).

    Parameters
    ----------
    results : DataFrame
        This campaign's rows (:func:`faultlab.runner.load_results`); only ``status == "ok"`` rows of
        repetition ``rep`` (default: the smallest) count.
    paper : DataFrame
        The paper's raw rows (:func:`faultlab.stats.load_paper_raw`).
    metadata : mapping, optional
        The results' metadata (:func:`faultlab.runner.load_metadata`): what ran, for the report.
    alpha, factor, min_n, n_boot : float, float, int, int
        See :class:`Fidelity`.
    seed : int
        Seed of the bootstrap generator (one ``SeedSequence(seed)`` stream, cells in table order).

    Raises
    ------
    ResultsError
        No suite and variant in common.
    ConfigError
        ``alpha``, ``factor``, ``min_n`` or ``n_boot`` out of range.
    """
    _check(alpha, factor, n_boot, min_n)
    ok = results[results["status"] == JobStatus.OK.value]
    if rep is None:
        rep = int(ok["rep"].min()) if len(ok) else 0
    ok = ok[ok["rep"] == rep]
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    rows = []
    suites = [s for s in SUITE_ORDER if s in set(ok["suite"]) and s in set(paper["suite"])]
    for suite in suites:
        for variant in (BASELINE, *PAPER_FAULTS):
            x = ok.loc[(ok["suite"] == suite) & (ok["variant"] == variant), "rms_mm"].to_numpy(float)
            y = paper.loc[(paper["suite"] == suite) & (paper["variant"] == variant), "rms_mm"].to_numpy(float)
            if x.size and y.size:
                rows.append({"suite": suite, "variant": variant,
                             **compare_distributions(x, y, n_boot=n_boot, alpha=alpha, rng=rng)})
    if not rows:
        raise ResultsError("no suite and variant has map errors both in this campaign and in the paper's data")
    table = pd.DataFrame(rows)
    table["p_holm"] = holm(table["p"].to_numpy(), alpha=alpha)[1]
    n = np.minimum(table["n"], table["paper_n"])
    table["verdict"] = [str(_verdict(p, lo, hi, k, alpha=alpha, factor=factor, min_n=min_n))
                        for p, lo, hi, k in zip(table["p_holm"], table["ratio_low"], table["ratio_high"], n)]
    return Fidelity(alpha=float(alpha), factor=float(factor), min_n=int(min_n), n_boot=int(n_boot), seed=int(seed),
                    campaign=_campaign(metadata or {}), fidelity=FIDELITY.conform(table))


def _campaign(metadata: Mapping) -> dict:
    exp = dict(metadata.get("experiment") or {})
    slam = dict(exp.get("slam") or {})
    out = {"source": str(metadata.get("experiment_source", "")),
           "slam": str(slam.get("name", "")),
           "profile": str(slam.get("profile", "reference")) if slam.get("name") == "fastslam" else "",
           "fov_bug": bool(exp.get("fov_bug", False)),
           "n_steps": exp.get("n_steps"), "particles": slam.get("particles"), "runs": exp.get("runs")}
    out["reduced"] = any(isinstance(out[k], int) and out[k] < v for k, v in PAPER_PROTOCOL.items())
    return out


def fidelity(results_dir: str | Path, *, paper_raw: str | Path | None = None, alpha: float = DEFAULT_ALPHA,
             factor: float = DEFAULT_FACTOR, min_n: int = DEFAULT_MIN_N, n_boot: int = DEFAULT_N_BOOT,
             seed: int = 0) -> Fidelity:
    """:func:`compare_with_paper` of a results store and the paper's raw data (default ``paper_repro/``)."""
    metadata = load_metadata(results_dir)
    results = load_results(results_dir)
    if results.empty:
        raise ResultsError(f"the results store at {results_dir} holds no rows yet: nothing to compare")
    paper = load_paper_raw(resolve_data_path(paper_raw, RAW_CSV))
    return compare_with_paper(results, paper, metadata=metadata, alpha=alpha, factor=factor, min_n=min_n,
                              n_boot=n_boot, seed=seed)
