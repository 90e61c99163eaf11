"""Table II writers on synthetic results and on the paper's own data."""

from __future__ import annotations

import itertools
import math
from decimal import ROUND_HALF_UP, Decimal

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st
from statsmodels.stats.proportion import proportion_confint

from faultlab.analysis import Analysis, analyse
from faultlab.errors import ResultsError
from faultlab.runner.store import load_results
from faultlab.report.comparison import compare_with_paper
from faultlab.report.tables import (
    PAPER,
    THIS_RUN,
    cell_text,
    detection_markdown,
    format_mm,
    format_pct_interval,
    md_table,
    round_mm,
    table2_csv_frame,
    table2_frame,
    table2_latex,
    table2_markdown,
    table2_runs,
    tex_escape,
    write_tables,
)
from faultlab.stats import DetectionRule

from .conftest import REPO, make_results, paper_results


def analysed(results, *, rule=None, paper=False, rep=None) -> Analysis:
    """The Analysis a report renders Table II from (``rule`` stored with the results)."""
    meta = {} if rule is None else {"detection": {"abs_mm": rule.abs_mm, "rel": rule.rel}}
    return Analysis.from_frame(results, meta, paper=paper, rep=rep)


# --------------------------------------------------------------------------- rounding


def test_round_mm_rounds_halves_up_not_to_even():
    assert round_mm(40.5) == 41  # Python's round gives 40
    assert round_mm(3000.5) == 3001
    assert round_mm(2.4999) == 2
    assert round_mm(5615.818248778024) == 5616  # paper, systematic baseline R1C1
    assert round_mm(-0.5) == -1
    assert round_mm(0.49999999999999994) == 0  # floor(x + 0.5) would give 1
    assert format_mm(float("nan")) == ""
    with pytest.raises(ValueError, match="non-finite"):
        round_mm(float("inf"))


def test_format_pct_interval_writes_both_bounds_as_percentages():
    assert format_pct_interval(0.125, 0.4567) == "13-46"  # 12.5 rounds half up
    assert format_pct_interval(0.0123, 0.5, 1) == "1.2-50.0"
    assert format_pct_interval(float("nan"), 0.5) == "-50"


def test_md_table_writes_header_separator_and_rows():
    frame = pd.DataFrame({"suite": ["random", "fixed"], "rate %": [27, 100]})
    assert md_table(frame) == "| suite | rate % |\n| --- | --- |\n| random | 27 |\n| fixed | 100 |"


@given(st.floats(min_value=-1e7, max_value=1e7, allow_nan=False, allow_infinity=False))
def test_round_mm_matches_decimal_half_up(x):
    expected = int(Decimal(x).quantize(Decimal(1), rounding=ROUND_HALF_UP))
    assert round_mm(x) == expected


def test_cell_text_marks_and_failures():
    assert cell_text(1234.4, "ok", True, style="csv") == "1234*"
    assert cell_text(1234.4, "ok", True, style="md") == "**1234**"
    assert cell_text(1234.4, "ok", True, style="tex") == "\\textbf{1234}"
    assert cell_text(1234.4, "ok", True, style="plain") == "1234"
    assert cell_text(1234.6, "ok", False, style="md") == "1235"
    assert cell_text(float("nan"), "crash", False) == "crash"
    assert cell_text(float("nan"), "timeout", True) == "timeout"
    assert cell_text(float("nan"), "ok", False) == ""


# --------------------------------------------------------------------------- synthetic Table II


def _csv(synthetic_results, **kw) -> pd.DataFrame:
    return table2_csv_frame(analysed(synthetic_results, **kw)).set_index(["Suite", "Algorithm", "Source"])


