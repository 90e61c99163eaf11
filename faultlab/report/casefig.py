"""Pictures of test cases in the style of the paper's Fig. 5: landmarks orange, true path blue.

Built without pyplot (plain :class:`matplotlib.figure.Figure`), so no GUI
backend or global figure registry is involved.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Sequence

from matplotlib.axes import Axes
from matplotlib.figure import Figure

from faultlab.scenario.model import Scenario

__all__ = ["plot_case", "save_case_png", "plot_suite", "case_title", "LANDMARK_COLOR", "PATH_COLOR"]

LANDMARK_COLOR = "tab:orange"
PATH_COLOR = "tab:blue"


def case_title(scenario: Scenario) -> str:
    """Short description: traversal, map side, landmark count, active + idle steps."""
    v = scenario.case.values
    side = math.sqrt(float(v["map_size"]))
    idle = int(v["inactivity"])
    steps = f"{scenario.n_steps - idle} steps" + (f" + {idle} idle" if idle else "")
    return f"{v['directionality']}, {side:.1f} m, {scenario.landmarks.shape[0]} lm, {steps}"


def plot_case(scenario: Scenario, ax: Axes | None = None, *, title: str | None = None) -> Axes:
    """Draw the landmarks (orange dots) and the true path (blue line) of one case.

    Parameters
    ----------
    scenario : Scenario
    ax : matplotlib Axes, optional
        A new single-axes figure when None.
    title : str, optional
        Defaults to :func:`case_title`.

    Returns
    -------
    Axes
    """
    if ax is None:
        ax = Figure(figsize=(5, 5)).add_subplot()
    lm = scenario.landmarks
    n = max(lm.shape[0], 1)
    size = max(0.5, min(12.0, 4000.0 / n))  # smaller dots for dense maps
    ax.scatter(lm[:, 0], lm[:, 1], s=size, c=LANDMARK_COLOR, linewidths=0, label="landmarks", zorder=3)
    p = scenario.true_poses
    ax.plot(p[:, 0], p[:, 1], color=PATH_COLOR, lw=0.6, label="true path", zorder=2, alpha=0.8)
    ax.plot(p[0, 0], p[0, 1], marker="o", ms=4, color=PATH_COLOR, zorder=4)
    half = math.sqrt(float(scenario.case.values["map_size"])) / 2.0
    pad = 0.05 * half + 0.1
    xlo, xhi = min(-half, p[:, 0].min()) - pad, max(half, p[:, 0].max()) + pad
    ylo, yhi = min(-half, p[:, 1].min()) - pad, max(half, p[:, 1].max()) + pad
    ax.set_xlim(xlo, xhi)
    ax.set_ylim(ylo, yhi)
    ax.set_aspect("equal")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(case_title(scenario) if title is None else title, fontsize=9)
    return ax


def save_case_png(scenario: Scenario, path: str | Path, *, dpi: int = 120) -> Path:
    """Plot one case (:func:`plot_case`) and save it as a PNG; returns the path."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig = Figure(figsize=(5, 5))
    plot_case(scenario, fig.add_subplot())
    fig.tight_layout()
    fig.savefig(path, dpi=dpi, format="png")
    return path


def plot_suite(scenarios: Sequence[Scenario], *, title: str | None = None) -> Figure:
    """All cases of a suite side by side (Fig. 5), one panel per case titled "Case i"."""
    n = max(len(scenarios), 1)
    fig = Figure(figsize=(3.2 * n, 3.6))
    axes = fig.subplots(1, n, squeeze=False)[0]
    for i, (sc, ax) in enumerate(zip(scenarios, axes), start=1):
        plot_case(sc, ax, title=f"Case {i}")
        ax.set_xlabel("")
        ax.set_ylabel("")
    for ax in axes[len(scenarios):]:
        ax.set_axis_off()
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig
