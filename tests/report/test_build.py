"""build_report: every file from a real (tiny) results store, never rerunning anything."""

from __future__ import annotations

import shutil
import sqlite3

import numpy as np
import pandas as pd
import pypdf
import pytest

import faultlab.stats.detection
from faultlab.analysis import Analysis, analyse
from faultlab.errors import ResultsError
from faultlab.report.build import ReportFiles, build_report, render_report
from faultlab.report.comparison import Verdict
from faultlab.report.pages import REPORT_TITLE
from faultlab.report.tables import round_mm
from faultlab.runner import case_path, load_metadata, load_results
from faultlab.runner.store import RESULT_COLUMNS, row_checksum


def _forbid_running(monkeypatch):
    """Make every way of running or generating something fail loudly."""
    import faultlab.runner
    import faultlab.runner.execution
    import faultlab.runner.orchestration
    import faultlab.scenario

    def boom(*args, **kwargs):
        raise AssertionError("the report must be built from saved results only")

    for module, name in ((faultlab.runner, "run_experiment"), (faultlab.runner.orchestration, "run_experiment"),
                         (faultlab.runner, "execute_job"), (faultlab.runner.execution, "execute_job"),
                         (faultlab.scenario, "generate_scenario")):
        monkeypatch.setattr(module, name, boom)


@pytest.fixture(scope="module")
def built(tiny_store, tmp_path_factory):
    before = (load_results(tiny_store), load_metadata(tiny_store))
    mp = pytest.MonkeyPatch()
    try:
        _forbid_running(mp)
        _count_classifications(mp)
        files = build_report(tiny_store, tmp_path_factory.mktemp("reports"))
    finally:
        mp.undo()
    return files, before


CLASSIFIED: list[int] = []


def _count_classifications(monkeypatch) -> None:
    """Record the size of every table of pairs the detection rule classifies."""
    original = faultlab.stats.detection.classify
    CLASSIFIED.clear()
    monkeypatch.setattr(faultlab.stats.detection, "classify",
                        lambda pairs, **kw: CLASSIFIED.append(len(pairs)) or original(pairs, **kw))


def _pdf_text(path) -> list[str]:
    return [p.extract_text() for p in pypdf.PdfReader(str(path)).pages]


def test_every_file_is_written(built):
    files, _ = built
    assert isinstance(files, ReportFiles)
    for p in files.files:
        assert p.is_file() and p.stat().st_size > 0, p
    assert {p.name for p in files.files} == {"table2.csv", "table2.md", "table2.tex",
                                             "detection_rates.csv", "detection_rates.md",
                                             "comparison.md", "report.pdf"}
    assert files.n_rows == 18
    assert "report.pdf" in str(files)


def test_pdf_pages_and_their_contents(built, tiny_store):
    files, _ = built
    text = _pdf_text(files.pdf)
    assert len(text) == files.n_pages == len(files.page_titles)
    for title in ("Table II: this run beside the paper",
                  "Detection rates per suite and fault with confidence intervals",
                  "RMS map error distributions per suite and variant (log scale)",
                  "Test cases of evaluation run 1 (Fig. 5 style: landmarks orange, true path blue)",
                  "Coverage of Table I's equivalence classes per suite (evaluation run 1)",
                  "Beyond the paper: false alarms of the detection rule",
                  "Beyond the paper: a statistical oracle over the SLAM repetitions",
                  "Comparison with the paper, row by row",
                  "Run metadata"):
        assert any(t.startswith(title) for t in files.page_titles), title
    table_page = text[[t.startswith("Table II: this run beside the paper") for t in files.page_titles].index(True)]
    res = load_results(tiny_store)
    first = res[(res["suite"] == "fixed") & (res["variant"] == "baseline") & (res["rep"] == 0)
                & (res["case"] == 1)]["rms_mm"].iloc[0]
    assert str(round_mm(first)) in table_page
    assert "5616" in table_page  # the paper's systematic baseline, run 1 case 1
    meta = load_metadata(tiny_store)
    meta_page = "\n".join(t for t, title in zip(text, files.page_titles) if title.startswith("Run metadata"))
    assert meta["experiment_hash"] in meta_page.replace("\n", "")
    assert "root seed" in meta_page and "11 (every case and SLAM seed derives from it" in meta_page
    assert "{'" not in meta_page and "'}" not in meta_page  # a table of settings, not a Python repr
    assert "tiny campaign for the report tests" in text[0]


def test_the_first_page_summarises_what_was_detected(built, tiny_store):
    files, _ = built
    assert files.page_titles[0] == "Summary: what this run detected"
    first = " ".join(_pdf_text(files.pdf)[0].split())
    # Independent count from the store: the campaign's rule per (case, fault) over its repetitions.
    analysis = analyse(tiny_store)
    verdicts = analysis.case_verdicts
    faults = set(analysis.case_rates["fault"])
    assert faults
    for fault, rows in verdicts[verdicts["fault"].isin(faults)].groupby("fault"):
        judged = rows[rows["verdict"] != "cannot_judge"]
        k = int(judged["verdict"].isin(["detected", "crash_detected"]).sum())
        assert f"detected on {k} of {len(judged)} judged cases" in first, fault
    assert "Detection rate per suite and fault" in first  # the figure is on the same page


