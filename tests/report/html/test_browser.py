"""The HTML reports in a real browser: headless Chromium (Debian's ``chromium`` and ``chromium-driver``) via Selenium.

The sites are opened from ``file://``; every test checks that the browser logged no JavaScript error
and loaded nothing but local files.  Skipped, with the reason, where no browser is installed, except
in CI (``CI=true``), where a missing browser fails: ``.ci/run`` installs it.
"""

from __future__ import annotations

import os
import shutil
import time

import pytest

from faultlab.report.html.campaign import case_page_path
from tests.report.html.conftest import PLANTED, REPS, planted_rms, seen_landmarks

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
DRIVER = shutil.which("chromedriver")
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking", "--disable-component-update",
         "--disable-sync", "--no-first-run", "--window-size=1300,1000")


@pytest.fixture(scope="module")
def browser(tmp_path_factory):
    if CHROMIUM is None or DRIVER is None:
        reason = ("no headless browser: install Debian's chromium and chromium-driver "
                  "(apt-get install -y chromium chromium-driver)")
        if os.environ.get("CI") == "true":
            pytest.fail(f"CI must run the browser tests: {reason}")
        pytest.skip(reason)
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in FLAGS:
        options.add_argument(flag)
    options.add_argument(f"--user-data-dir={tmp_path_factory.mktemp('chromium-profile')}")
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(DRIVER), options=options)
    driver.set_page_load_timeout(60)
    yield driver
    driver.quit()


def open_page(browser, path):
    """Load ``path`` from the file system and wait until it is rendered (:func:`wait_rendered`)."""
    browser.get(path.resolve().as_uri())
    wait_rendered(browser)


def wait_rendered(browser):
    """Wait until BokehJS rendered every root of the page (each root's element has its view inside)."""
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        ready = browser.execute_script(
            "if (document.readyState !== 'complete') return false;"
            "const roots = [...document.querySelectorAll('[data-root-id]')];"
            "return roots.length === 0 || (typeof Bokeh !== 'undefined' && roots.every(e => e.children.length > 0));")
        if ready:
            return
        time.sleep(0.1)
    raise AssertionError(f"{browser.current_url}: BokehJS did not render in 30 s")


def assert_clean(browser):
    """No JavaScript error in the browser's log, and every resource the page loaded is a local file."""
    errors = [e for e in browser.get_log("browser") if e["level"] == "SEVERE"]
    assert errors == []
    loaded = browser.execute_script("return performance.getEntriesByType('resource').map(e => e.name)")
    assert all(url.startswith("file://") for url in loaded), loaded


def cells_of(browser, key: str, column: int) -> list[str]:
    """Texts of one column's visible cells of the Bokeh table ``table-<key>``, top to bottom."""
    return browser.execute_script("""
        const grid = document.querySelector(arguments[0]);
        const found = [];
        const walk = (node) => {
            if (node.shadowRoot) walk(node.shadowRoot);
            for (const child of node.children || []) walk(child);
            if (node.classList && node.classList.contains('slick-row')) {
                const cell = node.querySelectorAll('.slick-cell')[arguments[1]];
                found.push([parseFloat(node.style.top || node.style.transform.replace(/[^0-9.]/g, '') || 0),
                            cell ? cell.textContent : null]);
            }
        };
        walk(grid);
        found.sort((a, b) => a[0] - b[0]);
        return found.map(x => x[1]);
    """, f"#table-{key}", column)


def in_shadow(browser, key: str, selector: str):
    """The first element matching ``selector`` inside the Bokeh table ``table-<key>`` (Bokeh renders in shadow roots)."""
    return browser.execute_script("""
        const walk = (node) => {
            if (node.matches && node.matches(arguments[1])) return node;
            for (const root of [node.shadowRoot, node].filter(Boolean)) {
                for (const child of root.children || []) { const hit = walk(child); if (hit) return hit; }
            }
            return null;
        };
        return walk(document.querySelector(arguments[0]));
    """, f"#table-{key}", selector)


