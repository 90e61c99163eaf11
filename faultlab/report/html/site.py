"""A static, self-contained HTML site: pages of text, sortable and filterable tables, plots and images.

The reusable builder behind every ``--html`` report.  A report describes its pages as data
(:class:`Page` holding :class:`Text`, :class:`Table`, :class:`Plot`, :class:`Image`, :class:`Code`
and :class:`Links` sections) and :func:`write_site` renders them with Jinja2 templates
(``faultlab/report/html/templates``) into a directory that opens from the file system and works
offline: BokehJS, the only script, is copied from the installed ``bokeh`` package into
``static/`` of the site, and every link is relative.

Tables are Bokeh ``DataTable`` widgets (sorted by clicking a column header) with a text box that
filters their rows through Bokeh's own ``CDSView`` and ``BooleanFilter``; plots are Bokeh figures
embedded as JSON documents.  Numbers keep their type in the table's data, so a column sorts by
value; a missing value (NaN) is shown as an empty cell, never as a number.

>>> from faultlab.report.html.site import Page, Text, write_site        # doctest: +SKIP
>>> write_site("out/html", [Page("index.html", "Overview", (Text("What ran", ("3 runs",)),))],
...            title="my report")                                        # doctest: +SKIP
"""

from __future__ import annotations

import io
import math
import re
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import Mapping, Sequence

import pandas as pd

from faultlab import __version__

__all__ = ["Text", "Table", "Plot", "Image", "Code", "Links", "Page", "Site", "write_site", "figure_png",
           "page_slug", "STATIC_DIR", "BOKEH_JS"]

#: Folder of the site's scripts (BokehJS).
STATIC_DIR = "static"
#: The BokehJS bundles a page loads, in order (core, widgets, tables).
BOKEH_COMPONENTS = ("bokeh", "bokeh-widgets", "bokeh-tables")
#: The one script file of the site, under :data:`STATIC_DIR`.
BOKEH_JS = "bokeh.min.js"
#: The site's style sheet, under :data:`STATIC_DIR` (from the templates' ``site.css``).
STYLE = "site.css"
#: Rows of a table shown before its scroll bar.
MAX_VISIBLE_ROWS = 15


@dataclass(frozen=True)
class Text:
    """A heading and paragraphs (plain text, escaped)."""

    title: str
    paragraphs: tuple[str, ...] = ()
    kind: str = field(default="text", init=False)


@dataclass(frozen=True, eq=False)
class Table:
    """A sortable, filterable table of ``frame``.

    Attributes
    ----------
    title : str
    frame : DataFrame
        Column names are shown as headers; float columns keep their values (shown with
        ``digits`` decimals), NaN shown empty.
    key : str
        Identifier of the table on its page (the HTML id ``table-<key>``; tests find it by it).
    links : mapping
        Column shown as a link -> the column holding its target (a path relative to the site's
        root); the target column is not shown.
    caption : str
        A sentence under the title: what a row is, units.
    digits : int
    interactive : bool
        A Bokeh DataTable with a filter box (True), or a plain HTML table for a few rows (False: lighter,
        nothing to sort).
    """

    title: str
    frame: pd.DataFrame
    key: str
    links: Mapping[str, str] = field(default_factory=dict)
    caption: str = ""
    digits: int = 3
    interactive: bool = True
    kind: str = field(default="table", init=False)

    def cells(self, root: str = "") -> tuple[list[str], list[list[tuple[str, str]]]]:
        """Headers and rows of ``(text, link)`` cells of the plain table (link "" when none)."""
        frame = self.frame.reset_index(drop=True)
        shown = [c for c in frame.columns if c not in set(self.links.values())]
        columns = {name: _cell_values(frame[name]) for name in shown}
        rows = []
        for i in range(len(frame)):
            row = []
            for name in shown:
                values, kind = columns[name]
                v = values[i]
                text = "" if v is None else f"{v:.{self.digits}f}" if kind == "float" else str(v)
                link = root + str(frame[self.links[name]].iloc[i]) if name in self.links else ""
                row.append((text, link))
            rows.append(row)
        return [str(c) for c in shown], rows


@dataclass(frozen=True, eq=False)
class Plot:
    """An interactive Bokeh figure (any Bokeh layout or model) with a caption."""

    title: str
    model: object
    caption: str = ""
    kind: str = field(default="plot", init=False)


@dataclass(frozen=True, eq=False)
class Image:
    """A PNG image (e.g. a figure of the PDF, :func:`figure_png`) written to ``filename`` under the site's root,
    with the table of the data it shows."""

    title: str
    filename: str
    png: bytes
    caption: str = ""
    data: Table | None = None
    kind: str = field(default="image", init=False)