def test_table2_cells_match_the_store_and_the_rule(built, tiny_store):
    files, _ = built
    res = load_results(tiny_store)
    t2 = pd.read_csv(files.table2_csv, dtype=str, keep_default_na=False)
    mine = t2[t2["Source"] == "this run"].set_index(["Suite", "Algorithm"])
    labels = {"baseline": "Nonfaulty Baseline", "naive_resampling": "Naive Resampling",
              "missing_angle_wrap": "Faulty Rotation"}
    rep0 = res[res["rep"] == 0]
    base = rep0[rep0["variant"] == "baseline"].set_index(["suite", "case"])["rms_mm"]
    checked = 0
    for row in rep0.itertuples():
        cell = mine.loc[(row.suite.capitalize(), labels[row.variant]), f"R{row.run}C{row.case}"]
        if row.status != "ok":
            assert cell == row.status
            continue
        expected = str(round_mm(row.rms_mm))
        if row.variant != "baseline":
            b = base.loc[(row.suite, row.case)]
            # the paper's rule by hand: more than 250 mm and at least 25 % above the baseline
            if row.rms_mm - b > 250.0 and row.rms_mm - b >= 0.25 * b:
                expected += "*"
        assert cell == expected
        checked += 1
    assert checked == len(rep0)
    # the paper's rows are there too, as printed (systematic baseline, run 1, case 1)
    paper = t2[t2["Source"] == "paper"].set_index(["Suite", "Algorithm"])
    assert paper.loc[("Systematic", "Nonfaulty Baseline"), "R1C1"] == "5616"


def test_detection_rates_follow_the_paper_protocol_one_pair_per_case(built, tiny_store):
    files, _ = built
    det = pd.read_csv(files.detection_csv)
    assert set(zip(det["suite"], det["variant"])) == {
        (s, f) for s in ("fixed", "random") for f in ("naive_resampling", "missing_angle_wrap")}
    fixed = det[(det["suite"] == "fixed") & (det["variant"] == "missing_angle_wrap")].iloc[0]
    assert int(fixed["n_jobs"]) == 2  # 2 cases, the shown repetition of 2 (the case-level tables use both)
    assert int(fixed["n_reps"]) == 1
    np.testing.assert_allclose(fixed["rate"], fixed["k"] / fixed["n"])


def test_comparison_marks_unrun_paper_rows(built):
    files, _ = built
    cmp = files.comparison
    # the tiny store has no systematic suite and no sign-error variant
    assert cmp.find("systematic", "baseline").verdict == Verdict.NOT_COMPARABLE
    assert cmp.find("fixed", "motion_sign_error").verdict == Verdict.NOT_COMPARABLE
    assert cmp.find("fixed", "baseline").verdict in (Verdict.AGREES, Verdict.DISAGREES)
    assert files.comparison_md.read_text().startswith("# Comparison with the paper")


def test_the_store_is_left_unchanged(built, tiny_store):
    _, (results_before, meta_before) = built
    pd.testing.assert_frame_equal(load_results(tiny_store), results_before)
    meta_after = load_metadata(tiny_store)
    assert meta_after["sessions"] == meta_before["sessions"]  # no runner invocation
    assert meta_after["n_rows"] == meta_before["n_rows"]


def test_damaged_store_still_reports_with_notes(tiny_store, tmp_path, monkeypatch):
    _forbid_running(monkeypatch)
    copy = tmp_path / "copy"
    shutil.copytree(tiny_store, copy)
    case_path(copy, 1, "random", 1).unlink()
    with sqlite3.connect(copy / "results.sqlite") as conn:  # as if killed before the last job
        conn.execute("DELETE FROM results WHERE suite = 'fixed' AND \"case\" = 2 AND rep = 1 "
                     "AND variant = 'missing_angle_wrap'")
    conn.close()
    files = build_report(copy, tmp_path / "rep")
    notes = " ".join(files.notes)
    assert "1 saved test case file(s)" in notes
    assert "incomplete: 17 of 18 jobs" in notes
    assert files.n_rows == 17 and files.pdf.is_file()
    assert "incomplete" in _pdf_text(files.pdf)[files.page_titles.index(REPORT_TITLE)]


def test_without_the_paper_data(tiny_store, tmp_path):
    files = build_report(tiny_store, tmp_path / "rep", paper_raw=tmp_path / "missing.csv")
    assert any("paper's data was not found" in n for n in files.notes)
    assert [s.verdict for s in files.comparison.statements] == [Verdict.NOT_COMPARABLE]
    t2 = pd.read_csv(files.table2_csv, dtype=str, keep_default_na=False)
    assert set(t2["Source"]) == {"this run"}


