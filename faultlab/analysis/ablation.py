"""What one difference between the paper's filter and faultlab's choices does to map errors.

An ablation (:data:`faultlab.slam.profiles.ABLATIONS`) runs the same cases with the same SLAM seeds
in two *arms* that differ in one point only: the paper's choice (e.g. the shallow-copy aliasing of
the ``paper`` profile) and faultlab's alternative (e.g. the deep copies of ``paper_no_aliasing``).
Per ablation and variant, the RMS errors of the two arms are paired by (run, suite, case, rep),
jobs that finished in both arms only.

The effect is the paired difference ``paper - alternative`` in mm: its median with a percentile
bootstrap interval (pairs resampled, ``n_boot`` times, from an explicit ``rng``), the median of the
ratios ``paper / alternative``, and how many pairs the paper's choice made larger.  The test is
the two-sided Wilcoxon signed-rank test of the differences (:func:`scipy.stats.wilcoxon`, exact
for small samples without ties or zeros; pairs with a zero difference are dropped as Wilcoxon
proposed, so equal maps count as no evidence either way), Holm-adjusted over the table.  A paired
test uses what the pairing buys: the case and the seed are the same, so the difference is the
point's effect plus the divergence of two particle filters run on different weights or draws.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Mapping, Sequence

import numpy as np
import pandas as pd
from scipy.stats import wilcoxon

from faultlab.analysis.bundle import TableBundle
from faultlab.analysis.fidelity import DEFAULT_N_BOOT
from faultlab.analysis.schema import TableSchema
from faultlab.errors import ConfigError, ResultsError
from faultlab.runner.store import load_metadata, load_results
from faultlab.slam.profiles import ABLATIONS, Ablation
from faultlab.inference.intervals import bootstrap_medians
from faultlab.inference.multiplicity import holm
from faultlab.vocabulary import BASELINE, DEFAULT_ALPHA, PAPER_FAULTS, JobStatus

__all__ = ["AblationResult", "ABLATION", "ABLATION_CSV", "ABLATION_JSON", "KEYS", "paired_effect",
           "compare_arms", "ablation"]

#: The metadata file under a report or analysis directory (the table is ``<ABLATION.name>.csv``).
ABLATION_JSON = "ablation.json"
#: The columns that pair two arms' rows.
KEYS = ("run", "suite", "case", "rep")

#: One row per ablation and variant.
ABLATION = TableSchema(
    "ablation",
    "per row of the paper profile's differences and variant: RMS errors with the paper's choice against "
    "faultlab's alternative on the same cases and seeds (paired; Wilcoxon signed-rank, Holm)",
    ("point", "variant", "paper_arm", "alternative_arm", "n", "n_zero", "paper_median_mm",
     "alternative_median_mm", "diff_median_mm", "diff_low_mm", "diff_high_mm", "ratio_median", "n_larger",
     "p", "p_holm"),
    ("str", "str", "str", "str", "int", "int", "float", "float", "float", "float", "float", "float", "int",
     "float", "float"))
#: The table's file under a report or analysis directory.
ABLATION_CSV = f"{ABLATION.name}.csv"


@dataclass(frozen=True, eq=False)
class AblationResult(TableBundle):
    """The effects of the isolated differences (saved as ``ablation.csv`` and ``ablation.json``, see
    :class:`~faultlab.analysis.bundle.TableBundle`).

    Attributes
    ----------
    alpha : float
        Family-wise level of the Holm adjustment and 1 - confidence of the intervals.
    n_boot : int
    seed : int
        Seed of the bootstrap generator.
    campaign : dict
        What ran: ``n_steps``, ``particles``, ``runs`` (the runs every arm has), ``arm_cases`` (arm
        name -> cases per suite), ``variants`` (those every arm has).
    ablation : DataFrame
        :data:`ABLATION` columns.
    """

    alpha: float
    n_boot: int
    seed: int
    campaign: dict
    ablation: pd.DataFrame

    def row(self, point: str, variant: str) -> pd.Series | None:
        """The row of ``point`` and ``variant``, or None."""
        t = self.ablation[(self.ablation["point"] == point) & (self.ablation["variant"] == variant)]
        return None if t.empty else t.iloc[0]

    TABLES = (ABLATION.name,)
    SCHEMAS = (ABLATION,)
    META_FILE = ABLATION_JSON
    WHAT = "ablation"
    META_FIELDS = {"alpha": float, "n_boot": int, "seed": int, "campaign": dict}


def paired_effect(paper, alternative, *, n_boot: int = DEFAULT_N_BOOT, alpha: float = DEFAULT_ALPHA,
                  rng: np.random.Generator) -> dict:
    """The paired effect of one ablation on one variant (without the multiplicity step).

    Parameters
    ----------
    paper, alternative : array_like, shape (n,)
        RMS errors (mm) of the same cases and seeds, with the paper's choice and with the
        alternative; ``n >= 1``, finite and positive.
    n_boot : int
        Bootstrap resamples of the pairs.
    alpha : float
        The interval of the median difference is a (1 - alpha) percentile interval.
    rng : numpy.random.Generator
        The bootstrap's only randomness.

    Returns
    -------
    dict
        ``n, n_zero, paper_median_mm, alternative_median_mm, diff_median_mm, diff_low_mm, diff_high_mm,
        ratio_median, n_larger, p`` (``p``: two-sided Wilcoxon signed-rank over the non-zero differences;
        1 when there are none).
    """
    a = np.asarray(paper, dtype=float)
    b = np.asarray(alternative, dtype=float)
    if a.shape != b.shape or a.ndim != 1 or a.size == 0:
        raise ResultsError(f"paired_effect: two samples of equal length >= 1 needed, got {a.shape} and {b.shape}")
    if np.any(~np.isfinite(a)) or np.any(~np.isfinite(b)) or np.any(a <= 0) or np.any(b <= 0):
        raise ResultsError("paired_effect: map errors must be finite and positive")
    d = a - b
    nonzero = d[d != 0.0]
    p = 1.0 if nonzero.size == 0 else float(wilcoxon(nonzero, alternative="two-sided").pvalue)
    lo, hi = np.percentile(bootstrap_medians(d, replicates=n_boot, rng=rng), [100 * alpha / 2, 100 * (1 - alpha / 2)])
    return {"n": int(d.size), "n_zero": int(d.size - nonzero.size), "paper_median_mm": float(np.median(a)),
            "alternative_median_mm": float(np.median(b)), "diff_median_mm": float(np.median(d)),
            "diff_low_mm": float(lo), "diff_high_mm": float(hi), "ratio_median": float(np.median(a / b)),
            "n_larger": int(np.sum(d > 0)), "p": p}


def _ok(frame: pd.DataFrame) -> pd.DataFrame:
    return frame[frame["status"] == JobStatus.OK.value]


def compare_arms(arms: Mapping[str, pd.DataFrame], *, ablations: Sequence[Ablation] = ABLATIONS,
                 variants: Sequence[str] = (BASELINE, *PAPER_FAULTS), alpha: float = DEFAULT_ALPHA, n_boot: int = DEFAULT_N_BOOT,
                 seed: int = 0, campaign: Mapping | None = None) -> AblationResult:
    """Pair every ablation's two arms and measure the effect per variant.

    Parameters
    ----------
    arms : mapping of str to DataFrame
        Result rows (:func:`faultlab.runner.load_results` columns) per arm name
        (:attr:`faultlab.slam.profiles.Arm.name`).  An ablation with an arm missing is left out.
    ablations : sequence of Ablation
    variants : sequence of str
        The variants compared, in this order (those with no pair in both arms are left out).
    alpha, n_boot, seed
        See :class:`AblationResult`; one ``SeedSequence(seed)`` stream, rows in table order.
    campaign : mapping, optional
        What ran, for the report.

    Raises
    ------
    ResultsError
        No ablation has a pair of finished jobs.
    ConfigError
        ``alpha`` or ``n_boot`` out of range.
    """
    if not 0.0 < alpha < 1.0:
        raise ConfigError(f"alpha must lie in (0, 1), got {alpha!r}")
    if isinstance(n_boot, bool) or not isinstance(n_boot, int) or n_boot < 100:
        raise ConfigError(f"n_boot must be an integer >= 100, got {n_boot!r}")
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    rows = []
    for ab in ablations:
        if ab.paper.name not in arms or ab.alternative.name not in arms:
            continue
        left, right = _ok(arms[ab.paper.name]), _ok(arms[ab.alternative.name])
        for variant in variants:
            pairs = pd.merge(left.loc[left["variant"] == variant, [*KEYS, "rms_mm"]],
                             right.loc[right["variant"] == variant, [*KEYS, "rms_mm"]],
                             on=list(KEYS), suffixes=("_paper", "_alternative"))
            if pairs.empty:
                continue
            rows.append({"point": ab.point, "variant": variant, "paper_arm": ab.paper.name,
                         "alternative_arm": ab.alternative.name,
                         **paired_effect(pairs["rms_mm_paper"].to_numpy(), pairs["rms_mm_alternative"].to_numpy(),
                                         n_boot=n_boot, alpha=alpha, rng=rng)})
    if not rows:
        raise ResultsError("no ablation has a case that finished in both of its arms")
    table = pd.DataFrame(rows)
    table["p_holm"] = holm(table["p"].to_numpy(), alpha=alpha)[1]
    return AblationResult(alpha=float(alpha), n_boot=int(n_boot), seed=int(seed), campaign=dict(campaign or {}),
                          ablation=ABLATION.conform(table))


def ablation(arm_dirs: Mapping[str, str | Path], *, ablations: Sequence[Ablation] = ABLATIONS, alpha: float = DEFAULT_ALPHA,
             n_boot: int = DEFAULT_N_BOOT, seed: int = 0) -> AblationResult:
    """:func:`compare_arms` of the results stores of the arms (arm name -> results directory)."""
    arms = {name: load_results(d) for name, d in arm_dirs.items()}
    campaign: dict = {}
    for name, d in arm_dirs.items():
        exp = dict(load_metadata(d).get("experiment") or {})
        slam = dict(exp.get("slam") or {})
        runs = sorted({int(r) for r in arms[name]["run"]})
        campaign.setdefault("n_steps", exp.get("n_steps"))
        campaign.setdefault("particles", slam.get("particles"))
        campaign.setdefault("arm_cases", {})[name] = dict(exp.get("suites") or {})
        campaign["runs"] = min(campaign.get("runs", len(runs)), len(runs))
        have = set(arms[name]["variant"])
        campaign["variants"] = [v for v in campaign.get("variants", exp.get("variants") or []) if v in have]
    return compare_arms(arms, ablations=ablations, alpha=alpha, n_boot=n_boot, seed=seed, campaign=campaign)
