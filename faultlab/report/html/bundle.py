"""The HTML report of a report directory already written as Markdown, CSV tables and PNG figures.

``study report``, ``effects report`` (and any verb whose report is a set of files) get their site
from the files they wrote: the Markdown summary shown as written, every CSV table as a sortable,
filterable table on a page of its own, every PNG figure as an image with the CSV of the same name (when there is one) as
its data table.  Nothing is analysed again: the site shows the report's own files.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import pandas as pd

from faultlab.report.html.site import Code, Image, Links, Page, Site, Table, page_slug, write_site

__all__ = ["write_files_html", "files_pages", "MAX_TABLE_BYTES"]

#: CSV files larger than this are linked, not embedded (a kill matrix of thousands of rows).
MAX_TABLE_BYTES = 1_000_000


def write_files_html(files: Sequence[str | Path], out: str | Path, *, title: str) -> Site:
    """Write a site of the report ``files`` (Markdown, CSV, PNG; others are ignored) into ``out``."""
    out = Path(out)
    return write_site(out, files_pages([Path(f) for f in files], out, title=title), title=title,
                      nav=(("Overview", "index.html"), ("Tables", "tables.html")))


def files_pages(files: Sequence[Path], out: Path, *, title: str) -> list[Page]:
    """The overview (Markdown and figures), the list of tables and a page per table of ``files``.

    A table has a page of its own, so that a page loads one table however many the report has."""
    import os

    csvs = {f.stem: f for f in files if f.suffix == ".csv"}
    overview, pages, links = [], [], []
    for f in files:
        if f.suffix == ".md":
            overview.append(Code(f.name, f.read_text(encoding="utf-8"), caption="The report's summary, as written."))
    for f in files:
        if f.suffix == ".png":
            data = csvs.pop(f.stem, None)
            overview.append(Image(f.stem.replace("_", " "), f"figures/{f.name}", f.read_bytes(),
                                  data=_table(data) if data is not None else None))
    for stem, f in csvs.items():
        if f.stat().st_size > MAX_TABLE_BYTES:
            links.append((f.name, Path(os.path.relpath(f, out)).as_posix(),
                          f"({f.stat().st_size / 1e6:.1f} MB: too large to embed; the CSV file itself)"))
        else:
            page = Page(f"tables/{page_slug(stem)}.html", f.name, (_table(f),))
            pages.append(page)
            links.append((f.name, page.path, ""))
    overview.append(Links("Pages", (("Tables", "tables.html", f"({len(csvs)} tables)"),)))
    return [Page("index.html", title, tuple(overview)),
            Page("tables.html", "Tables", (Links("Tables of the report", tuple(links)),)), *pages]


def _table(path: Path) -> Table:
    return Table(path.name, pd.read_csv(path), key=page_slug(path.stem), caption=f"The table {path.name}.")
