"""Report figures: what is drawn matches the numbers they are drawn from."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.figure import Figure

from faultlab.analysis import Analysis
from faultlab.report.figures import detection_rate_figure, rms_distribution_figure, suite_palette

from .conftest import make_results


def analysed(results, *, paper=False) -> Analysis:
    return Analysis.from_frame(results, paper=paper)


def _bars(ax):
    return [p for p in ax.patches if p.get_width() > 0]


def test_detection_bars_and_error_bars_follow_the_rates(synthetic_results):
    a = analysed(synthetic_results)
    det = a.detection_rates
    n_before = len(plt.get_fignums())
    fig = detection_rate_figure(a)
    assert isinstance(fig, Figure)
    assert len(plt.get_fignums()) == n_before  # nothing registered with pyplot
    ax = fig.axes[0]
    bars = _bars(ax)
    assert len(bars) == len(det)  # 3 suites x 3 faults
    heights = sorted(b.get_height() for b in bars)
    np.testing.assert_allclose(heights, sorted(100 * det["rate"].to_numpy()))
    # error bars: one vertical segment per bar from the Wilson low to the Wilson high bound
    segs = [seg for coll in ax.collections if hasattr(coll, "get_segments")
            for seg in coll.get_segments()]
    spans = sorted((round(s[0][1], 6), round(s[1][1], 6)) for s in segs if len(s) == 2)
    expected = sorted((round(100 * lo, 6), round(100 * hi, 6))
                      for lo, hi in zip(det["wilson_low"], det["wilson_high"]))
    assert spans == expected
    labels = [t.get_text() for t in ax.get_xticklabels()]
    assert labels == ["Naive Resampling", "Faulty Rotation", "Sign Error"]
    texts = {t.get_text() for t in ax.texts}
    assert {"1/2", "2/2", "0/2"} <= texts  # k/n above each bar


def test_clopper_pearson_bars_can_be_chosen(synthetic_results):
    a = analysed(synthetic_results)
    det = a.detection_rates
    ax = detection_rate_figure(a, interval="cp").axes[0]
    segs = [seg for coll in ax.collections if hasattr(coll, "get_segments")
            for seg in coll.get_segments()]
    lows = sorted(round(s[0][1], 6) for s in segs)
    np.testing.assert_allclose(lows, sorted(100 * det["cp_low"].to_numpy()), atol=1e-6)
    assert "Clopper-Pearson" in ax.get_title()


def test_paper_rates_are_drawn_as_markers(synthetic_results):
    a = analysed(synthetic_results, paper=True)
    det = a.detection_rates
    ax = detection_rate_figure(a).axes[0]
    offsets = np.vstack([c.get_offsets() for c in ax.collections if c.get_offsets().size and
                         not hasattr(c, "get_segments")])
    np.testing.assert_allclose(sorted(offsets[:, 1]), sorted(100 * det["paper_rate"].to_numpy()))
    assert "paper (rule on its raw data)" in [t.get_text() for t in ax.get_legend().get_texts()]


def test_empty_detection_frame_gives_a_message(synthetic_results):
    baseline_only = synthetic_results[synthetic_results["variant"] == "baseline"]
    a = analysed(baseline_only)
    assert a.detection_rates.empty
    fig = detection_rate_figure(a)
    assert "no faulty variant" in fig.axes[0].texts[0].get_text()


def test_rms_distributions_log_scale_one_panel_per_suite(synthetic_results):
    fig = rms_distribution_figure(analysed(synthetic_results))
    axes = fig.axes
    assert len(axes) == 3
    assert all(ax.get_yscale() == "log" for ax in axes)
    assert [ax.get_title() for ax in axes] == ["Systematic - this run", "Fixed - this run",
                                               "Random - this run"]
    # every job is a dot: 8 jobs per suite (2 cases x 4 variants)
    for ax in axes:
        dots = sum(len(c.get_offsets()) for c in ax.collections if c.get_offsets().size)
        assert dots == 8
    lo, hi = axes[0].get_ylim()
    assert lo < 50 and hi > 3000.5


def test_rms_distributions_with_the_paper_and_failures():
    res = make_results(lambda *k: 100.0, suites=("fixed",),
                       status={(1, "fixed", 1, "motion_sign_error", 0): "crash"})
    fig = rms_distribution_figure(analysed(res, paper=True))
    assert len(fig.axes) == 2 * 3  # this run and paper rows x the paper's 3 suites
    titles = [ax.get_title() for ax in fig.axes]
    assert "Fixed - this run" in titles and "Random - paper" in titles
    fixed = fig.axes[titles.index("Fixed - this run")]
    assert any("crash/timeout" in t.get_text() and "Sign Error: 1" in t.get_text() for t in fixed.texts)


@pytest.mark.parametrize("suites", [["systematic", "random", "fixed"], ["fixed", "other"]])
def test_suite_palette_is_stable(suites):
    pal = suite_palette(suites)
    assert list(pal) == suites
    assert len(set(pal.values())) == len(suites)
    if "fixed" in suites:
        assert pal["fixed"] == suite_palette(["systematic", "random", "fixed"])["fixed"]
