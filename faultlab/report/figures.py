"""Figures of the report (seaborn / matplotlib, no display needed).

Every function returns a :class:`matplotlib.figure.Figure` built without pyplot, so nothing
is kept in pyplot's figure registry and no GUI backend is touched; the caller saves it
(``fig.savefig`` or :mod:`faultlab.report.pdf`).
"""

from __future__ import annotations

import warnings

import numpy as np
import pandas as pd
import seaborn as sns
from matplotlib import MatplotlibDeprecationWarning
from matplotlib.figure import Figure

from faultlab.analysis import Analysis
from faultlab.analysis.schema import PAPER, THIS_RUN
from faultlab.report.tables import order_suites, order_variants, round_mm, suite_label, variant_label

__all__ = ["detection_rate_figure", "draw_detection_rates", "rms_distribution_figure", "suite_palette", "PAGE_SIZE"]

#: A4 landscape, inches.
PAGE_SIZE = (11.69, 8.27)


def suite_palette(suites) -> dict[str, tuple]:
    """One colour per suite (seaborn's colour-blind palette), stable across figures."""
    suites = list(suites)
    fixed_names = ("systematic", "random", "fixed")
    n_other = sum(s not in fixed_names for s in suites)
    base = sns.color_palette("colorblind", max(8, len(fixed_names) + n_other))  # any number of strategies
    fixed = dict(zip(fixed_names, base))
    extra = iter(base[len(fixed_names):])
    return {s: fixed.get(s) or next(extra) for s in suites}


def detection_rate_figure(analysis: Analysis, *, interval: str = "wilson", figsize=PAGE_SIZE) -> Figure:
    """Detection rate per suite x fault, bars with confidence-interval error bars.

    Parameters
    ----------
    analysis : Analysis
        Its detection rates: ``rate`` and the interval columns ``<interval>_low`` /
        ``<interval>_high``, ``k/n`` above each bar, and (with paper data) ``paper_rate`` as a
        black diamond: the paper's rate from its raw data.
    interval : {"wilson", "cp"}
        Which interval to draw (Wilson or Clopper-Pearson).
    """
    fig = Figure(figsize=figsize)
    with sns.axes_style("whitegrid"):  # rc styles apply to axes created inside the context
        ax = fig.add_subplot(1, 1, 1)
    if draw_detection_rates(ax, analysis, interval=interval):
        fig.tight_layout(rect=(0.0, 0.035, 1.0, 1.0))  # room for the page footer
    return fig


def draw_detection_rates(ax, analysis: Analysis, *, interval: str = "wilson") -> bool:
    """Draw :func:`detection_rate_figure`'s bars into ``ax`` (made under seaborn's whitegrid style).

    Returns
    -------
    bool
        False if the run has no faulty variant (``ax`` then says so and is hidden).
    """
    detection = analysis.detection_rates
    conf = round_mm(100 * (1 - analysis.alpha))
    name = {"wilson": "Wilson", "cp": "Clopper-Pearson"}[interval]
    if detection.empty:
        ax.text(0.5, 0.5, "no faulty variant in this run", ha="center", va="center",
                transform=ax.transAxes)
        ax.set_axis_off()
        return False
    suites = order_suites(detection["suite"])
    faults = order_variants(detection["variant"])
    palette = suite_palette(suites)
    width = 0.8 / len(suites)
    ax.grid(axis="x", visible=False)
    ax.set_axisbelow(True)
    paper_label = "paper (rule on its raw data)"
    for i, suite in enumerate(suites):
        x = np.arange(len(faults)) + (i - (len(suites) - 1) / 2) * width
        rows = detection[detection["suite"] == suite].set_index("variant").reindex(faults)
        _draw_suite_bars(ax, x, rows, interval=interval, width=width, colour=palette[suite],
                         label=suite_label(suite))
        if analysis.has_paper and _draw_paper_rates(ax, x, rows, label=paper_label):
            paper_label = None  # one legend entry for every suite's diamonds
    ax.set_xticks(np.arange(len(faults)), [variant_label(f) for f in faults])
    ax.set_ylim(0, 112)
    ax.set_ylabel("cases detecting the fault (%)")
    ax.set_title(f"Detection rate per suite and fault with {conf} % {name} intervals "
                 "(numbers: detecting cases / cases)")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    return True


