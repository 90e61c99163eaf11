"""PDF pages render what the Analysis holds, and say why a part is missing."""

from __future__ import annotations

import numpy as np
import pytest
from matplotlib.text import Text

from faultlab.analysis import Analysis
from faultlab.report.comparison import compare_with_paper
from faultlab.report.pages import (
    MAX_PICTURED_RUNS,
    beyond_pages,
    case_pages,
    coverage_pages,
    metadata_pages,
    title_pages,
)
from faultlab.report.pdf import page_title

from .conftest import make_results


def _text(pages) -> str:
    """Every text of the pages: free text and table cells."""
    return "\n".join(t.get_text() for fig in pages for t in fig.findobj(Text))  # table cells are texts too


def _results(reps=1, runs=1):
    # sign error: +900 mm on odd cases only; naive resampling never detected
    return make_results(lambda run, suite, case, variant, rep:
                        50.0 + rep + (900.0 if variant == "motion_sign_error" and case % 2 else 0.0)
                        + (3.0 if variant == "naive_resampling" else 0.0),
                        runs=runs, cases=2, reps=reps)


@pytest.fixture(scope="module")
def one_rep():
    return Analysis.from_frame(_results(), paper=False)


@pytest.fixture(scope="module")
def two_reps():
    return Analysis.from_frame(_results(reps=2), paper=False)


def test_beyond_the_paper_notes_what_one_repetition_cannot_show(one_rep):
    pages = beyond_pages(one_rep)
    titles = [page_title(p) for p in pages]
    assert titles[0] == "Beyond the paper: what these results allow"
    assert not any("false alarms" in t or "statistical oracle" in t for t in titles)
    assert "Beyond the paper: suites compared per fault (Fisher's exact test)" in titles
    text = _text(pages[:1])
    for note in one_rep.notes_on("false_alarms", "oracle"):
        assert note.text[:60] in text.replace("\n", " ")


def test_beyond_the_paper_tables_with_repetitions(two_reps):
    pages = beyond_pages(two_reps)
    titles = [page_title(p) for p in pages]
    assert "Beyond the paper: false alarms of the detection rule" in titles
    assert "Beyond the paper: a statistical oracle over the SLAM repetitions" in titles
    fa = two_reps.false_alarms.set_index("suite")
    text = _text(pages[titles.index("Beyond the paper: false alarms of the detection rule"):][:1])
    assert str(fa.loc["all", "n_pairs"]) in text  # 3 suites x 2 cases x 2 ordered pairs = 12
    oracle_text = _text([pages[titles.index("Beyond the paper: a statistical oracle over the SLAM repetitions")]])
    assert "Sign Error" in oracle_text and "Naive Resampling" in oracle_text


def test_coverage_pages_per_pictured_run_and_pooled():
    many = Analysis.from_frame(_results(runs=MAX_PICTURED_RUNS + 1), paper=False)
    titles = [page_title(p) for p in coverage_pages(many)]
    assert titles == [f"Coverage of Table I's equivalence classes per suite (evaluation run {r})"
                      for r in range(1, MAX_PICTURED_RUNS + 1)] + [
        f"Coverage of Table I's equivalence classes per suite (all {MAX_PICTURED_RUNS + 1} runs pooled)"]
    overall = many.coverage[(many.coverage["run"] == 1) & (many.coverage["parameter"] == "overall")]
    text = _text(coverage_pages(many)[:1])
    for c, k, r in zip(overall["covered"], overall["classes"], overall["coverage"]):
        assert f"{c}/{k} ({100 * r:.0f} %)" in text


def test_missing_cases_are_noted_not_fatal(one_rep, tmp_path):
    pages, seeds, notes = case_pages(tmp_path, one_rep)
    assert pages == [] and seeds == []
    (note,) = notes
    assert note.startswith(f"{len(one_rep.cases)} saved test case file(s) under {tmp_path}/cases could not be read; "
                           "their pictures are left out: test case ")
    assert "missing file" in note and note.endswith(".")


