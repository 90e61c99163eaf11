"""Multi-page PDF report: text and table pages drawn with matplotlib, written with PdfPages.

Pages are :class:`matplotlib.figure.Figure` objects made without pyplot, so no display and
no GUI backend is needed; :func:`write_pdf` renders them with matplotlib's PDF backend
(TrueType fonts embedded, so the text can be searched and extracted).
"""

from __future__ import annotations

import functools
import math
import sys
import textwrap
import weakref
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Sequence

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import RendererAgg
from matplotlib.backends.backend_pdf import PdfPages
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.colors import to_rgba
from matplotlib.font_manager import FontProperties
from matplotlib.figure import Figure
from matplotlib.text import Text

from faultlab.report.figures import PAGE_SIZE

__all__ = ["PAGE_TITLE_ATTR", "TABLE_FONT_RANGE", "PdfReport", "TableCell", "new_page", "text_pages", "table_pages",
           "table_cells", "write_pdf", "page_title"]

_TITLE_SIZE = 15
_TEXT_SIZE = 9.5
_MARGIN_IN = 0.6
#: Attribute of a Figure holding its page title (see :func:`page_title`).
PAGE_TITLE_ATTR = "_faultlab_page_title"


def page_title(fig: Figure) -> str:
    """The title a page was made with ("" for figures made elsewhere)."""
    return getattr(fig, PAGE_TITLE_ATTR, "") or fig.get_suptitle()


def new_page(title: str, subtitle: str | None = None, *, figsize=PAGE_SIZE) -> Figure:
    """An empty page with its title (bold, top left) and an optional grey subtitle."""
    fig = Figure(figsize=figsize)
    setattr(fig, PAGE_TITLE_ATTR, title)
    w, h = figsize
    fig.text(_MARGIN_IN / w, 1 - _MARGIN_IN / h, title, fontsize=_TITLE_SIZE, fontweight="bold",
             va="top", ha="left")
    if subtitle:
        fig.text(_MARGIN_IN / w, 1 - (_MARGIN_IN + 0.32) / h, subtitle, fontsize=9, color="0.35",
                 va="top", ha="left")
    return fig


def text_pages(title: str, blocks: Sequence[str], *, subtitle: str | None = None,
               fontsize: float = _TEXT_SIZE, figsize=PAGE_SIZE) -> list[Figure]:
    """Paragraphs of text on as many pages as they need.

    Each block is one paragraph, wrapped to the page width; a block starting with ``"## "``
    is a bold heading; ``"- "`` starts a bullet (continuation lines indented).
    """
    w, h = figsize
    chars = int((w - 2 * _MARGIN_IN) * 72 / (0.52 * fontsize))
    line_h = 1.45 * fontsize / 72 / h  # figure fraction per line
    top = 1 - (_MARGIN_IN + (0.62 if subtitle else 0.45)) / h
    bottom = _MARGIN_IN / h
    lines: list[tuple[str, bool]] = []
    previous = None  # kind of the previous block: "heading", "bullet" or "text"
    for block in blocks:
        if block.startswith("## "):
            if lines and lines[-1][0]:
                lines.append(("", False))
            lines.append((block[3:], True))
            previous = "heading"
            continue
        bullet = block.startswith("- ")
        if lines and lines[-1][0] and previous != "heading" and not (bullet and previous == "bullet"):
            lines.append(("", False))  # paragraphs are separated, consecutive bullets are not
        wrapped = textwrap.wrap(block, chars, subsequent_indent="   " if bullet else "") or [""]
        lines.extend((line, False) for line in wrapped)
        previous = "bullet" if bullet else "text"
    per_page = max(1, int((top - bottom) / line_h))
    pages = []
    chunks = [lines[i:i + per_page] for i in range(0, len(lines), per_page)] or [[]]
    for n, chunk in enumerate(chunks):
        fig = new_page(title if n == 0 else f"{title} (continued)", subtitle if n == 0 else None,
                        figsize=figsize)
        y = top
        for text, bold in chunk:
            if text:
                fig.text(_MARGIN_IN / w, y, text, fontsize=fontsize + (1 if bold else 0),
                         fontweight="bold" if bold else "normal", va="top", ha="left",
                         family="DejaVu Sans")
            y -= line_h
        pages.append(fig)
    return pages


#: Font sizes of table text, pt: never below the smaller (legible in print), at most the larger.
TABLE_FONT_RANGE = (8.0, 9.5)
_RENDERER = RendererAgg(10, 10, 72)  # measures text only
#: Horizontal padding of a cell and height of a row, em.
_PAD_EM = 0.9
_ROW_EM = 1.6
#: Shortest line a long cell text is wrapped to, characters.
_MIN_WRAP = 14
_NOTE_SIZE = 8.5
_NOTE_LINE_IN = 1.45 * _NOTE_SIZE / 72