@dataclass(frozen=True)
class Code:
    """Preformatted text, e.g. a unified diff (lines starting with ``+``/``-`` are coloured)."""

    title: str
    text: str
    caption: str = ""
    kind: str = field(default="code", init=False)


@dataclass(frozen=True)
class Links:
    """A list of links ``(label, target relative to the site's root, note)``."""

    title: str
    items: tuple[tuple[str, str, str], ...]
    caption: str = ""
    kind: str = field(default="links", init=False)


Section = Text | Table | Plot | Image | Code | Links


@dataclass(frozen=True, eq=False)
class Page:
    """One HTML page: ``path`` relative to the site's root (POSIX, ending in ``.html``)."""

    path: str
    title: str
    sections: tuple[Section, ...]


@dataclass(frozen=True)
class Site:
    """What :func:`write_site` wrote."""

    root: Path
    pages: tuple[Path, ...]
    n_bytes: int

    @property
    def index(self) -> Path:
        return self.root / "index.html"

    def __str__(self) -> str:
        return (f"HTML report: {self.index} ({len(self.pages)} pages, {self.n_bytes / 1e6:.1f} MB; "
                f"opens from the file system, works offline)")


def page_slug(*parts) -> str:
    """A file-name-safe slug of ``parts`` (letters, digits, ``-``, ``_`` and ``.``)."""
    text = "-".join(str(p) for p in parts)
    return re.sub(r"[^A-Za-z0-9_.-]+", "_", text).strip("_") or "page"


def figure_png(figure, *, dpi: int = 100) -> bytes:
    """A matplotlib Figure as PNG bytes."""
    buffer = io.BytesIO()
    figure.savefig(buffer, format="png", dpi=dpi)
    return buffer.getvalue()


def write_site(out: str | Path, pages: Sequence[Page], *, title: str,
               nav: Sequence[tuple[str, str]] = ()) -> Site:
    """Render ``pages`` into the directory ``out`` (created) with BokehJS beside them.

    Parameters
    ----------
    out : path
        The site's root; every file is written below it.
    pages : sequence of Page
        Their paths must be distinct; one of them should be ``index.html``.
    title : str
        The site's name, in every page's header.
    nav : sequence of (label, path)
        The links of every page's navigation bar (paths relative to the root).

    Returns
    -------
    Site
    """
    from bokeh.embed import components
    from jinja2 import Environment, PackageLoader, select_autoescape

    out = Path(out)
    paths = [p.path for p in pages]
    if len(set(paths)) != len(paths):
        raise ValueError("write_site: two pages share a path")
    env = Environment(loader=PackageLoader("faultlab.report.html", "templates"),
                      autoescape=select_autoescape(["html", "j2"]), trim_blocks=True, lstrip_blocks=True)
    template = env.get_template("page.html.j2")
    _write_bokeh(out / STATIC_DIR / BOKEH_JS)
    css = env.loader.get_source(env, "site.css")[0].encode("utf-8")
    size = _write(out / STATIC_DIR / STYLE, css)
    written = []
    for page in pages:
        root = "../" * (len(PurePosixPath(page.path).parts) - 1)
        models = {i: _model(s, root) for i, s in enumerate(page.sections)
                  if s.kind == "plot" or (s.kind == "table" and s.interactive)}
        script, divs = components(list(models.values())) if models else ("", ())
        div_of = dict(zip(models, divs))
        for s in page.sections:
            if s.kind == "image":
                size += _write(out / s.filename, s.png)
        data_divs = {}
        data_models = {i: _model(s.data, root) for i, s in enumerate(page.sections)
                       if s.kind == "image" and s.data is not None}
        if data_models:
            more_script, more_divs = components(list(data_models.values()))
            script += more_script
            data_divs = dict(zip(data_models, more_divs))
        html = template.render(page=page, site_title=title, root=root, nav=nav, script=script, divs=div_of,
                               data_divs=data_divs, bokeh_js=f"{root}{STATIC_DIR}/{BOKEH_JS}", version=__version__,
                               diff_class=_diff_class)
        target = out / page.path
        size += _write(target, html.encode("utf-8"))
        written.append(target)
    size += (out / STATIC_DIR / BOKEH_JS).stat().st_size
    return Site(root=out, pages=tuple(written), n_bytes=size)


def _write(path: Path, data: bytes) -> int:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    return len(data)