def test_title_and_metadata_pages_show_the_analysis(one_rep):
    title = _text(title_pages(one_rep, compare_with_paper(one_rep), ["a note for the reader"])).replace("\n", " ")
    assert f"Results: {one_rep.n_rows} jobs — {one_rep.n_rows} ok, 0 crash, 0 timeout." in title
    assert one_rep.rule.describe() in title and "a note for the reader" in title
    meta = _text(metadata_pages(one_rep, []))
    rt = one_rep.runtimes.set_index("variant")
    assert f"median {rt.loc['(all)', 'median_s']:.2f} s" in meta and f"over {len(_results())} jobs" in meta
    assert np.isclose(rt.loc["(all)", "total_s"], 1.5 * len(_results()))


def test_case_level_pages_state_test_alpha_family_and_what_could_not_be_judged():
    from faultlab.vocabulary import REPLICA

    res = make_results(lambda run, suite, case, variant, rep:
                       50.0 + 7 * ((rep * 13 + case * 5) % 11) + (900.0 if variant == "motion_sign_error" else 0.0)
                       + (3.0 * ((rep + case) % 3) if variant == REPLICA else 0.0),
                       runs=2, cases=2, reps=6)
    res = res[res["variant"].isin(["baseline", "motion_sign_error"])]
    replica = res[res["variant"] == "baseline"].assign(variant=REPLICA)
    replica = replica.assign(rms_mm=replica["rms_mm"] + 3.0 * ((replica["rep"] + replica["case"]) % 3))
    meta = {"detection": {"rule": "statistical", "alpha": 0.05, "family": "suite_fault", "direction": "either"}}
    import pandas as pd

    a = Analysis.from_frame(pd.concat([res, replica], ignore_index=True), meta, paper=False)
    pages = beyond_pages(a)
    titles = [page_title(p) for p in pages]
    for title in ("Per-case verdicts (statistical rule)", "Detection rates over cases (the case is the unit)",
                  "Suites compared per fault, cases as units",
                  "A/A control: false alarms of both rules (baseline_replica vs baseline)"):
        assert title in titles, title
    text = _text(pages).replace("\n", " ")
    assert "alpha = 0.05" in text and "family 'suite_fault'" in text and "cannot be judged" in text
    assert "two-sided" in text and "median diff mm [CI]" in text
    # K = 6: every case's two-sided p is 2^-5, but Holm over a suite's 4 cases needs 2^-5 <= 0.05 / 4: nothing
    # survives
    sign = a.case_verdicts.query("fault == 'motion_sign_error'")
    assert np.allclose(sign["p"], 1 / 32) and np.allclose(sign["p_holm"], 4 / 32)
    assert (sign["direction"] == "worse").all() and (sign["median_diff_mm"] > 800).all()
    assert (sign["verdict"] == "not_detected").all()
    # the suite-level page: every case's p is 2^-5, so the per-case minimum detects exactly the suite runs of
    # n cases with 2^-5 <= 0.05 / n (the combined one with 2^-5 <= 0.025 / n); at most 2 case means give a
    # pooled p of at least 1/2; the note states where pooling starts
    assert "Suite-level decisions: per-case minimum and pooled" in titles
    assert "only from 7 tested cases" in text
    sv = a.suite_verdicts.query("fault == 'motion_sign_error'")
    assert len(sv) == res.groupby(["suite", "run"]).ngroups
    assert (sv["detected_min"] == (1 / 32 <= 0.05 / sv["n_cases"])).all()
    assert (sv["detected_combined"] == (1 / 32 <= 0.025 / sv["n_cases"])).all()
    assert np.allclose(sv["min_p"], 1 / 32) and (sv["pooled_p"] >= 0.5).all()
    # no empty class-effect page: the continuous effects pages say why nothing is fitted, and what size would be
    assert "Which classes drive detection (logistic regression over cases)" not in titles
    assert "Beyond the paper: which scenario parameters drive the map error and the faults" in titles
    assert "Parameter effects: what this campaign's size allows" in titles
    why = a.class_effects.query("fault == 'motion_sign_error'")["note"].iloc[0]
    assert why and why in text
    assert "12 cases for 2 coefficients (1 varying parameters + intercept): the regression view needs about 20 cases" in text