def _cell_text(value) -> str:
    """A cell's text: ``str(value)``, and "" for a missing value."""
    return "" if value is None or (isinstance(value, float) and math.isnan(value)) or value is pd.NA else str(value)


def _wrap(text: str, width: int | None) -> str:
    return text if width is None or len(text) <= width else "\n".join(textwrap.wrap(text, width) or [""])


def _longest_line(text: str) -> int:
    return max((len(line) for line in text.split("\n")), default=0)


def _wrapped(frame: pd.DataFrame, width: int | None) -> pd.DataFrame:
    """``frame`` (header included) with every text longer than ``width`` characters wrapped."""
    out = frame.map(lambda v: _wrap(v, width))
    out.columns = [_wrap(str(c), width) for c in frame.columns]
    return out


@functools.lru_cache(maxsize=65536)
def _text_width_em(text: str, bold: bool) -> float:
    """Width of one line of ``text`` in DejaVu Sans (the report's font), em."""
    prop = FontProperties(family="DejaVu Sans", weight="bold" if bold else "normal", size=100)
    width, _, _ = _RENDERER.get_text_width_height_descent(text, prop, ismath=False)
    return width / 100  # the renderer works at 72 dpi: points at 100 pt


def _lines_em(text: str, bold: bool) -> float:
    return max((_text_width_em(line, bold) for line in text.split("\n")), default=0.0)


def _column_widths_pt(frame: pd.DataFrame, fontsize: float) -> np.ndarray:
    """Width of every column at ``fontsize``: its widest line (the header and cells in bold, as
    highlighted cells are) plus padding, pt."""
    widths = [max([_lines_em(str(c), True)] + [_lines_em(v, True) for v in frame[c]]) for c in frame.columns]
    return (np.maximum(np.array(widths, dtype=float), 0.7) + _PAD_EM) * fontsize


def _fit_columns(frame: pd.DataFrame, fontsize: float, available: float) -> pd.DataFrame:
    """``frame`` with its longest texts wrapped at the widest line length that lets the table fit
    ``available`` pt (never narrower than :data:`_MIN_WRAP` characters)."""
    longest = max([_longest_line(str(c)) for c in frame.columns]
                  + [_longest_line(v) for c in frame.columns for v in frame[c]])
    for width in range(longest, _MIN_WRAP - 1, -1):
        wrapped = _wrapped(frame, width)
        if _column_widths_pt(wrapped, fontsize).sum() <= available:
            return wrapped
    return _wrapped(frame, _MIN_WRAP)


def _column_groups(widths: np.ndarray, available: float, key_columns: int) -> list[list[int]]:
    """Split the columns into about equally wide groups that fit ``available`` pt, each repeating
    the key columns."""
    n = len(widths)
    keys = list(range(min(key_columns, n)))
    if widths.sum() <= available or n <= len(keys) + 1:
        return [list(range(n))]

    def fill(capacity: float) -> list[list[int]]:
        groups, current, used = [], list(keys), widths[keys].sum()
        for c in range(len(keys), n):
            if used + widths[c] > capacity and len(current) > len(keys):
                groups.append(current)
                current, used = list(keys), widths[keys].sum()
            current.append(c)
            used += widths[c]
        return groups + [current]

    count = len(fill(available))
    balanced = widths[keys].sum() + widths[len(keys):].sum() / count
    groups = fill(min(available, 1.02 * balanced))
    return groups if len(groups) == count else fill(available)


