"""``python -m faultlab reproduce --quick`` end to end, and ``report RESULTS`` rebuilding it."""

from __future__ import annotations

import contextlib
import io
import os
from pathlib import Path

import pandas as pd
import pypdf  # test dependency (pyproject [test] extra): reads the PDF back
import pytest

from faultlab.cli import main
from faultlab.runner import load_metadata, load_results

REPO = Path(__file__).resolve().parents[2]
PAPER_TOML = REPO / "experiments" / "paper.toml"
OUTPUTS = ("table2.csv", "table2.md", "table2.tex", "detection_rates.csv", "detection_rates.md",
           "comparison.md", "report.pdf")


def _run(argv: list[str]) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def quick(tmp_path_factory):
    """One real ``reproduce --quick --out D`` of the paper's protocol (the smoke version), run from an
    empty working directory: the report goes to ``D/report``; the files before and after are recorded."""
    base = tmp_path_factory.mktemp("quick")
    cwd = base / "cwd"
    cwd.mkdir()
    before = sorted(p.relative_to(base) for p in base.rglob("*"))
    old = os.getcwd()
    os.chdir(cwd)
    try:
        code, out, err = _run(["reproduce", "--quick", "--experiment", str(PAPER_TOML),
                               "--out", str(base / "results"), "--no-progress"])
    finally:
        os.chdir(old)
    new = [p for p in sorted(p.relative_to(base) for p in base.rglob("*")) if p not in before]
    return base, code, out, err, new


def _pages(pdf: Path) -> list[str]:
    return [page.extract_text() for page in pypdf.PdfReader(str(pdf)).pages]


@pytest.mark.slow
def test_reproduce_quick_succeeds_and_says_where(quick):
    base, code, out, err, _ = quick
    assert code == 0, err
    assert f"results: {base / 'results'}" in out
    assert str(base / "results" / "report" / "report.pdf") in out
    assert "36 jobs:" in out and "36 run now" in out  # (systematic 5 + random 2 + fixed 2 cases) x 4
    assert "comparable statements agree with the paper" in out
    # the HTML report: an overview and a page per case (9 cases)
    html = base / "results" / "report" / "html"
    assert f"HTML report: {html / 'index.html'}" in out
    assert (html / "index.html").is_file() and len(list((html / "cases").glob("*.html"))) == 9


@pytest.mark.slow
def test_reproduce_quick_writes_a_readable_pdf_with_the_table2_page(quick):
    base, code, _, err, _ = quick
    assert code == 0, err
    pdf = base / "results" / "report" / "report.pdf"
    reader = pypdf.PdfReader(str(pdf))
    pages = [p.extract_text() for p in reader.pages]
    assert len(pages) >= 12
    assert all(f"page {i} of {len(pages)}" in text for i, text in enumerate(pages, start=1))
    table2 = [t for t in pages if "Table II: this run beside the paper" in t]
    assert len(table2) == 2  # two evaluation runs per page: the paper's three runs beside this run's one
    for word in ("Systematic", "Fixed", "Random", "Nonfaulty Baseline", "Naive Resampling",
                 "Faulty Rotation", "Sign Error", "this run", "paper", "Detected %", "5616"):
        assert word in " ".join(table2), word
    assert "Table II: this run beside the paper" in reader.metadata["/Keywords"]
    titles = reader.metadata["/Keywords"]
    for title in ("Detection rates per suite and fault", "RMS map error distributions",
                  "Test cases of evaluation run 1", "Coverage of Table I", "Run metadata",
                  "Comparison with the paper"):
        assert title in titles, title


@pytest.mark.slow
def test_reproduce_quick_writes_the_tables(quick):
    base, code, _, err, _ = quick
    assert code == 0, err
    reports = base / "results" / "report"
    for name in OUTPUTS:
        assert (reports / name).is_file(), name
    t2 = pd.read_csv(reports / "table2.csv", dtype=str, keep_default_na=False)
    assert len(t2) == 3 * 4 * 2  # suites x variants x (this run, paper)
    mine = t2[t2["Source"] == "this run"].set_index(["Suite", "Algorithm"])
    filled = {s: [c for c in mine.columns if c.startswith("R") and mine.loc[(s, "Nonfaulty Baseline"), c]]
              for s in ("Systematic", "Fixed", "Random")}
    assert filled == {"Systematic": [f"R1C{c}" for c in range(1, 6)],
                      "Fixed": ["R1C1", "R1C2"], "Random": ["R1C1", "R1C2"]}
    det = pd.read_csv(reports / "detection_rates.csv")
    assert len(det) == 9 and int(det["n_jobs"].sum()) == 9 * 3
    assert (reports / "table2.tex").read_text().count("\\begin{tabular}") == 1
    assert (reports / "comparison.md").read_text().count("\n- **") == 19
    rows = load_results(base / "results")
    assert len(rows) == 36 and set(rows["variant"]) == {"baseline", "naive_resampling",
                                                         "missing_angle_wrap", "motion_sign_error"}


@pytest.mark.slow
def test_report_rebuilds_from_saved_results_without_rerunning(quick, tmp_path, monkeypatch):
    base, code, _, err, _ = quick
    assert code == 0, err
    import faultlab.runner
    import faultlab.runner.execution
    import faultlab.runner.orchestration

    def boom(*args, **kwargs):
        raise AssertionError("report must not run anything")

    for module, name in ((faultlab.runner, "run_experiment"), (faultlab.runner.orchestration, "run_experiment"),
                         (faultlab.runner, "execute_job"), (faultlab.runner.execution, "execute_job")):
        monkeypatch.setattr(module, name, boom)
    sessions = load_metadata(base / "results")["sessions"]
    code, out, err = _run(["report", str(base / "results"), "--reports", str(tmp_path / "again")])
    assert code == 0, err
    assert "report written to" in out
    for name in ("table2.csv", "table2.md", "table2.tex", "detection_rates.csv", "comparison.md"):
        assert (tmp_path / "again" / name).read_text() == (base / "results" / "report" / name).read_text(), name
    assert len(_pages(tmp_path / "again" / "report.pdf")) == len(_pages(base / "results" / "report" / "report.pdf"))
    assert load_metadata(base / "results")["sessions"] == sessions