def _write_bokeh(path: Path) -> None:
    """BokehJS (core, widgets, tables) of the installed bokeh, as one local file."""
    from bokeh.resources import Resources

    path.parent.mkdir(parents=True, exist_ok=True)
    js = Resources(mode="inline", components=list(BOKEH_COMPONENTS)).js_raw
    path.write_text("\n;\n".join(js), encoding="utf-8")


def _diff_class(line: str) -> str:
    if line.startswith(("+++", "---")):
        return "file"
    return {"+": "add", "-": "del", "@": "hunk"}.get(line[:1], "")


def _model(section, root: str):
    return _table_model(section, root) if section.kind == "table" else section.model


def _cell_values(series: pd.Series):
    """A column's values for BokehJS: numbers stay numbers (NaN as null, shown empty), others as text."""
    if pd.api.types.is_bool_dtype(series):
        return ["yes" if bool(v) else "no" for v in series], "text"
    if pd.api.types.is_numeric_dtype(series):
        values = series.astype(float).to_numpy()
        integral = pd.api.types.is_integer_dtype(series.dtype)
        return [None if not math.isfinite(v) else (int(v) if integral else float(v)) for v in values], (
            "int" if integral else "float")
    return ["" if (v is None or (isinstance(v, float) and math.isnan(v)) or v is pd.NA) else str(v)
            for v in series], "text"


def _column_width(title: str, values: list, digits: int) -> int:
    """Pixels for a column: its header or its longest value, within [60, 320] (SlickGrid's own text autosizing
    fails on text columns, so widths are set here)."""
    longest = max((len(v) if isinstance(v, str) else len(f"{v:.{digits}f}") if isinstance(v, float) else len(str(v))
                   for v in values if v is not None), default=0)
    return int(min(320, max(60, 7.5 * max(len(title), longest) + 16)))


def _table_model(table: Table, root: str):
    """A Bokeh column: a filter box above a DataTable of ``table.frame``."""
    from bokeh.layouts import column
    from bokeh.models import (BooleanFilter, CDSView, ColumnDataSource, CustomJS, DataTable, HTMLTemplateFormatter,
                              NumberFormatter, StringFormatter, TableColumn, TextInput)

    frame = table.frame.reset_index(drop=True)
    shown = [c for c in frame.columns if c not in set(table.links.values())]
    data, columns = {}, []
    for i, name in enumerate(shown):
        key = f"c{i}"
        data[key], kind = _cell_values(frame[name])
        if name in table.links:
            data[f"{key}_href"] = [root + str(v) for v in frame[table.links[name]]]
            formatter = HTMLTemplateFormatter(template=f'<a href="<%= {key}_href %>"><%- value %></a>')
        elif kind == "float":
            formatter = NumberFormatter(format="0." + "0" * table.digits if table.digits else "0", nan_format="",
                                        null_format="", text_align="right")
        elif kind == "int":
            formatter = NumberFormatter(format="0", nan_format="", null_format="", text_align="right")
        else:
            formatter = StringFormatter()
        columns.append(TableColumn(field=key, title=str(name), formatter=formatter,
                                   width=_column_width(str(name), data[key], table.digits)))
    source = ColumnDataSource(data)
    n = len(frame)
    keep = BooleanFilter(booleans=[True] * n)
    grid = DataTable(source=source, columns=columns, view=CDSView(filter=keep), sortable=True,
                     index_position=None, autosize_mode="none", reorderable=False,
                     height=max(min(n, MAX_VISIBLE_ROWS), 1) * 25 + 50, sizing_mode="stretch_width",
                     name=f"table-{table.key}", css_classes=[f"table-{table.key}"])
    box = TextInput(placeholder=f"filter the {n} rows (text in any column)", width=360,
                    name=f"filter-{table.key}", css_classes=[f"filter-{table.key}"])
    # Bokeh's view filter does the filtering; the callback only says which rows hold the text.
    box.js_on_change("value_input", CustomJS(args=dict(source=source, keep=keep, keys=[k for k in data if not k.endswith("_href")]), code="""
        const q = cb_obj.value_input.trim().toLowerCase();
        const n = source.get_length();
        const rows = new Array(n).fill(q === "");
        if (q !== "") {
            for (const k of keys) {
                const col = source.data[k];
                for (let i = 0; i < n; i++) {
                    if (!rows[i] && col[i] !== null && String(col[i]).toLowerCase().includes(q)) rows[i] = true;
                }
            }
        }
        keep.booleans = rows;
        source.change.emit();
    """))
    return column(box, grid, sizing_mode="stretch_width")
