"""PDF pages: text and table pages, and the written file read back with pypdf."""

from __future__ import annotations

import pandas as pd
import pypdf  # test dependency (pyproject [test] extra): reads the PDF back
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure

from faultlab.report.pdf import PAGE_TITLE_ATTR, page_title, table_cells, table_pages, text_pages, write_pdf


def _texts(fig: Figure) -> list[str]:
    return [t.get_text() for t in fig.texts]


def test_text_pages_wrap_and_continue_on_new_pages():
    blocks = ["## Heading"] + [f"- bullet number {i} " + "word " * 40 for i in range(60)]
    pages = text_pages("Long text", blocks)
    assert len(pages) > 1
    assert page_title(pages[0]) == "Long text"
    assert page_title(pages[1]) == "Long text (continued)"
    every = [t for p in pages for t in _texts(p)]
    # every bullet appears once, wrapped: no line longer than the page allows
    assert sum(t.startswith("- bullet number") for t in every) == 60
    assert max(len(t) for t in every) < 200
    assert "Heading" in every


def test_short_text_fits_one_page():
    pages = text_pages("Short", ["one paragraph", "- a bullet", "- another"], subtitle="sub")
    assert len(pages) == 1
    assert {"Short", "sub", "one paragraph", "- a bullet", "- another"} <= set(_texts(pages[0]))


def test_table_pages_split_rows_and_colour_cells():
    frame = pd.DataFrame({"a": [str(i) for i in range(25)], "b": ["x"] * 25})
    colours = pd.DataFrame("", index=frame.index, columns=frame.columns)
    colours.loc[3, "b"] = "#c6efce"
    bold = pd.DataFrame(False, index=frame.index, columns=frame.columns)
    bold.loc[3, "b"] = True
    pages = table_pages("T", frame, colours=colours, bold=bold, max_rows=10, note="a note")
    assert [page_title(p) for p in pages] == ["T", "T (continued)", "T (continued)"]
    cells = table_cells(pages[0].axes[0])
    assert len(cells) == (10 + 1) * 2  # header + 10 rows, 2 columns
    assert cells[(0, 0)].text.get_text() == "a" and cells[(0, 0)].text.get_fontweight() == "bold"
    assert cells[(0, 0)].facecolor == to_rgba("0.9")                       # the header's grey
    assert cells[(4, 1)].text.get_text() == "x"
    assert cells[(4, 1)].facecolor == to_rgba("#c6efce")
    assert cells[(4, 1)].text.get_fontweight() == "bold"
    assert cells[(5, 1)].facecolor == to_rgba("white") and cells[(5, 1)].text.get_fontweight() == "normal"
    # the cells tile the axes: rows top to bottom, columns left to right, no gap
    assert cells[(0, 0)].y1 == 1 and cells[(10, 1)].y0 == 0 and cells[(0, 0)].x0 == 0 and cells[(0, 1)].x1 == 1
    assert all(cells[(r, 0)].y0 == cells[(r + 1, 0)].y1 for r in range(10))
    # each text sits inside its cell
    for cell in cells.values():
        x, y = cell.text.get_position()
        assert cell.x0 <= x <= cell.x1 and cell.y0 <= y <= cell.y1
    last = table_cells(pages[2].axes[0])
    assert last[(5, 0)].text.get_text() == "24"
    assert "a note" in _texts(pages[0])


def test_empty_table_page_says_so():
    pages = table_pages("Empty", pd.DataFrame({"a": []}))
    assert len(pages) == 1
    assert "(no rows)" in [t.get_text() for t in pages[0].axes[0].texts]


def test_write_pdf_is_readable_and_searchable(tmp_path):
    pages = text_pages("First page", ["hello report"]) + table_pages(
        "Table II: a table", pd.DataFrame({"R1C1": ["5616", "9038"]}))
    extra = Figure()
    extra.suptitle("A plain figure")
    setattr(extra, PAGE_TITLE_ATTR, "")
    pages.append(extra)
    info = write_pdf(tmp_path / "sub" / "r.pdf", pages, title="T", subject="S", footer="faultlab test")
    assert info.n_pages == 3 and info.path.is_file()
    assert info.titles == ("First page", "Table II: a table", "A plain figure")
    assert not (tmp_path / "sub" / "r.pdf.partial").exists()
    reader = pypdf.PdfReader(str(info.path))
    assert len(reader.pages) == 3
    text = [p.extract_text() for p in reader.pages]
    assert "hello report" in text[0] and "First page" in text[0]
    assert "Table II: a table" in text[1] and "9038" in text[1]
    assert "page 2 of 3" in text[1] and "faultlab test" in text[1]
    meta = reader.metadata
    assert meta.title == "T" and meta.subject == "S"
    assert "Table II: a table" in meta["/Keywords"]


def _drawn(fig: Figure):
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    return canvas.get_renderer()


def test_tables_are_at_least_8_pt_sized_to_their_content_with_the_caption_under_them():
    wide = pd.DataFrame({f"column {i}": [f"{1000 * i + r}" for r in range(12)] for i in range(22)})
    wide.insert(0, "name", [f"row {r}" for r in range(12)])
    pages = table_pages("Wide", wide, note="the caption", key_columns=1)
    assert len(pages) > 1 and all("[columns" in page_title(p) for p in pages)  # split by columns, not shrunk
    for page in pages:
        renderer = _drawn(page)
        (ax,) = page.axes
        cells = table_cells(ax)
        assert cells and min(cell.text.get_fontsize() for cell in cells.values()) >= 8.0
        # Every column is about as wide as its widest text: never 40 % blank.
        axes_w = ax.get_window_extent(renderer).width
        columns = {c for _, c in cells}
        for c in columns:
            col = [cells[(r, cc)] for r, cc in cells if cc == c]
            text_w = max(cell.text.get_window_extent(renderer).width for cell in col)
            cell_w = (col[0].x1 - col[0].x0) * axes_w
            assert text_w <= cell_w and text_w >= 0.6 * cell_w
        # The key column is repeated on every page; the caption sits right under the table.
        assert cells[(1, 0)].text.get_text() == "row 0"
        table_bottom = ax.get_window_extent(renderer).y0
        (caption,) = [t for t in page.texts if t.get_text() == "the caption"]
        gap = table_bottom - caption.get_window_extent(renderer).y1
        assert 0 <= gap < 0.3 * page.dpi


def test_long_cell_texts_wrap_instead_of_shrinking_the_font():
    frame = pd.DataFrame({"name": ["a", "b"], "text": ["word " * 80, "short"]})
    (page,) = table_pages("Long", frame)
    cells = table_cells(page.axes[0])
    assert cells[(1, 1)].text.get_text().count("\n") >= 2
    assert cells[(1, 1)].text.get_fontsize() >= 8.0