@pytest.mark.slow
def test_report_without_the_pdf_writes_the_same_tables_and_no_pdf(quick, tmp_path):
    base, code, _, err, _ = quick
    assert code == 0, err
    code, out, err = _run(["report", str(base / "results"), "--reports", str(tmp_path / "tables"), "--no-pdf"])
    assert code == 0, err
    assert "(no PDF" in out and not (tmp_path / "tables" / "report.pdf").exists()
    for name in ("table2.csv", "table2.md", "table2.tex", "detection_rates.csv", "detection_rates.md",
                 "comparison.md", "fidelity.csv", "fidelity.md"):
        assert (tmp_path / "tables" / name).read_text() == (base / "results" / "report" / name).read_text(), name
    assert not (tmp_path / "tables" / "html").exists()  # the HTML report only when asked for


@pytest.mark.slow
def test_report_html_writes_the_same_site_as_reproduce(quick, tmp_path):
    base, code, _, err, _ = quick
    assert code == 0, err
    code, out, err = _run(["report", str(base / "results"), "--reports", str(tmp_path / "r"), "--no-pdf", "--html"])
    assert code == 0, err
    again, first = tmp_path / "r" / "html", base / "results" / "report" / "html"
    pages = sorted(p.relative_to(first) for p in first.rglob("*.html"))
    assert pages == sorted(p.relative_to(again) for p in again.rglob("*.html")) and len(pages) == 9 + 4
    # the same overview, but for the ids Bokeh gives its models afresh on every rendering
    assert (again / "index.html").read_text().count("<li>") == (first / "index.html").read_text().count("<li>")


def test_report_without_results_is_a_clear_error(tmp_path):
    code, out, err = _run(["report", str(tmp_path / "none"), "--reports", str(tmp_path / "r")])
    assert code == 1
    assert "no results store" in err and str(tmp_path / "none") in err


@pytest.mark.parametrize("argv", [["reproduce", "--runs", "0"], ["reproduce", "--jobs", "x"],
                                  ["reproduce", "--backend", "mpi"], ["report"]])
def test_bad_arguments_exit_2(argv):
    with pytest.raises(SystemExit) as exc, contextlib.redirect_stderr(io.StringIO()):
        main(argv)
    assert exc.value.code == 2


def test_reproduce_with_a_malformed_experiment_fails_before_running(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("seed = 1\nrunz = 3\n")
    code, _, err = _run(["reproduce", "--experiment", str(bad), "--out", str(tmp_path / "o"),
                         "--reports", str(tmp_path / "r"), "--no-progress"])
    assert code == 1 and "runz" in err
    assert not (tmp_path / "o").exists() and not (tmp_path / "r").exists()


def test_ablation_options_are_checked_before_anything_runs(tmp_path):
    code, _, err = _run(["reproduce", "--ablation", "--experiment", str(PAPER_TOML), "--out", str(tmp_path / "o"),
                         "--reports", str(tmp_path / "r"), "--no-progress"])
    assert code != 0 and "ablation needs profile='paper'" in err
    assert not (tmp_path / "o").exists()
    with pytest.raises(SystemExit):
        _run(["reproduce", "--profile", "paper", "--ablation", "--ablation-fixed", "0"])


@pytest.mark.slow
def test_reproduce_quick_writes_only_under_out(quick):
    """From an empty working directory, ``reproduce --quick --out D`` writes the store, the cases and the
    report under D, and nothing anywhere else."""
    base, code, printed, err, new = quick
    assert code == 0, err
    out = base / "results"
    assert list((base / "cwd").iterdir()) == []
    assert new and all(p.parts[0] == "results" for p in new), new
    assert (out / "results.sqlite").is_file() and any((out / "cases").rglob("*.npz"))
    for name in OUTPUTS:
        assert (out / "report" / name).is_file(), name
    assert str(out / "report" / "report.pdf") in printed


@pytest.mark.slow
def test_reproduce_runs_an_adaptive_experiment(tmp_path):
    """An ``[adaptive]`` experiment runs from the command line with no extra option: the stopping rule is
    the runner's own, and the pairs it stopped are recorded with the repetitions they used."""
    from faultlab.runner.staging import STOPS_KEY
    from tests.runner.suts import write_experiment

    toml = write_experiment(tmp_path / "adaptive.toml", runs=1, repetitions=4,
                            adaptive={"stages": [2, 4], "level": 0.1, "alternative": "greater", "futility": 0.5})
    code, _, err = _run(["reproduce", "--experiment", str(toml), "--out", str(tmp_path / "o"),
                         "--reports", str(tmp_path / "r"), "--no-progress"])
    assert code == 0, err
    results = load_results(tmp_path / "o")
    stops = load_metadata(tmp_path / "o")[STOPS_KEY]
    used = results.groupby(["run", "suite", "case", "variant"]).size()
    assert set(used) <= {2, 4}
    for e in stops:  # a stopped pair has exactly the first stage's repetitions
        assert e["repetitions"] == 2 and used[(e["run"], e["suite"], e["case"], e["variant"])] == 2