def test_detected_cells_marked_exactly_where_the_rule_fires(synthetic_results):
    f = _csv(synthetic_results)
    # missing_angle_wrap: 1234.4 vs 50 everywhere -> detected, rounded to 1234
    for suite in ("Systematic", "Random", "Fixed"):
        row = f.loc[(suite, "Faulty Rotation", THIS_RUN)]
        assert row["R1C1"] == "1234*" and row["R1C2"] == "1234*"
        assert f.loc[(suite, "Nonfaulty Baseline", THIS_RUN)][["R1C1", "R1C2"]].tolist() == ["50", "50"]
        # naive resampling: +5 mm, and +230 mm in random case 2 -> never detected
        assert not any(str(v).endswith("*") for v in
                       f.loc[(suite, "Naive Resampling", THIS_RUN)][["R1C1", "R1C2"]])
    # sign error: 3000.5 (rounded half up to 3001) in case 1 of systematic and random only
    assert f.loc[("Systematic", "Sign Error", THIS_RUN)][["R1C1", "R1C2"]].tolist() == ["3001*", "60"]
    assert f.loc[("Random", "Sign Error", THIS_RUN)][["R1C1", "R1C2"]].tolist() == ["3001*", "60"]
    assert f.loc[("Fixed", "Sign Error", THIS_RUN)][["R1C1", "R1C2"]].tolist() == ["60", "60"]
    assert f.loc[("Random", "Naive Resampling", THIS_RUN)]["R1C2"] == "280"


def test_detected_percentages_intervals_and_by_suite(synthetic_results):
    t = analysed(synthetic_results)
    f = table2_csv_frame(t).set_index(["Suite", "Algorithm", "Source"])
    assert f.loc[("Systematic", "Faulty Rotation", THIS_RUN), "Detected %"] == "100"
    assert f.loc[("Systematic", "Sign Error", THIS_RUN), "Detected %"] == "50"
    assert f.loc[("Fixed", "Sign Error", THIS_RUN), "Detected %"] == "0"
    assert f.loc[("Random", "Naive Resampling", THIS_RUN), "Detected %"] == "0"
    assert f.loc[("Fixed", "Nonfaulty Baseline", THIS_RUN), "Detected %"] == "-"
    lo, hi = proportion_confint(1, 2, alpha=0.05, method="wilson")
    assert f.loc[("Systematic", "Sign Error", THIS_RUN), "95% CI"] == f"{round_mm(100 * lo)}-{round_mm(100 * hi)}"
    # by Suite (fault x run pairs with a detecting case): systematic/random 2 of 3, fixed 1 of 3
    assert f.loc[("Systematic", "Nonfaulty Baseline", THIS_RUN), "by Suite %"] == "67"
    assert f.loc[("Random", "Nonfaulty Baseline", THIS_RUN), "by Suite %"] == "67"
    assert f.loc[("Fixed", "Nonfaulty Baseline", THIS_RUN), "by Suite %"] == "33"
    assert f.loc[("Fixed", "Sign Error", THIS_RUN), "by Suite %"] == ""
    rates = t.detection_rates.set_index(["suite", "variant"])
    assert (rates.loc[("systematic", "motion_sign_error"), ["k", "n"]].tolist()) == [1, 2]


def test_rule_thresholds_decide_the_marks():
    # baseline 1000 mm: +250 mm is not "more than 250 mm"; +250.5 mm (25.05 %) is
    rms = {(1, "fixed", 1, "baseline", 0): 1000.0, (1, "fixed", 1, "naive_resampling", 0): 1250.0,
           (1, "fixed", 2, "baseline", 0): 1000.0, (1, "fixed", 2, "naive_resampling", 0): 1250.5}
    res = make_results(rms, suites=("fixed",), variants=("baseline", "naive_resampling"))
    f = _csv(res)
    assert f.loc[("Fixed", "Naive Resampling", THIS_RUN)][["R1C1", "R1C2"]].tolist() == ["1250", "1251*"]
    # a stricter rule (30 %) takes the mark away again
    f = _csv(res, rule=DetectionRule(abs_mm=250.0, rel=0.30))
    assert f.loc[("Fixed", "Naive Resampling", THIS_RUN)]["R1C2"] == "1251"