def test_the_effects_page_renders_the_stored_campaign_effects(two_reps, monkeypatch, tmp_path):
    import dataclasses

    from faultlab.report.pages import EFFECT_PAGE_TITLE
    from faultlab.report.pdf import write_pdf

    def computed(*args, **kwargs):
        raise AssertionError("the report computed the campaign effects itself")

    monkeypatch.setattr("faultlab.analysis.effects.campaign_effects", computed)
    eff = two_reps.campaign_effects
    means = eff[eff["term"] == "(mean over cases)"]
    assert len(means) == 4  # the difficulty and the three faults' effect sizes
    # a planted estimate in the stored table is what the page prints
    planted = eff.copy()
    planted.loc[means.index[0], ["estimate", "low", "high"]] = (1.2345, 1.0, 1.5)
    pages = beyond_pages(dataclasses.replace(two_reps, campaign_effects=planted))
    effects = [p for p in pages if page_title(p) == EFFECT_PAGE_TITLE]
    assert len(effects) == 1
    text = _text(effects)
    assert "+1.23 [+1, +1.5]" in text
    for e, lo, hi in means[["estimate", "low", "high"]].to_numpy()[1:]:
        assert f"{e:+.3g} [{lo:+.3g}, {hi:+.3g}]" in text
    write_pdf(tmp_path / "report.pdf", pages)
    assert (tmp_path / "report.pdf").stat().st_size > 0


def test_the_effects_page_says_why_the_campaign_effects_are_missing(monkeypatch):
    from faultlab.analysis import BEYOND_THE_PAPER
    from faultlab.errors import ResultsError
    from faultlab.report.pages import EFFECT_PAGE_TITLE

    def fail(*args, **kwargs):
        raise ResultsError("no baseline jobs")

    monkeypatch.setattr("faultlab.analysis.result.campaign_effects", fail)
    a = Analysis.from_frame(_results(reps=2), paper=False)
    pages = beyond_pages(a)
    effects = [p for p in pages if page_title(p) == EFFECT_PAGE_TITLE]
    assert len(effects) == 1
    assert "Continuous effects: not available (no baseline jobs)." in _text(effects)
    # the reason is also on the page of what these results allow, not among the report's general notes
    assert "Continuous effects: not available (no baseline jobs)." in _text(pages[:1])
    assert "campaign_effects" in BEYOND_THE_PAPER


def test_a_table_shows_only_columns_that_hold_something_for_the_campaign(one_rep):
    from faultlab.report.pages import _case_verdict_pages

    v = one_rep.case_verdicts
    columns = {"p": "p", "p (Holm)": "p_holm", "MDE mm (80 %)": "mde_mm", "median diff mm [CI]": "median_diff_mm"}
    empty = [shown for shown, c in columns.items() if v[c].isna().all()]
    assert len(v) and "p" in empty and "median diff mm [CI]" not in empty  # K = 1: one pair, no test
    pages = _case_verdict_pages(one_rep)
    cells = {t.get_text() for fig in pages for t in fig.findobj(Text)}
    text = _text(pages).replace("\n", " ")
    for shown in columns:
        assert (shown in cells) == (shown not in empty), shown
    assert "Left out, empty for every case of this campaign: " in text
    assert all(e in text.split("Left out, empty for every case of this campaign: ")[1] for e in empty)
    for shown in ("suite", "verdict", "K"):
        assert shown in cells


def test_no_effects_table_of_blank_size_rows(one_rep):
    from faultlab.report.pages import EFFECT_PAGE_TITLE

    eff = one_rep.campaign_effects
    assert (eff["term"] == "(size)").any()
    pages = beyond_pages(one_rep)
    assert all("(size)" not in {t.get_text() for t in p.findobj(Text)} for p in pages)
    titles = [page_title(p) for p in pages]
    assert "Parameter effects: what this campaign's size allows" in titles
