"""The site builder: pages written where they belong, every asset local, tables' cells as the frame holds them."""

from __future__ import annotations

import math
import re
from html.parser import HTMLParser
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.report.html.site import (BOKEH_JS, STATIC_DIR, Code, Links, Page, Plot, Table, Text, page_slug,
                                       write_site)


class _Refs(HTMLParser):
    """Every src/href of a page, and the text of its plain tables' cells."""

    def __init__(self):
        super().__init__()
        self.refs, self.cells, self._in_td = [], [], False

    def handle_starttag(self, tag, attrs):
        a = dict(attrs)
        for key in ("src", "href"):
            if a.get(key):
                self.refs.append(a[key])
        self._in_td = tag == "td"
        if tag == "td":
            self.cells.append("")

    def handle_endtag(self, tag):
        if tag == "td":
            self._in_td = False

    def handle_data(self, data):
        if self._in_td:
            self.cells[-1] += data


def refs_of(path: Path) -> _Refs:
    parser = _Refs()
    parser.feed(path.read_text(encoding="utf-8"))
    return parser


def test_every_page_and_bokeh_written_with_relative_links_that_resolve(tmp_path):
    from bokeh.plotting import figure

    plot = figure()
    plot.line([0, 1], [1, 2])
    frame = pd.DataFrame({"name": ["a", "b"], "page": ["sub/deeper/a.html", "index.html"], "x": [1.5, 2.5]})
    pages = [Page("index.html", "Home", (Text("Hello", ("one", "two")), Table("T", frame, key="t", links={"name": "page"}),
                                         Links("More", (("A", "sub/deeper/a.html", ""),)))),
             Page("sub/deeper/a.html", "A", (Plot("P", plot), Code("D", "+added\n-removed\n same"),
                                             Links("Back", (("home", "index.html", ""),))))]
    site = write_site(tmp_path / "site", pages, title="t", nav=(("Home", "index.html"),))
    assert [p.relative_to(site.root).as_posix() for p in site.pages] == ["index.html", "sub/deeper/a.html"]
    assert (site.root / STATIC_DIR / BOKEH_JS).stat().st_size > 500_000  # BokehJS itself, not a loader
    for page in site.pages:
        for ref in refs_of(page).refs:
            assert not re.match(r"^[a-z]+://", ref), ref  # nothing from the network
            assert (page.parent / ref).resolve().is_file(), (page, ref)
    assert site.n_bytes == sum(p.stat().st_size for p in site.root.rglob("*") if p.is_file())
    diff = (site.root / "sub/deeper/a.html").read_text()
    assert '<span class="add">+added' in diff and '<span class="del">-removed' in diff


def test_two_pages_with_one_path_are_refused(tmp_path):
    with pytest.raises(ValueError, match="share a path"):
        write_site(tmp_path, [Page("a.html", "A", ()), Page("a.html", "B", ())], title="t")
    assert not any(tmp_path.iterdir())


def test_text_is_escaped(tmp_path):
    site = write_site(tmp_path, [Page("index.html", "<b>", (Text("<i>", ("a < b & c",)),))], title="t")
    html = site.index.read_text()
    assert "a &lt; b &amp; c" in html and "<i>" not in html and "<b>" not in html


def test_a_page_without_tables_or_plots_loads_no_script(tmp_path):
    site = write_site(tmp_path, [Page("index.html", "A", (Text("x", ("y",)),))], title="t")
    assert "<script" not in site.index.read_text()


@settings(max_examples=25, deadline=None)
@given(st.lists(st.one_of(st.floats(allow_infinity=True, allow_nan=True, width=32), st.none()), min_size=1, max_size=6),
       st.integers(0, 4))
def test_plain_table_cells_show_numbers_to_the_digits_and_no_nan(values, digits):
    frame = pd.DataFrame({"v": pd.Series(values, dtype=float), "n": np.arange(len(values))})
    table = Table("T", frame, key="k", digits=digits, interactive=False)
    headers, rows = table.cells()
    assert headers == ["v", "n"]
    for value, (cell, count) in zip(values, rows):
        if value is None or not math.isfinite(value):
            assert cell == ("", "")  # NaN and inf are no numbers to show
        else:
            assert float(cell[0]) == pytest.approx(round(float(np.float64(value)), digits), abs=10 ** -digits)
        assert count[0] == str(int(count[0]))  # integers stay integers


def test_interactive_table_keeps_numbers_as_numbers_and_links_per_row(tmp_path):
    frame = pd.DataFrame({"case": ["c1", "c2"], "href": ["cases/1.html", "cases/2.html"], "rms": [1.25, np.nan],
                          "n": [3, 4], "ok": [True, False]})
    site = write_site(tmp_path, [Page("sub/p.html", "P", (Table("T", frame, key="cases", links={"case": "href"}),))],
                      title="t")
    html = (tmp_path / "sub/p.html").read_text()
    text = re.search(r"docs_json = '(.*?)';", html, re.S).group(1)  # the Bokeh document, as JSON
    assert '"../cases/1.html"' in text and '"../cases/2.html"' in text  # relative to the page
    assert "1.25" in text and '"yes"' in text and '"no"' in text
    assert "NaN" not in text  # a missing value is null, shown empty
    assert 'id="table-cases"' in html
    assert site.pages == (tmp_path / "sub/p.html",)


@given(st.lists(st.text(min_size=1, max_size=8), min_size=1, max_size=4))
def test_page_slug_is_a_safe_file_name(parts):
    slug = page_slug(*parts)
    assert slug and re.fullmatch(r"[A-Za-z0-9_.-]+", slug)
