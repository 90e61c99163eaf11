"""The repetitions-against-cases report: CSV tables and ``allocation.md`` (:mod:`faultlab.analysis.allocation`)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd

from faultlab.analysis.allocation import analyse_allocation
from faultlab.precision import write_csv
from faultlab.report.mutation import markdown_table

__all__ = ["ALLOCATION_FILES", "allocation_markdown", "write_allocation_report"]

#: Files written by :func:`write_allocation_report`.
ALLOCATION_FILES = ("allocation.csv", "allocation_summary.csv", "allocation_meta.json", "allocation.md")


def _pct(x: float) -> str:
    return f"{100 * x:.0f}"


def _interval(rate: float, lo: float, hi: float) -> str:
    """``rate % (lo-hi)`` with as many decimals (up to 2) as keep a non-zero width visible; a bound
    closer to 0 or 100 % than that is shown as ``<0.01`` / ``>99.99``."""
    digits = 1
    while digits < 2 and hi > lo and f"{100 * lo:.{digits}f}" == f"{100 * hi:.{digits}f}":
        digits += 1
    low = f"{100 * lo:.{digits}f}" if lo == 0 or f"{100 * lo:.{digits}f}" != f"{100 * hi:.{digits}f}" or hi < 1 \
        else ">99.99"
    high = f"{100 * hi:.{digits}f}" if hi == 1 or f"{100 * lo:.{digits}f}" != f"{100 * hi:.{digits}f}" or lo > 0 \
        else "<0.01"
    return f"{_pct(rate)} % ({low}-{high})"


def allocation_markdown(table: pd.DataFrame, summary: pd.DataFrame, meta: dict) -> str:
    """The report: one row per (variant, K) with the exact intervals, then the answer per variant."""
    shown = pd.DataFrame({
        "variant": table["variant"], "K x n": [f"{k} x {n}" for k, n in zip(table["k"], table["n_cases"])],
        "case can reach alpha/n": np.where(table["reachable"], "yes", "no"),
        "single case (strong/pool, 95 % CP)": [f"{s}/{p} ({100 * lo:.1f}-{100 * hi:.1f} %)" for s, p, lo, hi in
                                               zip(table["strong_cases"], table["pool"], table["case_low"],
                                                   table["case_high"])],
        "suite, per-case min (exact, 95 %)": [_interval(r, lo, hi) for r, lo, hi in
                                             zip(table["rate_by_case_exact"], table["by_case_low"],
                                                 table["by_case_high"])],
        "suite, pooled (drawn)": [f"{_pct(r)} %" for r in table["rate_by_pool"]],
        "suite, combined alpha/2 each (drawn)": [f"{_pct(r)} %" for r in table["rate_combined"]]})
    answers = pd.DataFrame({
        "variant": summary["variant"],
        "most detecting K (per-case min)": [f"K = {k}: {_interval(r, lo, hi)}" for k, r, lo, hi in
                                           zip(summary["best_k"], summary["best_rate"], summary["best_low"],
                                               summary["best_high"])],
        "least": [f"K = {k}: {_interval(r, lo, hi)}" for k, r, lo, hi in
                  zip(summary["worst_k"], summary["worst_rate"], summary["worst_low"], summary["worst_high"])],
        "answer": summary["answer"]})
    head = (f"# Repetitions K against cases n at a budget of {meta['budget']} paired executions\n\n"
            f"One pool of {meta['pool']} cases run once at K = {meta['stored_k']} ({meta['n_steps']} steps, "
            f"SLAM {meta['slam']}), judged again on the first K repetitions for K in {meta['ks']}; "
            f"{meta['draws']} suites of n = budget / K cases drawn per allocation (seed {meta['seed']}). "
            f"Per-case test: exact {meta['alternative']} sign-flip; a suite detects by the per-case minimum at "
            f"alpha / n (alpha = {meta['alpha']}), by the pooled sign-flip test over its case mean log ratios at "
            f"alpha, or by both at alpha / 2 each (combined). Per-case-minimum rates are hypergeometric on the pool "
            f"with the exact interval for n generated cases; pooled and combined rates are over drawn suites of "
            f"this pool (Monte Carlo SE <= {table['mc_se'].max():.3f}) and carry no interval over cases.\n\n")
    return (head + "## Detection per allocation\n\n" + markdown_table(shown)
            + "\n## Which allocation detects more (per-case minimum; shown only when the exact intervals are "
              "disjoint)\n\n" + markdown_table(answers))


def write_allocation_report(results: str | Path, reports: str | Path, *, budget: int, ks, draws: int = 2000,
                            seed: int = 0) -> list[Path]:
    """Analyse the store in ``results`` and write :data:`ALLOCATION_FILES` to ``reports``."""
    table, summary, meta = analyse_allocation(results, budget=budget, ks=ks, draws=draws, seed=seed)
    out = Path(reports)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / name for name in ALLOCATION_FILES]
    write_csv(table, paths[0])  # at the tables' precision: 6 digits would print 1 - 1e-10 as 1
    write_csv(summary, paths[1])
    paths[2].write_text(json.dumps(meta, indent=1, allow_nan=False) + "\n")
    paths[3].write_text(allocation_markdown(table, summary, meta))
    return paths
