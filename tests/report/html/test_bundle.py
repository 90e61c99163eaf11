"""The site of a report's files: the Markdown as written, every CSV as a table, every PNG with its data."""

from __future__ import annotations

import pandas as pd
from matplotlib.figure import Figure

from faultlab.report.html.bundle import MAX_TABLE_BYTES, write_files_html
from tests.report.html.test_site import refs_of


def test_files_become_pages_tables_and_images(tmp_path):
    reports = tmp_path / "reports"
    reports.mkdir()
    (reports / "study.md").write_text("# Study\n\nsystematic 93.8 % <b>\n")
    pd.DataFrame({"suite": ["a", "b"], "score": [0.5, 0.75]}).to_csv(reports / "scores.csv", index=False)
    pd.DataFrame({"x": [1, 2], "y": [3.5, 4.5]}).to_csv(reports / "sobol.csv", index=False)
    fig = Figure()
    fig.add_subplot().plot([1, 2], [3.5, 4.5])
    fig.savefig(reports / "sobol.png")
    big = reports / "kill_matrix.csv"
    big.write_text("a\n" + "1\n" * (MAX_TABLE_BYTES // 2 + 1))
    files = [reports / n for n in ("study.md", "scores.csv", "sobol.png", "sobol.csv", "kill_matrix.csv")]
    site = write_files_html(files, reports / "html", title="study")
    index = site.index.read_text()
    assert "systematic 93.8 % &lt;b&gt;" in index  # the Markdown as written, escaped
    assert (site.root / "figures" / "sobol.png").read_bytes() == (reports / "sobol.png").read_bytes()
    assert 'id="table-sobol"' in index  # the figure's data beside it
    links = refs_of(site.root / "tables.html").refs
    assert "tables/scores.html" in links and "tables/sobol.html" not in links  # sobol is beside its figure
    assert 'id="table-scores"' in (site.root / "tables" / "scores.html").read_text()
    assert "../kill_matrix.csv" in links and (site.root / "../kill_matrix.csv").resolve() == big.resolve()
    assert not (site.root / "tables" / "kill_matrix.html").exists()
    assert len(site.pages) == 3
