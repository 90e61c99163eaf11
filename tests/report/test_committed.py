"""Every committed report of the paper's protocol is what the code renders from its committed store.

Each committed store is copied to a temporary directory (so that opening it leaves nothing in the
repository) and rendered with the function its command uses; every table the committed report holds
(CSV, Markdown, LaTeX, JSON) must equal the rendered one byte for byte (:mod:`tests.report.committed`).
A report left stale by a change of the code fails here.  The PDFs and figures are rendered too but not
compared (they embed fonts and dates).  The studies' reports: ``test_committed_studies``.
"""

from __future__ import annotations

import re
from pathlib import Path

import pypdf  # test dependency (pyproject [test] extra): reads the committed PDFs back
import pytest

from tests.report.committed import (COMMITTED, PAPER_REPORTS, REPO, REPORTS, TABLE_SUFFIXES, check_committed,
                                    copy_store, report_id, stale_tables)


@pytest.mark.slow
@pytest.mark.parametrize("report, store, render, per_slam", PAPER_REPORTS, ids=[report_id(c) for c in PAPER_REPORTS])
def test_a_committed_report_is_what_its_committed_store_renders(report, store, render, per_slam, tmp_path,
                                                                 monkeypatch):
    check_committed(report, store, render, per_slam, tmp_path, monkeypatch)


def test_every_committed_store_has_its_report_checked():
    stores = {p.parent.relative_to(REPORTS).as_posix() for p in REPORTS.rglob("results.sqlite")}
    checked = set()
    for report, store, _, per_slam in COMMITTED:
        base = (Path(report) / store).as_posix()
        checked |= {s for s in stores if s == base or (per_slam and s.startswith(base + "/"))}
    assert stores and stores == checked


@pytest.mark.slow
def test_the_committed_analysis_tables_of_paper_k10_are_what_its_store_gives(tmp_path):
    """``reports/paper-k10/analysis`` is ``analyse(store).save(...)``, at the precision its tables are written with
    (the last digits of model fits depend on the machine's linear algebra)."""
    from faultlab.analysis import analyse

    committed = REPORTS / "paper-k10" / "analysis"
    analyse(copy_store(REPORTS / "paper-k10" / "store", tmp_path / "store")).save(tmp_path / "analysis")
    tables = sorted(p.name for p in committed.glob("*.csv"))
    assert len(tables) >= 20 and sorted(p.name for p in (tmp_path / "analysis").glob("*.csv")) == tables
    assert stale_tables(committed, tmp_path / "analysis", suffixes=(".csv",)) == []  # the JSON names the store's path


#: The command that wrote ``reports/paper-k10/adaptive`` (run from the repository's root).
ADAPTIVE_REPLAY = ["stats", "adaptive", "reports/paper-k10/store", "--stages", "6,11", "--level", "0.05",
                   "--alternative", "two-sided", "--futility", "0.5", "--reports", "reports/paper-k10/adaptive"]


@pytest.mark.slow
def test_the_committed_adaptive_replay_of_paper_k10_is_what_its_store_gives(tmp_path, monkeypatch):
    from faultlab.cli import main

    copy_store(REPORTS / "paper-k10" / "store", tmp_path / "reports" / "paper-k10" / "store")
    monkeypatch.chdir(tmp_path)  # the same relative paths, below a scratch directory
    assert main(ADAPTIVE_REPLAY) == 0
    committed = REPORTS / "paper-k10" / "adaptive"
    rendered = tmp_path / "reports" / "paper-k10" / "adaptive"
    names = sorted(p.name for p in committed.iterdir())
    assert len(names) == 5 and sorted(p.name for p in rendered.iterdir()) == names
    stale = stale_tables(committed, rendered)
    assert stale == [], f"reports/paper-k10/adaptive: stale {stale}; rerun `python -m faultlab {' '.join(ADAPTIVE_REPLAY)}`"


MACHINE_PATHS = ("/tmp/", "/work/", "/home/", "/root/", "/check/")


def test_no_committed_report_names_a_machine_path():
    """Committed tables and texts (CSV, Markdown, LaTeX, JSON) name no directory of the machine they were made on."""
    files = sorted(p for p in REPORTS.rglob("*") if p.is_file() and p.suffix in TABLE_SUFFIXES)
    assert len(files) > 50  # the scan saw the committed reports
    found = [f"{p.relative_to(REPO)}: {m}" for p in files for m in MACHINE_PATHS
             if m in p.read_text(encoding="utf-8", errors="replace")]
    assert not found, "machine paths in committed reports:\n" + "\n".join(found)


# --------------------------------------------------------------------------- effect pages of committed PDFs

#: An effect page: its title says which scenario parameters or which classes drive an outcome (the
#: continuous effects page, the class-indicator page, and the logistic page they replaced).
EFFECT_TITLE = re.compile(r"which (?:scenario parameters|classes) drive", re.IGNORECASE)
_NUMBER = r"[+-]?\d+(?:\.\d+)?(?:e[+-]?\d+)?"
#: An effect estimate as the effect pages print one: a value with its interval, "+4.73 [+4.4, +5.06]"
#: (continuous responses) or "2.42 1.65-3.55" (odds ratio per SD of the logistic view), or a
#: likelihood-ratio statistic with its degrees of freedom, "7.1 (2)" (class indicators).
ESTIMATE = re.compile(rf"{_NUMBER} \[{_NUMBER}, {_NUMBER}\]|{_NUMBER} +{_NUMBER}-{_NUMBER}|{_NUMBER} \(\d+\)")


