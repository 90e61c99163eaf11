"""The comparison of a campaign's RMS distributions with the paper's raw data, against scipy."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import mannwhitneyu

from faultlab.analysis.fidelity import (
    FIDELITY,
    Fidelity,
    Verdict,
    compare_distributions,
    compare_with_paper,
)
from faultlab.errors import ConfigError, ResultsError
from faultlab.vocabulary import BASELINE, PAPER_FAULTS


def _frame(values: dict[tuple[str, str], np.ndarray], *, status: str = "ok") -> pd.DataFrame:
    rows = []
    for (suite, variant), xs in values.items():
        for i, x in enumerate(xs):
            rows.append({"run": 1 + i // 5, "suite": suite, "case": 1 + i % 5, "variant": variant, "rep": 0,
                         "rms_mm": float(x), "status": status})
    return pd.DataFrame(rows)


def _holm(p: np.ndarray) -> np.ndarray:
    """Holm's step-down adjustment, written out (monotone, capped at 1)."""
    order = np.argsort(p)
    m = len(p)
    adj = np.empty(m)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p[i]))
        adj[i] = running
    return adj


@pytest.fixture
def constructed():
    """Three cells of 15 vs 15 values with known relations to the 'paper' sample.

    same: both samples from one narrow log-normal (medians within a few %): reproduced.
    tenfold: this run's values ten times the paper's: differs.
    wide: one narrow and one very wide sample with the same median: no difference shown, but the
    medians' ratio is uncertain by more than a factor of 2: inconclusive.
    """
    rng = np.random.default_rng(5)
    base = np.exp(rng.normal(np.log(100.0), 0.05, 15))
    paper = {("systematic", BASELINE): base, ("systematic", PAPER_FAULTS[0]): base,
             ("systematic", PAPER_FAULTS[1]): np.exp(np.linspace(np.log(10.0), np.log(1000.0), 15))}
    this = {("systematic", BASELINE): np.exp(rng.normal(np.log(100.0), 0.05, 15)),
            ("systematic", PAPER_FAULTS[0]): 10.0 * base,
            ("systematic", PAPER_FAULTS[1]): np.exp(np.linspace(np.log(10.0), np.log(1000.0), 15))[::-1] * 1.01}
    return _frame(this), _frame(paper), this, paper


def test_p_values_are_scipys_and_holm_is_holms(constructed):
    results, paper, this, ref = constructed
    fid = compare_with_paper(results, paper, n_boot=500)
    t = fid.fidelity
    for row in t.itertuples():
        x, y = this[(row.suite, row.variant)], ref[(row.suite, row.variant)]
        res = mannwhitneyu(x, y, alternative="two-sided")
        assert row.u == pytest.approx(res.statistic) and row.p == pytest.approx(res.pvalue)
        assert row.median_mm == pytest.approx(np.median(x)) and row.paper_median_mm == pytest.approx(np.median(y))
        assert row.ratio == pytest.approx(np.median(x) / np.median(y))
        assert row.min_mm == pytest.approx(x.min()) and row.paper_max_mm == pytest.approx(y.max())
    np.testing.assert_allclose(t["p_holm"], _holm(t["p"].to_numpy()))


def test_verdicts_on_constructed_data(constructed):
    results, paper, *_ = constructed
    fid = compare_with_paper(results, paper, n_boot=2000, seed=3)
    verdict = dict(zip(fid.fidelity["variant"], fid.fidelity["verdict"]))
    assert verdict == {BASELINE: "reproduced", PAPER_FAULTS[0]: "differs", PAPER_FAULTS[1]: "inconclusive"}
    tenfold = fid.fidelity[fid.fidelity["variant"] == PAPER_FAULTS[0]].iloc[0]
    assert tenfold.ratio_low > 5 and not tenfold.paper_median_in_ci
    same = fid.fidelity[fid.fidelity["variant"] == BASELINE].iloc[0]
    assert 0.9 < same.ratio_low <= same.ratio <= same.ratio_high < 1.1