def test_crash_and_timeout_cells_and_their_counts():
    status = {(1, "fixed", 1, "motion_sign_error", 0): "crash",
              (1, "fixed", 2, "motion_sign_error", 0): "timeout"}
    res = make_results(lambda *k: 50.0 if k[3] == "baseline" else 900.0, suites=("fixed",),
                       status=status)
    t = analysed(res)
    f = table2_csv_frame(t).set_index(["Suite", "Algorithm", "Source"])
    assert f.loc[("Fixed", "Sign Error", THIS_RUN)][["R1C1", "R1C2"]].tolist() == ["crash", "timeout"]
    det = t.detection_rates.set_index("variant")
    assert int(det.loc["motion_sign_error", "crash"]) == 1
    assert int(det.loc["motion_sign_error", "timeout"]) == 1
    assert int(det.loc["motion_sign_error", "n"]) == 0  # failures excluded from k/n
    assert f.loc[("Fixed", "Sign Error", THIS_RUN), "Detected %"] == ""


def test_cells_and_rates_show_one_repetition():
    # rep 0 detects nothing, rep 1 detects every fault: grid and rate show rep 0 (one pair per case, as the paper)
    res = make_results(lambda run, suite, case, variant, rep:
                       50.0 if variant == "baseline" else (60.0 if rep == 0 else 900.0),
                       suites=("fixed",), variants=("baseline", "motion_sign_error"), reps=2)
    t = analysed(res)
    f = table2_csv_frame(t).set_index(["Suite", "Algorithm", "Source"])
    assert f.loc[("Fixed", "Sign Error", THIS_RUN)][["R1C1", "R1C2"]].tolist() == ["60", "60"]
    assert f.loc[("Fixed", "Sign Error", THIS_RUN), "Detected %"] == "0"
    assert "repetition 0 of 2" in table2_markdown(t)
    t1 = analysed(res, rep=1)
    f1 = table2_csv_frame(t1).set_index(["Suite", "Algorithm", "Source"])
    assert f1.loc[("Fixed", "Sign Error", THIS_RUN)][["R1C1", "R1C2"]].tolist() == ["900*", "900*"]
    assert f1.loc[("Fixed", "Sign Error", THIS_RUN), "Detected %"] == "100"
    with pytest.raises(ResultsError, match="repetition 5"):
        analysed(res, rep=5)


def test_empty_results_are_refused(synthetic_results):
    with pytest.raises(ResultsError, match="no rows"):
        analysed(synthetic_results.iloc[:0])


# --------------------------------------------------------------------------- writers


def test_markdown_and_latex_mark_the_same_cells(synthetic_results):
    t = analysed(synthetic_results)
    md = table2_markdown(t)
    assert md.count("**1234**") == 6 and md.count("**3001**") == 2
    assert "| Systematic | Sign Error | this run | **3001** | 60 |" in md
    tex = table2_latex(t)
    assert tex.count("\\textbf{1234}") == 6 and tex.count("\\textbf{3001}") == 2
    assert "\\begin{tabular}" in tex and tex.count("\\begin{tabular}") == tex.count("\\end{tabular}")
    # every body row has as many cells as the column spec
    spec = tex.split("\\begin{tabular}{", 1)[1].split("}", 1)[0]
    body = [ln for ln in tex.splitlines() if ln.startswith(("Systematic", "Fixed", "Random"))]
    assert body and all(ln.count(" & ") == len(spec) - 1 for ln in body)
    assert "Detected \\%" in tex


def test_tex_escape():
    assert tex_escape("a_b & 50% #1") == "a\\_b \\& 50\\% \\#1"


def test_many_runs_are_split_into_blocks_of_three():
    res = make_results(lambda *k: 50.0, runs=4, suites=("fixed",), cases=1,
                       variants=("baseline", "naive_resampling"))
    t = analysed(res)
    assert table2_runs(t) == [1, 2, 3, 4]
    md = table2_markdown(t)
    assert "## Evaluation runs 1-3" in md and "## Evaluation runs 4-4" in md
    assert table2_latex(t).count("\\begin{tabular}") == 2
    assert list(table2_frame(t, runs=[4]).columns[3:4]) == ["R4C1"]
    assert {"R1C1", "R4C1"} <= set(table2_csv_frame(t).columns)