def table_pages(title: str, frame: pd.DataFrame, *, note: str | None = None,
                colours: pd.DataFrame | None = None, bold: pd.DataFrame | None = None,
                max_rows: int = 40, fontsize: float | None = None, subtitle: str | None = None,
                key_columns: int = 1, align: str = "center", figsize=PAGE_SIZE) -> list[Figure]:
    """A frame of strings as a table sized to its content, with its caption right under it.

    Every column is as wide as its longest text; the font is ``fontsize`` (default the larger of
    :data:`TABLE_FONT_RANGE`), reduced down to the smaller bound when that lets the table fit the
    page width.  A table still too wide is split into groups of columns, each repeating the first
    ``key_columns`` columns; rows are split over pages by the page height (at most ``max_rows``).

    Parameters
    ----------
    colours, bold : DataFrame, optional
        Same shape as ``frame``: a cell colour (any matplotlib colour, "" for none) and a
        boolean for bold text, per cell.
    note : str, optional
        Wrapped text right under the table (its caption), on every page.
    key_columns : int
        Columns that identify a row, repeated when the columns are split.
    align : {"center", "left", "right"}
        Alignment of the text in its cells.
    """
    w, h = figsize
    frame = frame.reset_index(drop=True).map(_cell_text)
    colours = None if colours is None else colours.reset_index(drop=True)
    bold = None if bold is None else bold.reset_index(drop=True)
    small, large = TABLE_FONT_RANGE
    fontsize = float(np.clip(large if fontsize is None else fontsize, small, large))
    available = (w - 2 * _MARGIN_IN) * 72
    if frame.shape[1]:
        natural = _column_widths_pt(frame, 1.0).sum()  # widths are proportional to the font size
        fontsize = float(np.clip(min(fontsize, available / natural), small, fontsize))
        frame = _fit_columns(frame, fontsize, available)
        widths = _column_widths_pt(frame, fontsize)
        groups = _column_groups(widths, available, key_columns)
    else:
        widths, groups = np.zeros(0), [[]]
    line_in = 1.2 * fontsize / 72
    pad_in = (_ROW_EM - 1.2) * fontsize / 72

    def height(lines: int) -> float:
        return lines * line_in + pad_in

    header_in = height(max([str(c).count("\n") + 1 for c in frame.columns], default=1))
    row_heights = [height(max([v.count("\n") + 1 for v in row], default=1)) for row in frame.to_numpy()]
    note_lines = textwrap.wrap(note, int((w - 2 * _MARGIN_IN) * 72 / (0.52 * _NOTE_SIZE))) if note else []
    note_in = len(note_lines) * _NOTE_LINE_IN + (0.12 if note_lines else 0)
    top_in = _MARGIN_IN + (0.7 if subtitle else 0.55)  # from the top edge
    room = h - top_in - _MARGIN_IN - 0.2 - note_in - header_in  # the footer below
    row_chunks: list[list[int]] = []
    used = 0.0
    for i, rh in enumerate(row_heights):
        if not row_chunks or len(row_chunks[-1]) >= max_rows or used + rh > room:
            row_chunks.append([])
            used = 0.0
        row_chunks[-1].append(i)
        used += rh
    row_chunks = row_chunks or [[]]
    pages = []
    for g, cols in enumerate(groups):
        for n, rows in enumerate(row_chunks):
            label = title if g == 0 and n == 0 else f"{title} (continued)"
            if len(groups) > 1:
                label += f" [columns {g + 1}/{len(groups)}]"
            fig = new_page(label, subtitle, figsize=figsize)
            table_h = header_in + sum(row_heights[i] for i in rows) if rows else 0.3
            table_w = widths[cols].sum() / 72 if cols else w - 2 * _MARGIN_IN
            ax = fig.add_axes([_MARGIN_IN / w, 1 - (top_in + table_h) / h, table_w / w, table_h / h])
            ax.set_axis_off()
            if not rows:
                ax.text(0, 1, "(no rows)", va="top", fontsize=fontsize + 1)
            else:
                row_h = [header_in] + [row_heights[i] for i in rows]
                _draw_table(ax, frame.iloc[rows, cols], widths=widths[cols], heights=np.array(row_h) / table_h,
                            fontsize=fontsize, align=align, pad=0.5 * _PAD_EM * fontsize / 72 / table_w,
                            colours=None if colours is None else colours.iloc[rows, cols].to_numpy(),
                            bold=None if bold is None else bold.iloc[rows, cols].to_numpy(bool))
            y = 1 - (top_in + table_h + 0.12) / h
            for line in note_lines:
                fig.text(_MARGIN_IN / w, y, line, fontsize=_NOTE_SIZE, va="top", ha="left", color="0.2")
                y -= _NOTE_LINE_IN / h
            pages.append(fig)
    return pages


@dataclass(frozen=True)
class TableCell:
    """One drawn cell of a :func:`table_pages` table: its text and geometry (axes fractions)."""

    text: Text
    facecolor: tuple[float, float, float, float]
    x0: float
    x1: float
    y0: float
    y1: float


#: Geometry and colour of the cells of every table drawn, by axes (forgotten with the figure).
_DRAWN: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()