@pytest.mark.slow
def test_from_the_overview_to_the_one_detected_case_in_one_click(browser, planted_site):
    """The planted detection: overview -> its case (one click) shows its scenario and every repetition."""
    site, _, scenarios = planted_site
    open_page(browser, site.index)
    assert_clean(browser)
    run, suite, case, fault = PLANTED
    link = browser.find_element("link text", f"run {run}, {suite} case {case}: {fault}")
    link.click()  # click 1
    wait_rendered(browser)
    assert browser.current_url.endswith(case_page_path(run, suite, case))
    assert browser.find_element("tag name", "h1").text == f"Case: run {run}, {suite}, case {case}"
    # the scenario is drawn (a Bokeh canvas) with the landmarks it saw
    assert browser.execute_script("return Bokeh.documents.flatMap(d => d.roots()).length") == 2  # scenario, errors
    assert f"landmarks seen ({seen_landmarks(scenarios[(run, suite, case)])})" in browser.page_source
    table = browser.find_element("id", "table-repetitions")
    rows = table.find_elements("css selector", "tbody tr")
    assert len(rows) == REPS
    header = [th.text for th in table.find_elements("css selector", "th")]
    col = header.index(f"{fault} RMS mm")
    for rep, row in enumerate(rows):
        assert row.find_elements("tag name", "td")[col].text == f"{planted_rms(run, suite, case, fault, rep):.1f}"
    assert_clean(browser)


@pytest.mark.slow
def test_sort_and_filter_the_cases_table(browser, planted_site):
    site, analysis, _ = planted_site
    open_page(browser, site.root / "cases.html")
    assert_clean(browser)
    names = cells_of(browser, "cases", 0)
    assert len(names) == len(analysis.cases)
    # sort by map_size: click its header; the column reads in ascending order, then descending
    headers = browser.execute_script("""
        const out = [];
        const walk = (n) => { if (n.shadowRoot) walk(n.shadowRoot); for (const c of n.children || []) walk(c);
                              if (n.classList && n.classList.contains('slick-column-name')) out.push(n); };
        walk(document.querySelector('#table-cases')); return out;""")
    titles = [h.text for h in headers]
    col = titles.index("map_size")
    headers[col].click()
    values = [float(v) for v in cells_of(browser, "cases", col)]
    assert values == sorted(values) and len(set(values)) > 1
    headers[col].click()
    values = [float(v) for v in cells_of(browser, "cases", col)]
    assert values == sorted(values, reverse=True)
    # filter: only the systematic suite's cases are left (no other cell holds the word), then all again
    box = in_shadow(browser, "cases", "input")
    box.send_keys("systematic")
    deadline = time.monotonic() + 10
    expected = int((analysis.cases["suite"] == "systematic").sum())
    while len(cells_of(browser, "cases", 0)) != expected and time.monotonic() < deadline:
        time.sleep(0.1)
    left = cells_of(browser, "cases", 0)
    assert 0 < len(left) == expected < len(analysis.cases) and all("systematic" in name for name in left)
    for _ in "systematic":
        box.send_keys("\b")
    time.sleep(0.5)
    assert len(cells_of(browser, "cases", 0)) == len(analysis.cases)
    assert_clean(browser)


@pytest.mark.slow
def test_the_verdicts_table_links_to_the_case(browser, planted_site):
    site, _, _ = planted_site
    open_page(browser, site.root / "verdicts.html")
    run, suite, case, _ = PLANTED
    link = in_shadow(browser, "verdicts", f'a[href="{case_page_path(run, suite, case)}"]')
    assert link is not None
    link.click()
    wait_rendered(browser)
    assert browser.find_element("tag name", "h1").text == f"Case: run {run}, {suite}, case {case}"
    assert_clean(browser)


@pytest.mark.slow
def test_overview_to_a_mutant_and_its_diff(browser, mutation_site):
    site, _, chosen = mutation_site
    open_page(browser, site.index)
    assert_clean(browser)
    browser.find_element("link text", "Mutants").click()
    wait_rendered(browser)
    assert_clean(browser)
    link = in_shadow(browser, "mutants", "a")
    mutant = link.text
    assert mutant in chosen
    link.click()
    wait_rendered(browser)
    assert browser.find_element("tag name", "h1").text == f"Mutant {mutant}"
    assert browser.find_elements("css selector", "pre.code span.add") and browser.find_elements(
        "css selector", "pre.code span.del")
    assert_clean(browser)



@pytest.mark.slow
def test_a_checks_results_filter_to_its_failure(browser, tmp_path):
    from tests.report.html.test_check import write_planted_check

    site, _ = write_planted_check(tmp_path)
    open_page(browser, site.root / "index.html")
    assert_clean(browser)
    browser.find_element("link text", "All results").click()
    wait_rendered(browser)
    assert sorted(cells_of(browser, "results", 2)) == ["fail", "pass", "pass", "pass"]
    box = in_shadow(browser, "results", "input")
    box.send_keys("fail")
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline and cells_of(browser, "results", 2) != ["fail"]:
        time.sleep(0.1)
    assert cells_of(browser, "results", 2) == ["fail"]
    assert_clean(browser)