def effect_pages(pdf: Path) -> dict[int, str]:
    """The text of each effect page of ``pdf`` by page number (1-based).

    ``write_pdf`` stores the page titles in the PDF's Keywords, one per titled page, so only the effect
    pages are read when every page has a title (reading the text of every page takes minutes: the case
    pictures draw thousands of markers); otherwise every page is read.
    """
    reader = pypdf.PdfReader(pdf)
    titles = str((reader.metadata or {}).get("/Keywords", "")).split("; ")
    assert titles != [""], f"{pdf}: no page titles in its metadata (not written by faultlab.report.pdf.write_pdf)"
    if not any(EFFECT_TITLE.search(t) for t in titles):
        return {}
    numbers = range(1, len(reader.pages) + 1)
    if len(titles) == len(reader.pages):
        numbers = [n for n, t in zip(numbers, titles) if EFFECT_TITLE.search(t)]
    pages = {n: " ".join(reader.pages[n - 1].extract_text().split()) for n in numbers}
    found = {n: text for n, text in pages.items() if EFFECT_TITLE.search(text)}
    assert len(found) == sum(bool(EFFECT_TITLE.search(t)) for t in titles), f"{pdf}: effect pages {sorted(found)}"
    return found


def empty_effect_pages(pdf: Path) -> list[int]:
    """Numbers of the effect pages of ``pdf`` that hold no effect estimate (:data:`ESTIMATE`): the
    page says only that nothing was fitted ("not fitted: ...", "too few data", "Not available")."""
    return [number for number, text in effect_pages(pdf).items() if not ESTIMATE.search(text)]


@pytest.mark.slow
def test_the_effect_page_check_tells_a_page_that_estimates_from_one_that_does_not(tmp_path):
    """Reference: the report's own effects page of a campaign whose sign error multiplies the error by
    ten on every case (its mean log ratio is printed with a t interval), and pages that fit nothing,
    in the forms the renderers print them."""
    import math

    import pandas as pd

    from faultlab.analysis import Analysis
    from faultlab.report.pages import CLASS_EFFECT_PAGE_TITLE, EFFECT_PAGE_TITLE, beyond_pages
    from faultlab.report.pdf import page_title, table_pages, text_pages, write_pdf

    from .conftest import make_results

    results = make_results(lambda run, suite, case, variant, rep:
                           (60.0 + 7 * case + 3 * rep) * (10.0 if variant == "motion_sign_error" else 1.0),
                           cases=3, reps=2)
    rendered = beyond_pages(Analysis.from_frame(results, paper=False))
    effects = [p for p in rendered if page_title(p) == EFFECT_PAGE_TITLE]
    assert len(effects) == 1
    assert EFFECT_TITLE.search(EFFECT_PAGE_TITLE) and EFFECT_TITLE.search(CLASS_EFFECT_PAGE_TITLE)
    write_pdf(tmp_path / "current.pdf", effects)
    text = effect_pages(tmp_path / "current.pdf")[1]
    assert f"+{math.log(10.0):.3g} [" in text  # log(10) = 2.30: the planted effect size, with its interval
    assert empty_effect_pages(tmp_path / "current.pdf") == []

    not_fitted = pd.DataFrame({"fault": ["Faulty Rotation", "Sign Error"], "term": ["(model)", "(model)"],
                               "detected/n": ["15/15", "15/15"], "odds ratio per SD": ["", ""], "95 % CI": ["", ""],
                               "p": ["", ""], "note": ["not fitted: every judged job detected the fault "
                                                       "(outcome does not vary)"] * 2})
    fitted = not_fitted.assign(**{"odds ratio per SD": ["2.42", "0.729"], "95 % CI": ["1.65-3.55", "0.5-1.06"],
                                  "p": ["6.8e-06", "0.101"], "note": ["", ""]})
    pages = (table_pages("Beyond the paper: which scenario parameters drive detection", not_fitted)
             + text_pages(CLASS_EFFECT_PAGE_TITLE, ["- Faulty Rotation: too few data: 2 events (the rarer of 13 "
                                                    "detected / 2 missed cases) for 20 class indicators"])
             + text_pages(EFFECT_PAGE_TITLE, ["Not available: no baseline jobs"])
             + table_pages("Beyond the paper: which scenario parameters drive detection", fitted)
             + text_pages("Beyond the paper: what these results allow", ["Nothing was fitted."]))
    write_pdf(tmp_path / "old.pdf", pages)
    assert sorted(effect_pages(tmp_path / "old.pdf")) == [1, 2, 3, 4]
    assert empty_effect_pages(tmp_path / "old.pdf") == [1, 2, 3]


def test_no_committed_pdf_has_an_effect_page_that_estimates_nothing():
    pdfs = sorted(REPORTS.rglob("*.pdf"))
    assert len(pdfs) >= 5  # the scan saw the committed reports
    with_effects = {p.relative_to(REPORTS).as_posix() for p in pdfs if effect_pages(p)}
    assert {"report.pdf", "paper-k10/report.pdf"} <= with_effects  # campaign reports have an effect page
    empty = {p.relative_to(REPORTS).as_posix(): pages for p in pdfs if (pages := empty_effect_pages(p))}
    assert empty == {}, f"effect pages that estimate nothing (re-render the report from its store): {empty}"
