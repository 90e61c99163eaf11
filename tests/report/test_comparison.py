"""The honest comparison with the paper says "agrees" / "disagrees" where it should."""

from __future__ import annotations

import pytest

from faultlab.analysis import Analysis
from faultlab.report.comparison import Verdict, compare_with_paper

from .conftest import PAPER_FAULTS, make_results, paper_results


@pytest.fixture(scope="module")
def paper():
    """Compare with the paper's data (``paper_repro/``)."""
    return True


def _compare(results, paper, **kw):
    return compare_with_paper(Analysis.from_frame(results, paper=paper), **kw)


def _paper_like(changes: dict):
    """The paper's raw data as this run's results, with some cells replaced."""
    res = paper_results()
    for (run, suite, case, variant), value in changes.items():
        m = ((res["run"] == run) & (res["suite"] == suite) & (res["case"] == case)
             & (res["variant"] == variant))
        assert m.sum() == 1
        res.loc[m, "rms_mm"] = value
    return res


def test_the_paper_agrees_with_itself(paper):
    cmp = _compare(paper_results(), paper)
    assert cmp.by_verdict(Verdict.DISAGREES) == []
    assert len(cmp.statements) == 12 + 3 + 4
    # the 9 fault rows: identical counts (p = 1), but 15 cases per side cannot detect a difference below the
    # 20-point margin with 80 % power, so "no difference" is inconclusive rather than agreement
    unsure = cmp.by_verdict(Verdict.INCONCLUSIVE)
    assert len(unsure) == 9 and all(s.topic == "detection" and "Boschloo" in s.text for s in unsure)
    assert cmp.summary() == ("10 of 19 comparable statements agree with the paper, 9 inconclusive (too few "
                             "cases to tell).")
    fixed = cmp.find("fixed", "baseline")
    assert fixed.verdict == Verdict.AGREES
    assert "38-101 mm" in fixed.text and "19-202 mm" in fixed.text and "agrees" in fixed.text


def test_fixed_baseline_outside_the_widened_range_disagrees(paper):
    # 250 mm is beyond 101 * 2 = 202 mm
    cmp = _compare(_paper_like({(2, "fixed", 3, "baseline"): 250.0}), paper)
    s = cmp.find("fixed", "baseline")
    assert s.verdict == Verdict.DISAGREES
    assert "disagrees" in s.text and "1 of 15 values" in s.text and "250 mm" in s.text
    # inside the widened range (< 202 mm) it still agrees, and a wider factor accepts 250 mm
    assert _compare(_paper_like({(2, "fixed", 3, "baseline"): 200.0}), paper) \
        .find("fixed", "baseline").verdict == Verdict.AGREES
    assert _compare(_paper_like({(2, "fixed", 3, "baseline"): 250.0}), paper, range_factor=3.0) \
        .find("fixed", "baseline").verdict == Verdict.AGREES


def test_a_fault_the_paper_detected_but_this_run_never_does(paper):
    res = make_results(lambda run, suite, case, variant, rep:
                       50.0 if variant in ("baseline", "naive_resampling") else 5000.0, cases=5)
    cmp = _compare(res, paper)
    s = cmp.find("systematic", "naive_resampling")
    # 0/5 against 4/15: Boschloo's test cannot tell them apart, nor could it detect a small difference
    from scipy.stats import boschloo_exact

    p = boschloo_exact([[4, 11], [0, 5]]).pvalue
    assert p > 0.05 and s.verdict == Verdict.INCONCLUSIVE and f"p = {p:.3g}" in s.text
    assert "0 % (0/5 cases)" in s.this_run and "27 % (4/15, printed)" in s.paper
    assert cmp.find("fixed", "naive_resampling").verdict == Verdict.INCONCLUSIVE
    # claim 'only varied suites detect naive resampling' fails: nobody detects it here
    claim = [c for c in cmp.statements if c.topic == "claim" and c.variant == "naive_resampling"][0]
    assert claim.verdict == Verdict.DISAGREES


def test_a_fault_detected_where_the_paper_never_did(paper):
    res = make_results(lambda run, suite, case, variant, rep:
                       50.0 if variant == "baseline" else 5000.0, cases=5)
    s = _compare(res, paper).find("fixed", "naive_resampling")
    assert s.verdict == Verdict.DISAGREES  # 5/5 against 0/15
    assert "Boschloo" in s.text and "< alpha = 0.05" in s.text


