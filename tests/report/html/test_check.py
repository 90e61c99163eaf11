"""The HTML report of a check: planted records (two cases, one failing one oracle, shrunk) and the site
they give; the browser test opens it in headless Chromium."""

from __future__ import annotations

import re

import pytest

from faultlab.analysis.check import summarise_check
from faultlab.campaigns.check import CaseRecord
from faultlab.report.html.check import write_check_html

SPEC = {"slam": "mylab.mapper:make", "command": [], "suite": "pairwise", "seed": 1, "n_steps": 60, "alpha": 0.05,
        "repetitions": 8,
        "reference": "ekf", "oracles": ["execution", "floor"],
        "options": {"relations": ["rigid_motion"], "floor_ratio": 0.5, "floor_margin_mm": 100.0,
                    "differential_ratio": 2.0, "differential_margin_mm": 100.0, "metamorphic_atol": 1e-6}}


def _records(tmp_path):
    where = tmp_path / "out" / "reproducers" / "pairwise-1-001-floor"
    where.mkdir(parents=True)
    shrunk = {"floor": {"original": {"steps": 240, "landmarks": 9}, "minimal": {"steps": 7, "landmarks": 2},
                        "tests": 31, "confirmed": True, "directory": str(where),
                        "replay": "faultlab check mylab.mapper:make --case case.npz", "log": []}}
    ok = CaseRecord("pairwise-1-000", {"map_size": "small"}, 240, 9, True, 3, 0.025,
                    ({"oracle": "execution", "status": "pass", "message": "ran"},
                     {"oracle": "floor", "status": "pass", "message": "within the floor"}))
    bad = CaseRecord("pairwise-1-001", {"map_size": "large"}, 240, 9, True, 3, 0.025,
                     ({"oracle": "execution", "status": "pass", "message": "ran"},
                      {"oracle": "floor", "status": "fail", "message": "3120 mm > dead reckoning's 880 mm"}),
                     reduction=shrunk)
    return [ok, bad], where


def write_planted_check(tmp_path):
    """The site of the planted records and the minimal scenario's folder."""
    records, where = _records(tmp_path)
    summary = summarise_check(SPEC, records)
    return write_check_html(summary, records, SPEC, tmp_path / "report" / "html"), where


@pytest.fixture
def check_site(tmp_path):
    return write_planted_check(tmp_path)


def test_the_overview_states_the_failure_and_links_its_minimal_scenario(check_site):
    site, where = check_site
    index = (site.root / "index.html").read_text()
    assert "FAIL: 1 (case, oracle) results failed on 1 of 2 cases." in index
    assert "240 steps, 9 landmarks -&gt; 7 steps, 2 landmarks" in index
    hrefs = re.findall(r'href="([^"]+)"', index)
    target = next(h for h in hrefs if h.endswith("pairwise-1-001-floor"))
    assert (site.root / target).resolve() == where.resolve()
    assert "results.html" in hrefs


def test_a_check_that_passes_says_so_and_lists_no_reproducer(tmp_path):
    records, _ = _records(tmp_path)
    good = records[:1]
    site = write_check_html(summarise_check(SPEC, good), good, SPEC, tmp_path / "html")
    index = (site.root / "index.html").read_text()
    assert "pass: no oracle failed on any of the 1 cases." in index and "Minimal failing" not in index


def test_results_table_holds_one_row_per_case_and_oracle(check_site):
    site, _ = check_site
    results = (site.root / "results.html").read_text()
    assert 'id="table-results"' in results
    for needle in ("pairwise-1-000", "pairwise-1-001", "3120 mm &gt; dead reckoning"):
        assert needle in results or needle.replace("&gt;", "\\u003e") in results
