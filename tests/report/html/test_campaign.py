"""The campaign's site: the planted detection found from the overview, a page per case, the saved scenario shown."""

from __future__ import annotations

import shutil

import numpy as np

from faultlab.analysis import analyse
from faultlab.report.html.campaign import _Scenarios, build_campaign_html, case_page_path
from faultlab.runner.store import case_path, load_metadata, results_path
from faultlab.scenario.model import load_scenario
from tests.report.html.conftest import CASES, PLANTED, REPS, planted_rms, seen_landmarks
from tests.report.html.test_site import refs_of


def test_the_overview_links_the_planted_detection_and_nothing_else(planted_site):
    site, analysis, _ = planted_site
    refs = refs_of(site.index).refs
    cases = [r for r in refs if r.startswith("cases/")]
    run, suite, case, fault = PLANTED
    assert cases == [case_page_path(run, suite, case)]
    html = site.index.read_text()
    assert "Cases where a fault was detected (1)" in html
    assert f"run {run}, {suite} case {case}: {fault}" in html


def test_a_page_per_case_and_the_tables(planted_site):
    site, analysis, _ = planted_site
    n_cases = len(analysis.cases)
    assert n_cases == 3 * CASES
    assert len(list((site.root / "cases").glob("*.html"))) == n_cases
    assert len(site.pages) == n_cases + 4
    for name in ("cases.html", "verdicts.html", "figures.html"):
        assert (site.root / name).is_file()


def test_the_planted_case_page_shows_its_repetitions_scenario_and_verdict(planted_site, planted):
    site, analysis, scenarios = planted_site
    store = planted[1]
    run, suite, case, fault = PLANTED
    page = site.root / case_page_path(run, suite, case)
    parsed = refs_of(page)
    html = page.read_text()
    # every repetition of every variant, as planted (one decimal)
    for variant in ("baseline", fault, "naive_resampling", "motion_sign_error"):
        for rep in range(REPS):
            assert f"{planted_rms(run, suite, case, variant, rep):.1f}" in parsed.cells
    # the verdicts on the case: the planted fault detected, the others not
    assert parsed.cells.count("detected") == 1 and parsed.cells.count("not_detected") == 2
    # the saved scenario is the one pictured, and linked
    scenario = scenarios[(run, suite, case)]
    assert f"landmarks seen ({seen_landmarks(scenario)})" in html
    npz = [r for r in parsed.refs if r.endswith(".npz")]
    assert len(npz) == 1 and (page.parent / npz[0]).resolve() == case_path(store, run, suite, case).with_suffix(
        ".npz").resolve()


def test_a_store_without_case_files_gets_its_scenarios_from_the_stored_experiment(tiny_store, tmp_path):
    """The committed stores keep only their rows: the scenario made again equals the one the runner saved."""
    bare = tmp_path / "bare"
    bare.mkdir()
    shutil.copy(results_path(tiny_store), bare / "results.sqlite")
    metadata = load_metadata(bare)
    again = _Scenarios(bare, metadata)
    for suite, case in (("fixed", 1), ("fixed", 2), ("random", 1)):
        saved = load_scenario(case_path(tiny_store, 1, suite, case))
        made, source = again.get(1, suite, case)
        assert "generated again" in source
        np.testing.assert_array_equal(made.landmarks, saved.landmarks)
        np.testing.assert_array_equal(made.true_poses, saved.true_poses)
        np.testing.assert_array_equal(made.obs_ids, saved.obs_ids)


def test_a_case_that_cannot_be_pictured_says_why(planted, tmp_path):
    from faultlab.report.html.campaign import write_campaign_html

    analysis, _, _ = planted
    site = write_campaign_html(analysis, tmp_path / "html", store_dir=tmp_path / "nowhere", figures=False)
    run, suite, case, _ = PLANTED
    html = (site.root / case_page_path(run, suite, case)).read_text()
    assert "Not pictured: the store keeps no case files and its experiment cannot be read" in html


def test_build_campaign_html_of_a_real_store_writes_only_under_the_reports(tiny_store, tmp_path):
    before = sorted(p for p in tiny_store.rglob("*"))
    site = build_campaign_html(tiny_store, tmp_path / "reports", figures=True)
    assert site.root == tmp_path / "reports" / "html"
    assert sorted(p for p in tiny_store.rglob("*")) == before
    assert {p.name for p in (site.root / "figures").iterdir()} == {"detection_rates.png", "rms_distribution.png"}
    assert len(list((site.root / "cases").glob("*.html"))) == len(analyse(tiny_store).cases)