def test_write_tables_round_trip(tmp_path, synthetic_results):
    t = analysed(synthetic_results)
    files = write_tables(t, tmp_path / "rep")
    for p in (files.table2_csv, files.table2_md, files.table2_tex, files.detection_csv, files.detection_md):
        assert p.is_file() and p.stat().st_size > 0
    back = pd.read_csv(files.table2_csv, dtype=str, keep_default_na=False)
    pd.testing.assert_frame_equal(back, table2_csv_frame(t).astype(str))
    d = pd.read_csv(files.detection_csv)
    assert len(d) == 9 and set(d["variant"]) == {"naive_resampling", "missing_angle_wrap",
                                                 "motion_sign_error"}
    md = files.detection_md.read_text()
    assert "| Systematic | Sign Error | 1/2 | 50.0 |" in md


# --------------------------------------------------------------------------- the paper's data


def test_paper_rows_reproduce_the_printed_grid_and_marks():
    t = analysed(paper_results(), paper=True)
    f = table2_csv_frame(t).set_index(["Suite", "Algorithm", "Source"])
    # cells as printed in Table II (rounded to mm)
    row = f.loc[("Systematic", "Nonfaulty Baseline", PAPER)]
    assert [row[f"R1C{c}"] for c in range(1, 6)] == ["5616", "40", "55", "544", "42"]
    assert f.loc[("Fixed", "Sign Error", PAPER), "R3C5"] == "3254*"
    # Sec. VII-D: the systematic suite detected the resampling fault in four cases, at least one per
    # run; the random suite in two, both in run 1; the fixed suite never
    def marked(suite):
        r = f.loc[(suite, "Naive Resampling", PAPER)]
        return sorted(c for c in r.index if c.startswith("R") and str(r[c]).endswith("*"))
    assert marked("Systematic") == ["R1C1", "R2C4", "R3C2", "R3C4"]
    assert marked("Random") == ["R1C3", "R1C5"]
    assert marked("Fixed") == []
    # the printed percentage next to the rule's where they differ (random / faulty rotation: 11 of 15)
    assert f.loc[("Random", "Faulty Rotation", PAPER), "Detected %"] == "80 (rule: 73)"
    assert f.loc[("Systematic", "Naive Resampling", PAPER), "Detected %"] == "27"
    assert f.loc[("Fixed", "Nonfaulty Baseline", PAPER), "by Suite %"] == "67"


def test_detection_rates_put_the_paper_beside(synthetic_results):
    a = analysed(synthetic_results, paper=True)
    d = a.detection_rates.set_index(["suite", "variant"])
    np.testing.assert_allclose(d.loc[("systematic", "naive_resampling"), "paper_rate"], 4 / 15)
    assert d.loc[("random", "missing_angle_wrap"), "paper_printed_pct"] == 80
    np.testing.assert_allclose(d.loc[("random", "missing_angle_wrap"), "paper_rate"], 11 / 15)
    assert math.isclose(d.loc[("systematic", "motion_sign_error"), "rate"], 0.5)
    md = detection_markdown(a)
    assert "Paper % (printed)" in md
    assert "Paper % (printed)" not in detection_markdown(analysed(synthetic_results))


# --------------------------------------------------------------------------- the reference run


def test_the_committed_store_renders_the_committed_tables(tmp_path):
    """The reference run's results store gives the committed report files byte for byte."""
    analysis = analyse(REPO / "reports" / "store")
    files = write_tables(analysis, tmp_path)
    for path in (files.table2_csv, files.detection_csv, files.table2_md, files.table2_tex, files.detection_md):
        assert path.read_bytes() == (REPO / "reports" / path.name).read_bytes(), path.name
    comparison = compare_with_paper(analysis).markdown()
    assert comparison == (REPO / "reports" / "comparison.md").read_text(encoding="utf-8")


# --------------------------------------------------------------------------- the campaign-level verdict