def _draw_suite_bars(ax, x: np.ndarray, rows: pd.DataFrame, *, interval: str, width: float, colour,
                     label: str) -> None:
    """One suite's bars (rows: one per fault, NaN where absent), error bars and k/n labels."""
    rate = rows["rate"].to_numpy(dtype=float)
    low = rows[f"{interval}_low"].to_numpy(dtype=float)
    high = rows[f"{interval}_high"].to_numpy(dtype=float)
    ax.bar(x, 100 * rate, width=width * 0.92, color=colour, label=label, edgecolor="white")
    err = np.vstack([100 * (rate - low), 100 * (high - rate)])
    ax.errorbar(x, 100 * rate, yerr=np.clip(err, 0, None), fmt="none", ecolor="0.15", elinewidth=1.2, capsize=4)
    for xi, k, n in zip(x, rows["k"], rows["n"]):
        if not pd.isna(n):
            ax.text(xi, 101.5, f"{int(k)}/{int(n)}", ha="center", va="bottom", fontsize=8, color="0.25")


def _draw_paper_rates(ax, x: np.ndarray, rows: pd.DataFrame, *, label: str | None) -> bool:
    """The paper's rates (rule on its raw data) as black diamonds; whether any was drawn."""
    pr = rows["paper_rate"].to_numpy(dtype=float)
    ok = np.isfinite(pr)
    if ok.any():
        ax.scatter(x[ok], 100 * pr[ok], marker="D", s=36, color="black", zorder=5, label=label)
    return bool(ok.any())


def rms_distribution_figure(analysis: Analysis, *, figsize=PAGE_SIZE) -> Figure:
    """RMS map error per suite x variant on a log scale (box plot plus every job as a dot).

    One column per suite; a second row shows the paper's raw data when the analysis has it.
    Crashed and timed-out jobs have no error and are counted under the axis instead.
    """
    jobs = analysis.jobs
    sources = [(source, jobs[jobs["source"] == source]) for source in (THIS_RUN, PAPER)
               if (jobs["source"] == source).any()]
    suites = order_suites(pd.concat([s[1]["suite"] for s in sources]))
    variants = order_variants(pd.concat([s[1]["variant"] for s in sources]))
    fig = Figure(figsize=figsize)
    with sns.axes_style("whitegrid"):
        axes = fig.subplots(len(sources), len(suites), sharey=True, squeeze=False)
    palette = dict(zip(variants, sns.color_palette("deep", len(variants))))
    finite = pd.concat([s[1]["rms_mm"] for s in sources]).to_numpy(dtype=float)
    finite = finite[np.isfinite(finite) & (finite > 0)]
    for r, (source, frame) in enumerate(sources):
        status = frame["status"]
        for c, suite in enumerate(suites):
            ax = axes[r][c]
            sub = frame[(frame["suite"] == suite) & (status == "ok")]
            sub = sub[np.isfinite(sub["rms_mm"].to_numpy(dtype=float)) & (sub["rms_mm"] > 0)]
            ax.set_yscale("log")
            if not sub.empty:
                with warnings.catch_warnings():  # seaborn 0.13 passes matplotlib 3.11's deprecated vert=
                    warnings.simplefilter("ignore", MatplotlibDeprecationWarning)
                    sns.boxplot(data=sub, x="variant", y="rms_mm", order=variants, hue="variant",
                                hue_order=variants, palette=palette, ax=ax, fliersize=0, width=0.6,
                                legend=False, boxprops={"alpha": 0.55})
                sns.stripplot(data=sub, x="variant", y="rms_mm", order=variants, color="0.15",
                              size=3, jitter=0.18, ax=ax)
            failed = frame[(frame["suite"] == suite) & (status != "ok")]
            if not failed.empty:
                counts = failed.groupby("variant").size()
                note = ", ".join(f"{variant_label(v)}: {n}" for v, n in counts.items())
                ax.text(0.5, -0.32, f"crash/timeout - {note}", ha="center", va="top",
                        transform=ax.transAxes, fontsize=7, color="firebrick")
            ax.set_xticks(range(len(variants)), [variant_label(v).replace(" ", "\n")
                                                 for v in variants], fontsize=8)
            ax.set_xlabel("")
            ax.set_ylabel("RMS map error (mm, log)" if c == 0 else "")
            ax.set_title(f"{suite_label(suite)} - {source}", fontsize=10)
            ax.grid(axis="y", which="major", color="0.85")
            if finite.size:
                ax.set_ylim(finite.min() / 1.6, finite.max() * 1.6)
    fig.suptitle("RMS map error per suite and variant (every job a dot)")
    fig.tight_layout(rect=(0.0, 0.035, 1.0, 1.0))  # room for the page footer
    return fig