def test_a_stricter_factor_or_too_few_values_turn_reproduced_into_inconclusive(constructed):
    results, paper, *_ = constructed
    strict = compare_with_paper(results, paper, n_boot=2000, factor=1.0001)
    assert strict.fidelity.loc[strict.fidelity["variant"] == BASELINE, "verdict"].item() == "inconclusive"
    few = compare_with_paper(results, paper, n_boot=2000, min_n=16)
    assert set(few.fidelity["verdict"]) == {"differs", "inconclusive"}


def test_same_seed_same_intervals_and_bad_rows_are_ignored(constructed):
    results, paper, *_ = constructed
    crashed = results.iloc[:3].assign(status="crash", rms_mm=np.nan)
    a = compare_with_paper(results, paper, n_boot=300, seed=9)
    b = compare_with_paper(pd.concat([results, crashed]), paper, n_boot=300, seed=9)
    pd.testing.assert_frame_equal(a.fidelity, b.fidelity)
    c = compare_with_paper(results, paper, n_boot=300, seed=10)
    assert not np.allclose(a.fidelity["ratio_low"], c.fidelity["ratio_low"])


@settings(max_examples=25, deadline=None)
@given(x=st.lists(st.floats(1.0, 1e4), min_size=1, max_size=12),
       y=st.lists(st.floats(1.0, 1e4), min_size=1, max_size=12), seed=st.integers(0, 2**32 - 1))
def test_intervals_contain_the_estimates_range(x, y, seed):
    r = compare_distributions(x, y, n_boot=200, rng=np.random.default_rng(seed))
    assert min(x) <= r["median_low_mm"] <= r["median_high_mm"] <= max(x)
    assert min(x) / max(y) <= r["ratio_low"] <= r["ratio_high"] <= max(x) / min(y)
    assert r["p"] == pytest.approx(mannwhitneyu(x, y, alternative="two-sided").pvalue)


def test_save_and_load_round_trip(constructed, tmp_path):
    results, paper, *_ = constructed
    fid = compare_with_paper(results, paper, n_boot=300,
                             metadata={"experiment": {"n_steps": 200, "runs": 3, "fov_bug": True,
                                                      "slam": {"name": "fastslam", "profile": "paper",
                                                               "particles": 60}}})
    assert fid.campaign["reduced"] and fid.campaign["profile"] == "paper" and fid.campaign["fov_bug"]
    fid.save(tmp_path)
    back = Fidelity.load(tmp_path)
    pd.testing.assert_frame_equal(back.fidelity, fid.fidelity)
    assert (back.alpha, back.factor, back.min_n, back.n_boot, back.campaign) == \
        (fid.alpha, fid.factor, fid.min_n, fid.n_boot, fid.campaign)
    assert tuple(back.fidelity.columns) == FIDELITY.columns
    assert set(Verdict) == {"reproduced", "differs", "inconclusive"}
    assert back.table("fidelity") is back.fidelity
    with pytest.raises(ResultsError, match="unknown fidelity comparison table 'table'"):
        back.table("table")
    (tmp_path / "fidelity.json").write_text('{"alpha": 0.05}')
    with pytest.raises(ResultsError, match="fidelity.json"):
        Fidelity.load(tmp_path)


@pytest.mark.parametrize("kwargs", [{"alpha": 0.0}, {"factor": 1.0}, {"n_boot": 10}, {"min_n": 0}])
def test_bad_options(constructed, kwargs):
    results, paper, *_ = constructed
    with pytest.raises(ConfigError):
        compare_with_paper(results, paper, **kwargs)


def test_no_common_cell_or_bad_values(constructed):
    results, paper, *_ = constructed
    with pytest.raises(ResultsError, match="no suite and variant"):
        compare_with_paper(results.assign(suite="random"), paper)
    with pytest.raises(ResultsError, match="positive"):
        compare_distributions([1.0, -2.0], [1.0], rng=np.random.default_rng(0))
