"""Checking a committed report against what the code renders from its committed store.

:func:`check_committed` copies the store to a temporary directory (so that opening it leaves nothing
in the repository) and renders it with the function its command uses; every table the committed
report holds (CSV, Markdown, LaTeX, JSON) must equal the rendered one at the precision it is written
with (:func:`faultlab.precision.same_at_precision`: a library release that moves the last bits of a
value does not make a committed report stale; a change in a written digit beyond one rounding step does).  The paper reports
are rendered without their PDF; the studies' PDFs and figures are rendered but not compared (they embed
fonts and dates).
"""

from __future__ import annotations

import shutil
from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
REPORTS = REPO / "reports"
TABLE_SUFFIXES = (".csv", ".md", ".tex", ".json")


def copy_store(store: Path, to: Path) -> Path:
    """The store's files (results and campaign records, not the regenerable cases) copied to ``to``."""
    to.mkdir(parents=True)
    for f in store.iterdir():
        if f.is_file() and f.suffix in (".sqlite", ".json"):
            shutil.copy2(f, to / f.name)
    return to


def _render_paper(store: Path, out: Path) -> None:
    from faultlab.report.reproduce import rebuild_report

    rebuild_report(store, out, pdf=False)  # the tables are compared; test_build renders the PDF


def _render_mutation(store: Path, out: Path) -> None:
    from faultlab.report.mutation import write_mutation_report

    write_mutation_report(store, out)


def _render_slams(stores: Path, out: Path) -> None:
    from faultlab.analysis.slams import compare_slams
    from faultlab.campaigns.slams import slam_stores
    from faultlab.report.slams import write_slam_report

    found, missing = slam_stores(stores)
    write_slam_report(compare_slams(found, not_installed=missing), out,
                      intro=(REPORTS / "slams" / "intro.md").read_text())


def _render_robustness(stores: Path, out: Path) -> None:
    from faultlab.analysis.robustness import robustness
    from faultlab.campaigns.robustness import robustness_stores
    from faultlab.report.robustness import write_robustness_report

    write_robustness_report(robustness(robustness_stores(stores)), out,
                            intro=(REPORTS / "robustness" / "intro.md").read_text())


def _render_calibration(store: Path, out: Path) -> None:
    from faultlab.analysis.calibration import assess_calibration
    from faultlab.precision import write_csv

    result = assess_calibration(store)
    result.analysis.save(out)
    write_csv(result.rates, out / "calibration.csv")


def _render_study(store: Path, out: Path) -> None:
    from faultlab.report.study import write_study_report

    write_study_report(store, out)


def _render_allocation(store: Path, out: Path) -> None:
    from faultlab.report.allocation import write_allocation_report

    write_allocation_report(store, out, budget=72, ks=[6, 9, 12])


#: (committed report directory, its store relative to it, renderer, store holds one store per SLAM):
#: the reports of the paper's protocol (rendered in ``test_committed``) ...
PAPER_REPORTS = [
    ("", "store", _render_paper, False),
    ("paper-k10", "store", _render_paper, False),
    ("calibrate-quick", "store", _render_calibration, False),
]
#: ... and those of the studies (``test_committed_studies``): two modules, so that two test workers
#: render them at once (``--dist loadscope`` keeps a module on one worker).
STUDY_REPORTS = [
    ("mutation", "store", _render_mutation, False),
    ("mutation-paper", "store", _render_mutation, False),
    ("mutation-user", "store", _render_mutation, False),
    ("mutation-rtb", "store", _render_mutation, False),
    ("slams", "store", _render_slams, True),
    ("robustness", "store", _render_robustness, True),
    ("study-k", "store", _render_allocation, False),
    ("study-confirm", "store", _render_study, False),
]
COMMITTED = PAPER_REPORTS + STUDY_REPORTS


def report_id(entry) -> str:
    return entry[0] or "reports"


def stale_tables(committed: Path, rendered: Path, suffixes: tuple[str, ...] = TABLE_SUFFIXES) -> list[str]:
    """The tables of ``committed`` that differ from those of the same name in ``rendered`` at their precision."""
    from faultlab.precision import same_at_precision

    names = sorted(p.name for p in committed.iterdir() if (rendered / p.name).is_file() and p.suffix in suffixes)
    return [n for n in names if not same_at_precision((committed / n).read_text(), (rendered / n).read_text())]


def check_committed(report: str, store: str, render, per_slam: bool, tmp_path: Path, monkeypatch) -> None:
    """Render ``reports/<report>`` from a copy of its store into ``tmp_path``; every committed table must
    equal the rendered one at its precision, and nothing may be written into the repository."""
    import matplotlib

    matplotlib.use("Agg")
    committed = REPORTS / report
    source = committed / store
    if per_slam:
        copy = tmp_path / "stores"
        for sub in sorted(p for p in source.iterdir() if p.is_dir()):
            copy_store(sub, copy / sub.name)
    else:
        copy = copy_store(source, tmp_path / "store")
    before = sorted(p.name for p in REPORTS.rglob("*"))
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "rendered"
    render(copy, out)
    rendered = {p.name for p in out.iterdir() if p.suffix in TABLE_SUFFIXES}
    tables = sorted(p.name for p in committed.iterdir() if p.name in rendered)
    assert len(tables) >= 4, (report, tables)
    stale = stale_tables(committed, out)
    assert stale == [], f"reports/{report}: stale {stale}; re-render it from its store"
    assert sorted(p.name for p in REPORTS.rglob("*")) == before  # nothing written into the repository


