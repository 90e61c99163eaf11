"""The ablation page renders an AblationResult as it is: one table per difference, every row."""

from __future__ import annotations

import pandas as pd

from faultlab.analysis.ablation import ABLATION, AblationResult, compare_arms
from faultlab.report.ablation import ablation_markdown, ablation_pages, effect_sentence, write_ablation
from faultlab.slam.profiles import ABLATIONS


def _result(weights_shift: float = -5.0):
    rows = []
    for arm, shift in (("paper", 50.0), ("paper_no_aliasing", 0.0), ("paper_no_aliasing_log_weights", weights_shift)):
        for c in range(1, 6):
            for variant, base in (("baseline", 100.0), ("missing_angle_wrap", 1000.0)):
                rows.append({"arm": arm, "run": 1, "suite": "fixed", "case": c, "variant": variant, "rep": 0,
                             "rms_mm": base + c + shift, "status": "ok"})
    df = pd.DataFrame(rows)
    arms = {a: g.drop(columns="arm") for a, g in df.groupby("arm")}
    return compare_arms(arms, n_boot=200, campaign={"runs": 1, "n_steps": 1000, "particles": 200,
                                                    "arm_cases": {"paper": {"fixed": 5}}, "variants": ["baseline"]})


def test_markdown_has_one_table_per_difference_and_every_row(tmp_path):
    res = _result()
    md = ablation_markdown(res)
    assert [a.point for a in ABLATIONS[:2]] == ["resampling copies", "weights"]
    assert "## resampling copies" in md and "## weights" in md and "## map output" not in md
    assert "REDUCED" in md and "Wilcoxon" in md and "1000 steps per case, 200 particles" in md
    assert "(every arm: fixed 5 cases)" in md
    rows = [line for line in md.splitlines() if line.startswith("| ") and "---" not in line and "variant" not in line]
    assert len(rows) == len(res.ablation) == 4
    assert "| Nonfaulty Baseline | 5 | 153 / 103 | 50.0 [50.0, 50.0] |" in md  # paper - paper_no_aliasing
    assert "| Nonfaulty Baseline | 5 | 103 / 98 | 5.0 [5.0, 5.0] |" in md
    assert effect_sentence(res, "weights").startswith("paired median difference paper - alternative: "
                                                      "Nonfaulty Baseline 5.0 mm [5.0, 5.0]")
    assert effect_sentence(res, "map output") == ""
    files = write_ablation(res, tmp_path)
    pd.testing.assert_frame_equal(ABLATION.read_csv(files.csv), res.ablation)
    # the result's own save wrote the table: the bytes the schema writes, read back with its settings
    assert files.csv.read_bytes() == ABLATION.to_csv(res.ablation, tmp_path / "schema.csv").read_bytes()
    back = AblationResult.load(files.meta.parent)
    assert (back.alpha, back.n_boot, back.seed, back.campaign) == (res.alpha, res.n_boot, res.seed, res.campaign)
    pd.testing.assert_frame_equal(back.table("ablation"), res.ablation)
    assert files.markdown.read_text() == md


def test_arms_identical_in_every_pair_show_no_interval():
    md = ablation_markdown(_result(weights_shift=0.0))  # the weights arms agree bit for bit on every case
    assert "| Nonfaulty Baseline | 5 (5 equal) | 103 / 103 | 0 (identical in every pair) |" in md
    assert "[0.0, 0.0]" not in md


def test_pages_carry_their_titles():
    titles = [getattr(p, "_faultlab_page_title") for p in ablation_pages(_result())]
    assert titles == ["Differences from the paper's filter, one at a time",
                      "Differences from the paper's filter, one at a time: effects"]
