"""Multi-page PDF report: text and table pages drawn with matplotlib, written with PdfPages.

Pages are :class:`matplotlib.figure.Figure` objects made without pyplot, so no display and
no GUI backend is needed; :func:`write_pdf` renders them with matplotlib's PDF backend
(TrueType fonts embedded, so the text can be searched and extracted).
"""

from __future__ import annotations

import sys
import textwrap
from dataclasses import dataclass
from pathlib import Path
from typing import Iterable, Sequence

import matplotlib
import numpy as np
import pandas as pd
from matplotlib.backends.backend_pdf import PdfPages
from matplotlib.figure import Figure

from faultlab.report.figures import PAGE_SIZE

__all__ = ["PAGE_TITLE_ATTR", "PdfReport", "text_pages", "table_pages", "write_pdf", "page_title"]

_TITLE_SIZE = 15
_TEXT_SIZE = 9.5
_MARGIN_IN = 0.6
#: Attribute of a Figure holding its page title (see :func:`page_title`).
PAGE_TITLE_ATTR = "_faultlab_page_title"


def page_title(fig: Figure) -> str:
    """The title a page was made with ("" for figures made elsewhere)."""
    return getattr(fig, PAGE_TITLE_ATTR, "") or fig.get_suptitle()


def _new_page(title: str, subtitle: str | None = None, *, figsize=PAGE_SIZE) -> Figure:
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
        fig = _new_page(title if n == 0 else f"{title} (continued)", subtitle if n == 0 else None,
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


def _text_lengths(frame: pd.DataFrame) -> np.ndarray:
    """Longest text (header or cell) of every column, characters."""
    return np.array([max([len(str(c))] + [len(str(v)) for v in frame[c]]) for c in frame.columns],
                    dtype=float)


def _col_widths(frame: pd.DataFrame) -> np.ndarray:
    """Column widths (fractions of the table width) proportional to their longest text."""
    lengths = np.clip(_text_lengths(frame), 3, 60) + 1.5
    return lengths / lengths.sum()


#: Width of a (bold) character in em, generous: DejaVu Sans Bold digits are 0.70 em.
_CHAR_EM = 0.72


def _fitting_fontsize(frame: pd.DataFrame, widths: np.ndarray, table_width_pt: float) -> float:
    """Largest font size (pt) at which every column's longest text fits its width."""
    lengths = np.maximum(_text_lengths(frame), 1.0)
    return float(np.min(0.94 * widths * table_width_pt / (lengths * _CHAR_EM)))


def table_pages(title: str, frame: pd.DataFrame, *, note: str | None = None,
                colours: pd.DataFrame | None = None, bold: pd.DataFrame | None = None,
                max_rows: int = 30, fontsize: float | None = None, subtitle: str | None = None,
                figsize=PAGE_SIZE) -> list[Figure]:
    """A frame of strings as a table, split over pages of at most ``max_rows`` rows.

    Parameters
    ----------
    colours, bold : DataFrame, optional
        Same shape as ``frame``: a cell colour (any matplotlib colour, "" for none) and a
        boolean for bold text, per cell.
    note : str, optional
        Wrapped text under the table (a caption), on every page.
    """
    w, h = figsize
    frame = frame.astype(str).reset_index(drop=True)
    chunks = [frame.iloc[i:i + max_rows] for i in range(0, len(frame), max_rows)] or [frame]
    widths = _col_widths(frame) if frame.shape[1] else None
    # never larger than what fits the columns (cells would overlap), never below 4.5 pt
    fit = _fitting_fontsize(frame, widths, (w - 2 * _MARGIN_IN) * 72) if frame.shape[1] else 9.5
    fontsize = float(np.clip(min(9.5 if fontsize is None else fontsize, fit), 4.5, 9.5))
    pages = []
    for n, chunk in enumerate(chunks):
        fig = _new_page(title if n == 0 else f"{title} (continued)", subtitle, figsize=figsize)
        note_lines = textwrap.wrap(note, int((w - 2 * _MARGIN_IN) * 72 / (0.56 * 8.5))) if note else []
        note_h = (len(note_lines) * 1.45 * 8.5 / 72 + 0.15) / h if note_lines else 0
        top = 1 - (_MARGIN_IN + (0.65 if subtitle else 0.5)) / h
        ax = fig.add_axes([_MARGIN_IN / w, _MARGIN_IN / h + note_h,
                           1 - 2 * _MARGIN_IN / w, top - _MARGIN_IN / h - note_h])
        ax.set_axis_off()
        if chunk.empty:
            ax.text(0, 1, "(no rows)", va="top", fontsize=fontsize + 1)
        else:
            cell_colours = None
            if colours is not None:
                cc = colours.reset_index(drop=True).iloc[chunk.index]
                cell_colours = [[c if c else "white" for c in row] for row in cc.to_numpy()]
            table = ax.table(cellText=chunk.to_numpy().tolist(), colLabels=list(chunk.columns),
                             cellColours=cell_colours, colWidths=list(widths), loc="upper center",
                             cellLoc="center")
            table.auto_set_font_size(False)
            table.set_fontsize(fontsize)
            row_h = min(0.06, 0.95 / (len(chunk) + 1))
            for (r, c), cell in table.get_celld().items():
                cell.set_height(row_h)
                cell.set_linewidth(0.4)
                cell.set_edgecolor("0.7")
                if r == 0:
                    cell.set_text_props(fontweight="bold")
                    cell.set_facecolor("0.9")
                elif bold is not None and bool(bold.reset_index(drop=True).iloc[chunk.index[r - 1], c]):
                    cell.set_text_props(fontweight="bold")
        y = _MARGIN_IN / h + note_h - 0.1 / h
        for line in note_lines:
            fig.text(_MARGIN_IN / w, y, line, fontsize=8.5, va="top", ha="left", color="0.2")
            y -= 1.45 * 8.5 / 72 / h
        pages.append(fig)
    return pages


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
    return PdfReport(path=path, n_pages=len(pages), titles=titles)