def test_rate_outside_the_interval_disagrees_even_when_both_detect(paper):
    # 1 of 30 systematic cases detects the rotation fault; the paper's 80 % is far outside the CI
    res = make_results(lambda run, suite, case, variant, rep:
                       5000.0 if (variant == "missing_angle_wrap" and case == 1 and run == 1) else 50.0,
                       runs=6, cases=5)
    s = _compare(res, paper).find("systematic", "missing_angle_wrap")
    assert s.verdict == Verdict.DISAGREES
    assert "1/30" in s.this_run and "12/15" in s.paper


def test_close_rates_on_many_cases_agree_and_on_few_are_inconclusive(paper):
    # 3 of 5 cases against the paper's 12/15: no difference shown, but 5 cases could not show one
    res = make_results(lambda run, suite, case, variant, rep:
                       5000.0 if (variant == "missing_angle_wrap" and case <= 3) else 50.0, cases=5)
    s = _compare(res, paper).find("systematic", "missing_angle_wrap")
    assert s.verdict == Verdict.INCONCLUSIVE and "inconclusive" in s.text
    # 80 % of 200 cases against 12/15: near a rate of 80 % the test could have seen a 20-point difference
    res = make_results(lambda run, suite, case, variant, rep:
                       5000.0 if (variant == "missing_angle_wrap" and case % 5) else 50.0, runs=40, cases=5)
    s = _compare(res, paper).find("systematic", "missing_angle_wrap")
    assert s.verdict == Verdict.AGREES and "would have been detected" in s.text


def test_rows_missing_on_one_side_are_not_comparable(paper):
    res = make_results(lambda *k: 50.0, suites=("fixed",), variants=("baseline", "naive_resampling"))
    cmp = _compare(res, paper)
    s = cmp.find("fixed", "missing_angle_wrap")
    assert s.verdict == Verdict.NOT_COMPARABLE and "this run has no such row" in s.text
    assert cmp.find("systematic", "baseline").verdict == Verdict.NOT_COMPARABLE
    assert "not comparable" in cmp.summary()
    # a plugin fault the paper never ran
    res = make_results(lambda *k: 50.0, suites=("fixed",), variants=("baseline", "my_plugin_fault"))
    s = _compare(res, paper).find("fixed", "my_plugin_fault")
    assert s.verdict == Verdict.NOT_COMPARABLE and "the paper has no such row" in s.text


def test_by_suite_and_systematic_claim(paper):
    # the systematic suite misses the resampling fault in its only run: 2 of 3 pairs
    res = make_results(lambda run, suite, case, variant, rep:
                       50.0 if variant in ("baseline", "naive_resampling") else 5000.0, cases=5)
    cmp = _compare(res, paper)
    claim = [c for c in cmp.statements if c.topic == "claim" and c.suite == "systematic"][0]
    assert claim.verdict == Verdict.DISAGREES and "misses 1 of 3" in claim.text
    bs = cmp.find("systematic", "", topic="by suite")
    # 2/3 has a Wilson interval of about 21-94 %: the paper's 100 % is outside
    assert bs.verdict == Verdict.DISAGREES and "outside" in bs.text


def test_without_paper_data_nothing_is_compared(synthetic_results):
    cmp = compare_with_paper(Analysis.from_frame(synthetic_results, paper=False))
    assert [s.verdict for s in cmp.statements] == [Verdict.NOT_COMPARABLE]


def test_markdown_and_frame(paper, synthetic_results):
    cmp = _compare(synthetic_results, paper)
    md = cmp.markdown()
    assert md.startswith("# Comparison with the paper")
    assert md.count("- **") == len(cmp.statements)
    f = cmp.frame()
    assert list(f.columns) == ["topic", "suite", "variant", "verdict", "this_run", "paper", "text"]
    assert set(f["verdict"]) <= {"agrees", "disagrees", "inconclusive", "not comparable"}
    # every statement's text carries its verdict's word
    for s in cmp.statements:
        assert str(s.verdict) in s.text


def test_range_factor_must_be_at_least_one(paper, synthetic_results):
    with pytest.raises(ValueError, match="range_factor"):
        _compare(synthetic_results, paper, range_factor=0.5)


def test_paper_faults_constant_matches_table_order():
    assert PAPER_FAULTS == ("naive_resampling", "missing_angle_wrap", "motion_sign_error")