def test_no_store_is_a_clear_error(tmp_path):
    with pytest.raises(ResultsError, match="no results store"):
        build_report(tmp_path / "nothing", tmp_path / "rep")
    assert not (tmp_path / "rep").exists()


def test_package_exports_resolve():
    import faultlab.report as report

    for name in report.__all__:
        assert getattr(report, name) is not None, name
    assert report.build_report is build_report
    with pytest.raises(AttributeError, match="no attribute 'nope'"):
        report.nope  # noqa: B018


def _reseal(conn: sqlite3.Connection) -> None:
    """Recompute every row's checksum after a deliberate edit of the store's values."""

    cols = ", ".join(f'"{c}"' for c in RESULT_COLUMNS)
    for rowid, *values in conn.execute(f"SELECT rowid, {cols} FROM results").fetchall():
        conn.execute("UPDATE results SET checksum = ? WHERE rowid = ?", (row_checksum(values), rowid))


def test_a_fault_identical_to_the_baseline_everywhere_is_flagged(built, tiny_store, tmp_path):
    copy = tmp_path / "copy"
    shutil.copytree(tiny_store, copy)
    with sqlite3.connect(copy / "results.sqlite") as conn:  # as if the fault never changed anything
        conn.execute("UPDATE results SET rms_mm = (SELECT b.rms_mm FROM results b WHERE b.variant = 'baseline' "
                     "AND b.run = results.run AND b.suite = results.suite AND b.\"case\" = results.\"case\" "
                     "AND b.rep = results.rep) WHERE variant = 'missing_angle_wrap'")
        _reseal(conn)  # the edit is deliberate: the rows' checksums are recomputed, as a writer would
    conn.close()
    original, _ = built  # the unmodified store's report
    assert not any("equivalent mutant" in n for n in original.notes)
    files = build_report(copy, tmp_path / "rep")
    (note,) = [n for n in files.notes if "equivalent mutant" in n]
    assert note.startswith("missing_angle_wrap:")
    assert "equivalent mutant" in " ".join(_pdf_text(files.pdf)[files.page_titles.index(REPORT_TITLE)].split())


def test_the_report_classifies_every_job_once(built):
    # this run's 12 faulty jobs (3 cases x 2 faults x 2 repetitions) and the paper's 135 faulty cells,
    # each once: every table and page is rendered from the one Analysis
    assert sorted(CLASSIFIED) == [12, 135]


@pytest.mark.slow
def test_a_saved_analysis_renders_the_same_report(built, tiny_store, tmp_path):
    files, _ = built
    analyse(tiny_store).save(tmp_path / "analysis")
    again = render_report(Analysis.load(tmp_path / "analysis"), tmp_path / "rep", store_dir=tiny_store)
    for name in ("table2.csv", "table2.md", "table2.tex", "detection_rates.csv", "detection_rates.md",
                 "comparison.md"):
        assert (tmp_path / "rep" / name).read_bytes() == (files.reports_dir / name).read_bytes(), name
    assert again.page_titles == files.page_titles and again.notes == files.notes


def test_the_fidelity_and_ablation_pages_are_in_the_pdf(built, tiny_store, tmp_path, monkeypatch):
    from faultlab.analysis.ablation import compare_arms
    from faultlab.analysis.fidelity import fidelity
    from faultlab.report.fidelity import FIDELITY_TITLE

    files, _ = built
    fid = fidelity(tiny_store, n_boot=200)
    rows = load_results(tiny_store)
    abl = compare_arms({"paper": rows, "paper_no_aliasing": rows.assign(rms_mm=rows["rms_mm"] * 0.5)}, n_boot=200)
    _forbid_running(monkeypatch)
    with_pages = build_report(tiny_store, tmp_path / "r", fidelity=fid, ablation=abl)
    titles = list(with_pages.page_titles)
    new = [FIDELITY_TITLE, FIDELITY_TITLE + ": what it says", "Differences from the paper's filter, one at a time",
           "Differences from the paper's filter, one at a time: effects"]
    assert with_pages.n_pages == files.n_pages + len(new)
    i = titles.index(FIDELITY_TITLE)
    assert titles[i:i + len(new)] == new and titles[:i] == list(files.page_titles[:i])
    assert titles[i - 1].startswith("Comparison with the paper, row by row")
    text = _pdf_text(with_pages.pdf)
    assert "Faulty rotation" in text[i + 1] and "Mann-Whitney" in text[i + 1]
    fixed_rot = fid.fidelity[(fid.fidelity.suite == "fixed") & (fid.fidelity.variant == "missing_angle_wrap")].iloc[0]
    assert f"{round_mm(fixed_rot.median_mm)} [" in text[i]
    assert "resampling copies" in text[i + 3] and "Wilcoxon" in text[i + 2]
    keywords = pypdf.PdfReader(str(with_pages.pdf)).metadata["/Keywords"]
    assert FIDELITY_TITLE in keywords