#: The paper's protocol at reduced scale (one run of three 5-case suites, K = 6, 40 steps, 10 particles) with a
#: fault written as a user would write it (tests/stats/userfault.py: the particles get half the turn noise).
USER_FAULT = "tests.stats.userfault:HALVED_TURN_NOISE"
REDUCED_PAPER = f"""
description = "paper protocol, reduced: three 5-case suites, K = 6, with a user's fault"
seed = 20240501
runs = 1
n_steps = 40
sensor_range = 2.0
variants = ["baseline", "{USER_FAULT}"]
repetitions = 6
timeout_s = 120.0
[suites]
systematic = 5
random = 5
fixed = 5
[slam]
name = "fastslam"
particles = 10
[detection]
rule = "statistical"
alpha = 0.05
family = "fault"
[space]
map_size = {{ classes = {{ small = [4, 9], medium = [9, 25], large = [25, 49] }} }}
landmark_density = {{ classes = {{ low = [1, 2], medium = [2, 4], high = [4, 6] }} }}
"""


@pytest.mark.slow
def test_a_users_fault_that_lowers_the_error_is_a_change_in_the_summary_though_no_suite_can_judge_it(tmp_path):
    """The planted fault lowers the error by about 20 % on most cases: per case nothing reaches Holm's level,
    every 5-case suite says it cannot judge (with its smallest attainable p), and the campaign-level verdict
    over the 15 cases is a change, direction better, with its factor, interval, test and level -- in the
    summary, the Markdown table and the Analysis' table."""
    from faultlab.report.pages import _detected_lines
    from faultlab.report.tables import detection_markdown
    from faultlab.runner import run_experiment

    (tmp_path / "exp.toml").write_text(REDUCED_PAPER)
    run_experiment(tmp_path / "exp.toml", tmp_path / "out", jobs=1, progress=False)
    a = analyse(tmp_path / "out", paper=False)
    cases = a.case_verdicts
    assert len(cases) == 15 and (cases["verdict"] == "not_detected").all()
    assert (cases["direction"] == "better").sum() >= 12
    suites = a.suite_verdicts
    assert len(suites) == 3 and (suites["verdict"] == "cannot_judge").all()
    assert (suites["pooled_p_min"] == 2.0 ** -4).all() and (suites["case_p_min"] == 2.0 ** -5).all()
    row = a.campaign_verdicts.iloc[0]
    assert row["verdict"] == "detected" and row["direction"] == "better" and row["n_tested"] == 15
    assert row["ratio_low"] < row["ratio"] < row["ratio_high"] < 1.0 and row["p_holm"] <= 0.05
    # the independent reference: the case means of log(faulty / baseline), two-sided sign flips enumerated
    res = load_results(tmp_path / "out")
    wide = res.pivot_table(index=["suite", "case", "rep"], columns="variant", values="rms_mm")
    means = np.log(wide[USER_FAULT] / wide["baseline"]).groupby(level=["suite", "case"]).mean().to_numpy()
    signs = np.array(list(itertools.product((1, -1), repeat=15)))
    sums = signs @ means
    p = min(1.0, 2 * min(np.mean(sums >= means.sum() - 1e-12), np.mean(sums <= means.sum() + 1e-12)))
    assert row["p"] == pytest.approx(p) and row["ratio"] == pytest.approx(math.exp(means.mean()))
    summary = " ".join(_detected_lines(a))
    assert "detected on 0 of 15 judged cases" in summary
    assert (f"campaign level: changed, better (error x {row['ratio']:.3g} [{row['ratio_low']:.3g}, "
            f"{row['ratio_high']:.3g}] over 15 cases; exact two-sided sign-flip test over the case means, alpha = "
            f"0.05, family faults") in summary
    md = detection_markdown(a)
    assert "## Campaign-level verdict per fault" in md and "| changed | better |" in md
    suite_page = _suite_verdict_rows(a)
    assert all(v.startswith("cannot judge (smallest attainable p = ") for v in suite_page)


def _suite_verdict_rows(a) -> list[str]:
    from faultlab.report.tables import verdict_text

    return [verdict_text(v, p) for v, p in zip(a.suite_verdicts["pooled_verdict"], a.suite_verdicts["pooled_p_min"])]
