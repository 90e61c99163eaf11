"""The paired effect of one difference from the paper's filter, against hand-computed values."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import wilcoxon

from faultlab.analysis.ablation import ABLATION, AblationResult, compare_arms, paired_effect
from faultlab.errors import ConfigError, ResultsError
from faultlab.slam.profiles import Ablation, Arm


def _rows(values: dict[tuple[str, int, str], float], *, status: dict | None = None) -> pd.DataFrame:
    status = status or {}
    return pd.DataFrame([{"run": 1, "suite": s, "case": c, "variant": v, "rep": 0, "rms_mm": x,
                          "status": status.get((s, c, v), "ok")} for (s, c, v), x in values.items()])


def test_paired_effect_on_a_tiny_sample_by_hand():
    paper = [110.0, 220.0, 330.0, 440.0, 550.0]
    alternative = [100.0, 200.0, 300.0, 400.0, 500.0]  # differences 10, 20, 30, 40, 50
    e = paired_effect(paper, alternative, n_boot=200, rng=np.random.default_rng(0))
    assert e["n"] == 5 and e["n_zero"] == 0 and e["n_larger"] == 5
    assert e["paper_median_mm"] == 330.0 and e["alternative_median_mm"] == 300.0
    assert e["diff_median_mm"] == 30.0 and e["ratio_median"] == pytest.approx(1.1)
    # all five signs positive: W- = 0, the exact two-sided p is 2 / 2^5
    assert e["p"] == pytest.approx(2 / 32)
    assert 10.0 <= e["diff_low_mm"] <= 30.0 <= e["diff_high_mm"] <= 50.0


def test_zero_differences_are_no_evidence():
    e = paired_effect([5.0, 6.0, 7.0], [5.0, 6.0, 7.0], n_boot=100, rng=np.random.default_rng(1))
    assert e["p"] == 1.0 and e["n_zero"] == 3 and e["diff_median_mm"] == 0.0 and e["n_larger"] == 0
    # one zero among four: dropped before the test (three differences of 2, -4, 6: ranks 1, 2, 3)
    e = paired_effect([5.0, 12.0, 6.0, 16.0], [5.0, 10.0, 10.0, 10.0], n_boot=100, rng=np.random.default_rng(1))
    assert e["n_zero"] == 1 and e["n_larger"] == 2
    # W+ = 1 + 3 = 4 of 6; exact distribution of W+ for n = 3: 0,1,2,3,3,4,5,6 -> P(W+ >= 4) = 3/8
    assert e["p"] == pytest.approx(min(1.0, 2 * 3 / 8))


@settings(max_examples=25, deadline=None)
@given(st.lists(st.tuples(st.floats(1.0, 1e4), st.floats(1.0, 1e4)), min_size=6, max_size=20))
def test_p_is_scipys_wilcoxon_of_the_non_zero_differences(pairs):
    a, b = np.array(pairs).T
    e = paired_effect(a, b, n_boot=100, rng=np.random.default_rng(2))
    d = (a - b)[a != b]
    assert e["p"] == (1.0 if d.size == 0 else pytest.approx(wilcoxon(d).pvalue))
    assert e["diff_low_mm"] <= e["diff_median_mm"] + 1e-9 or e["n"] < 3
    assert e["diff_median_mm"] == pytest.approx(np.median(a - b))


def test_compare_arms_pairs_by_case_and_drops_failed_jobs():
    paper = Ablation("weights", Arm("a"), Arm("b"), "change")
    left = _rows({("fixed", 1, "baseline"): 110.0, ("fixed", 2, "baseline"): 220.0,
                  ("fixed", 3, "baseline"): 330.0, ("fixed", 1, "missing_angle_wrap"): 900.0},
                 status={("fixed", 3, "baseline"): "crash"})
    right = _rows({("fixed", 2, "baseline"): 200.0, ("fixed", 1, "baseline"): 100.0,
                   ("fixed", 3, "baseline"): 300.0, ("fixed", 4, "baseline"): 400.0,
                   ("fixed", 1, "missing_angle_wrap"): 1000.0})
    res = compare_arms({"a": left, "b": right}, ablations=[paper], n_boot=200, seed=3)
    assert list(res.ablation["variant"]) == ["baseline", "missing_angle_wrap"]
    base = res.row("weights", "baseline")
    assert base.n == 2 and base.diff_median_mm == 15.0 and base.paper_median_mm == 165.0  # cases 1, 2 only
    rot = res.row("weights", "missing_angle_wrap")
    assert rot.n == 1 and rot.diff_median_mm == -100.0 and rot.ratio_median == pytest.approx(0.9)
    # Holm over two tests: the smaller p times 2, the larger max(itself, that), capped at 1
    p = np.sort(res.ablation["p"].to_numpy())
    assert np.sort(res.ablation["p_holm"].to_numpy()) == pytest.approx([min(1, 2 * p[0]), min(1, max(2 * p[0], p[1]))])
    assert res.row("weights", "naive_resampling") is None
    # an ablation with an arm missing is left out; none at all is an error
    assert compare_arms({"a": left, "b": right, "c": right},
                        ablations=[paper, Ablation("x", Arm("a"), Arm("zz"), "")], n_boot=200).ablation.shape[0] == 2
    with pytest.raises(ResultsError, match="no ablation"):
        compare_arms({"a": left}, ablations=[paper])
    with pytest.raises(ConfigError, match="n_boot"):
        compare_arms({"a": left, "b": right}, ablations=[paper], n_boot=5)


def test_save_and_load_round_trip(tmp_path):
    ab = Ablation("map output", Arm("a"), Arm("b"), "")
    frame = _rows({("fixed", c, "baseline"): 100.0 + c for c in range(1, 6)})
    res = compare_arms({"a": frame, "b": frame.assign(rms_mm=frame["rms_mm"] - 0.4)}, ablations=[ab], n_boot=200,
                       campaign={"runs": 1})
    assert res.row("map output", "baseline").diff_median_mm == pytest.approx(0.4)
    res.save(tmp_path)
    back = AblationResult.load(tmp_path)
    pd.testing.assert_frame_equal(back.ablation, res.ablation)
    assert back.campaign == {"runs": 1} and back.n_boot == 200
    assert list(ABLATION.read_csv(tmp_path / "ablation.csv").columns) == list(ABLATION.columns)