def _draw_table(ax, chunk: pd.DataFrame, *, widths: np.ndarray, heights: np.ndarray, fontsize: float, align: str,
                pad: float, colours: np.ndarray | None, bold: np.ndarray | None) -> None:
    """Draw ``chunk`` (header row first) into ``ax`` filling it: the grid as one line collection, the
    header and coloured cells as one polygon collection, one text per cell.

    ``widths`` are the columns' widths (any unit), ``heights`` the rows' heights (header first) as
    fractions of the axes, ``pad`` the horizontal text padding as a fraction of the axes width.  Each
    cell's text carries the gid ``cell:<row>:<col>`` (row 0: the header), which :func:`table_cells`
    reads back.  (A matplotlib ``Table`` draws the same with a patch per cell and a layout pass,
    about twice as slow to save.)
    """
    xs = np.concatenate([[0.0], np.cumsum(widths) / widths.sum()])
    ys = 1.0 - np.concatenate([[0.0], np.cumsum(heights)])
    ys[-1] = 0.0
    n_rows, n_cols = len(heights), len(widths)
    faces = [(c, 0, "0.9") for c in range(n_cols)]
    if colours is not None:
        faces += [(c, r + 1, colours[r, c]) for r in range(n_rows - 1) for c in range(n_cols)
                  if colours[r, c] and to_rgba(colours[r, c]) != to_rgba("white")]
    cells = {(r, c): to_rgba("white") for r in range(n_rows) for c in range(n_cols)}
    if faces:
        polys = [[(xs[c], ys[r + 1]), (xs[c + 1], ys[r + 1]), (xs[c + 1], ys[r]), (xs[c], ys[r])] for c, r, _ in faces]
        ax.add_collection(PolyCollection(polys, facecolors=[f for *_, f in faces], edgecolors="none",
                                         transform=ax.transAxes, zorder=0))
        cells.update({(r, c): to_rgba(f) for c, r, f in faces})
    grid = [[(0, y), (1, y)] for y in ys] + [[(x, ys[-1]), (x, ys[0])] for x in xs]
    ax.add_collection(LineCollection(grid, colors="0.7", linewidths=0.4, transform=ax.transAxes, zorder=1))
    texts = [list(map(str, chunk.columns))] + chunk.to_numpy().tolist()
    for r, row in enumerate(texts):
        for c, text in enumerate(row):
            x = {"left": xs[c] + pad, "right": xs[c + 1] - pad}.get(align, (xs[c] + xs[c + 1]) / 2)
            heavy = r == 0 or (bold is not None and bool(bold[r - 1, c]))
            t = ax.text(x, (ys[r] + ys[r + 1]) / 2, text, ha=align, va="center", fontsize=fontsize,
                        fontweight="bold" if heavy else "normal", transform=ax.transAxes, clip_on=False, zorder=2)
            t.set_gid(f"cell:{r}:{c}")
    _DRAWN[ax] = {(r, c): (xs[c], xs[c + 1], ys[r + 1], ys[r], cells[(r, c)]) for r in range(n_rows)
                  for c in range(n_cols)}


def table_cells(ax) -> dict[tuple[int, int], TableCell]:
    """The cells :func:`table_pages` drew into ``ax``, by (row, column), row 0 the header; {} if none."""
    geometry = _DRAWN.get(ax, {})
    texts = {tuple(map(int, t.get_gid().split(":")[1:])): t for t in ax.texts
             if (t.get_gid() or "").startswith("cell:")}
    return {key: TableCell(text=texts[key], facecolor=face, x0=x0, x1=x1, y0=y0, y1=y1)
            for key, (x0, x1, y0, y1, face) in geometry.items()}


@dataclass(frozen=True)
class PdfReport:
    """A written PDF: its path, number of pages and the title of every page."""

    path: Path
    n_pages: int
    titles: tuple[str, ...]


def write_pdf(path: str | Path, pages: Iterable[Figure], *, title: str = "faultlab report",
              subject: str = "", footer: str = "") -> PdfReport:
    """Render ``pages`` into one PDF (page numbers added to each page's footer).

    The page titles are stored in the PDF's Keywords, so a reader (or a test) can find a
    page without rendering it.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    pages = list(pages)
    titles = tuple(page_title(p) for p in pages)
    keywords = "; ".join(t for t in titles if t)
    tmp = path.with_name(path.name + ".partial")
    try:
        with matplotlib.rc_context({"pdf.fonttype": 42, "font.family": "DejaVu Sans"}):
            with PdfPages(tmp, metadata={"Title": title, "Subject": subject, "Keywords": keywords,
                                         "Creator": "faultlab"}) as pdf:
                for i, fig in enumerate(pages, start=1):
                    fig.text(1 - _MARGIN_IN / fig.get_figwidth(), 0.25 / fig.get_figheight(),
                             f"{footer}{'  ·  ' if footer else ''}page {i} of {len(pages)}",
                             fontsize=7.5, color="0.45", ha="right", va="bottom")
                    pdf.savefig(fig)
                    pyplot = sys.modules.get("matplotlib.pyplot")
                    if pyplot is not None and getattr(fig.canvas, "manager", None) is not None:
                        pyplot.close(fig)  # made with pyplot, which holds on to it until closed
        tmp.replace(path)  # a reader never sees a half-written report
    except Exception as exc:  # e.g. the disk is full: no half-written file stays, the error names the report
        tmp.unlink(missing_ok=True)
        cause = exc if isinstance(exc, OSError) else exc.__context__  # matplotlib's close after a failed write
        if isinstance(cause, OSError):                                # raises a zlib.error of its own
            raise OSError(cause.errno, cause.strerror or str(cause), str(path)) from None
        raise
    return PdfReport(path=path, n_pages=len(pages), titles=titles)
