"""No committed table prints a degenerate number.

Every CSV and Markdown file under ``reports/`` (the stores excepted) is scanned for: a zero-width
interval (a finite sample never pins a quantity down exactly), a p value of 0 (a test on a finite
sample has a smallest attainable p above 0), NaN or infinity printed as a number (a value that does
not exist is a blank cell or a word saying why), a point estimate outside its own interval, and a
probability, rate or variance-share index outside [0, 1].  Each check is shown to fail on a planted
example of its defect.
"""

from __future__ import annotations

import csv
import math
import re
from pathlib import Path

import pytest

REPORTS = Path(__file__).resolve().parents[1] / "reports"

#: Column names of p values (not their Monte Carlo standard errors, ``p_mc_se``).
P_COLUMN = re.compile(r"p|pvalue|p_value|p_(?![a-z0-9_]*_se$)[a-z0-9_]+|[a-z0-9_]+_p")
#: Column names whose values are probabilities, rates, shares or variance-share indices: in [0, 1].
UNIT_COLUMN = re.compile(r"S1|ST|rate|rate_[a-z_]+|[a-z_]+_rate|share|coverage|power|score|score_[ab]")
#: (lower, upper) column suffixes of an interval; the bare names too (``low, high``).
BOUNDS = (("low", "high"), ("lo", "hi"), ("lower", "upper"))
#: Where an interval's column prefix names no column, the point it belongs to is the first of these present.
POINTS = ("estimate", "diff", "rate_generated", "coef", "slope", "ratio", "effect", "mean", "rate_exact", "rate",
          "score")
#: Points of intervals whose prefix does not name them: a bootstrap interval belongs to the pool's rate.
OWN_POINTS = {"boot_": ("rate_exact",)}
#: Cell texts that print a non-number as a number.
NOT_A_NUMBER = {"nan", "-nan", "inf", "+inf", "-inf", "infinity", "-infinity"}

_NUM = r"-?\d+(?:\.\d+)?"
MD_DEFECTS = (
    ("zero-width interval", re.compile(rf"\(\s*({_NUM})\s*%?\s*[-–]\s*\1\s*%?\s*\)")),
    ("zero-width interval", re.compile(rf"\[\s*({_NUM})\s*%?\s*,\s*\1\s*%?\s*\]")),
    # as Python and numpy print them; prose ("answers with NaN") names the value, it does not print it
    ("nan/inf as a number", re.compile(r"(?<![\w.`'\"/-])(nan|-?inf)(?![\w.`'\"/-])")),
    ("p = 0", re.compile(r"\bp\s*=\s*0(?:\.0+)?(?![\d.eE])")),
)


def _float(text: str) -> float | None:
    try:
        return float(text)
    except ValueError:
        return None


def _close(a: float, b: float) -> bool:
    """Equal at the 10 significant digits a committed table carries (:data:`faultlab.precision.FLOAT_FORMAT`)."""
    return f"{a:.10g}" == f"{b:.10g}"


def _intervals(columns) -> list[tuple[str, str, str | None]]:
    """(lower, upper, point or None) column triples of a table's header."""
    found = []
    for lo, hi in BOUNDS:
        for c in columns:
            if c == lo or c.endswith("_" + lo):
                prefix = c[: -len(lo)]
                if prefix + hi in columns:
                    own = [prefix.rstrip("_"), prefix + "rate", *OWN_POINTS.get(prefix, ())] \
                        if prefix not in ("ci_", "") else []
                    point = next((p for p in [*own, *POINTS] if p in columns), None)
                    found.append((c, prefix + hi, point))
    return found


def scan_csv(path: Path) -> list[str]:
    """The degenerate values of one CSV table, as ``file:line: what`` strings."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        return []
    columns = list(rows[0].keys())
    intervals = _intervals(columns)
    found = []
    for line, row in enumerate(rows, start=2):
        where = f"{path}:{line}"
        for c in columns:
            text = (row.get(c) or "").strip()
            if text.lower() in NOT_A_NUMBER:
                found.append(f"{where}: {c} = {text} (nan/inf as a number)")
                continue
            v = _float(text)
            if v is None or c is None:
                continue
            if P_COLUMN.fullmatch(c) and v == 0.0:
                found.append(f"{where}: {c} = 0 (p = 0 from a finite sample)")
            if P_COLUMN.fullmatch(c) and not 0.0 <= v <= 1.0:
                found.append(f"{where}: {c} = {text} (p outside [0, 1])")
            if UNIT_COLUMN.fullmatch(c) and not -1e-12 <= v <= 1.0 + 1e-12 and (row.get("noise") or "") != "yes":
                found.append(f"{where}: {c} = {text} (outside [0, 1])")
        for lo, hi, point in intervals:
            a, b = _float((row.get(lo) or "").strip()), _float((row.get(hi) or "").strip())
            if a is None or b is None or not (math.isfinite(a) and math.isfinite(b)):
                continue
            if _close(a, b):
                found.append(f"{where}: {lo}..{hi} = {a} (zero-width interval)")
            x = _float((row.get(point) or "").strip()) if point else None
            if x is not None and math.isfinite(x) and (x < a and not _close(x, a) or x > b and not _close(x, b)):
                found.append(f"{where}: {point} = {x} outside {lo}..{hi} = [{a}, {b}]")
    return found


def scan_markdown(path: Path) -> list[str]:
    """The degenerate values of one Markdown file (outside code blocks and inline code)."""
    found = []
    fenced = False
    for line, text in enumerate(path.read_text(errors="replace").splitlines(), start=1):
        if text.lstrip().startswith("```"):
            fenced = not fenced
            continue
        if fenced or text.startswith("    "):
            continue
        text = re.sub(r"`[^`]*`", "", text)
        for what, rx in MD_DEFECTS:
            m = rx.search(text)
            if m:
                found.append(f"{path}:{line}: {m.group(0)!r} ({what})")
    return found


def scan(root: Path) -> list[str]:
    """The degenerate values of every committed CSV and Markdown table under ``root`` (stores excepted)."""
    found = []
    for p in sorted(root.rglob("*")):
        if "store" in p.relative_to(root).parts or not p.is_file():
            continue
        if p.suffix == ".csv":
            found += scan_csv(p)
        elif p.suffix == ".md":
            found += scan_markdown(p)
    return found


def test_no_committed_table_prints_a_degenerate_number():
    tables = [p for p in REPORTS.rglob("*") if p.suffix in (".csv", ".md")]
    assert len(tables) > 100
    found = scan(REPORTS)
    assert found == [], f"{len(found)} degenerate values, first: " + "\n".join(found[:20])


CLEAN_CSV = "variant,rate,ci_low,ci_high,p,p_min,p_mc_se,min_mde_mm\nf,0.5,0.3,0.7,0.04,0.0039,0,\n"


@pytest.mark.parametrize("header, row, defect", [
    ("variant,rate,ci_low,ci_high", "f,1.0,1.0,1.0", "zero-width"),
    ("variant,rate,ci_low,ci_high", "f,0.9999999999999999,0.99999999999999999,1.0", "zero-width"),
    ("slope,low,high", "0.1,0.1,0.1", "zero-width"),
    ("ratio,ratio_low,ratio_high", "1.2,1.2,1.2", "zero-width"),
    ("slope,low,high,p", "-0.05,-0.06,-0.04,0", "p = 0"),
    ("variant,p_holm", "f,0.0", "p = 0"),
    ("mutant,min_p", "m,0", "p = 0"),
    ("mutant,min_mde_mm", "m,inf", "nan/inf"),
    ("mutant,max_p_equivalence", "m,nan", "nan/inf"),
    ("case,mde_mm", "1,-inf", "nan/inf"),
    ("variant,rate,ci_low,ci_high", "f,0.9,0.5,0.8", "outside"),
    ("coef,low,high", "-3,-2,2", "outside"),
    ("response,parameter,S1,ST", "r,x,3.48,0.3", "outside [0, 1]"),
    ("response,parameter,S1,ST", "r,x,0.1,-1.48", "outside [0, 1]"),
    ("strategy,rate", "s,1.2", "outside [0, 1]"),
    ("variant,p", "f,1.5", "outside [0, 1]"),
])
def test_the_csv_scan_finds_each_planted_defect_and_passes_a_clean_table(tmp_path, header, row, defect):
    clean = tmp_path / "clean.csv"
    clean.write_text(CLEAN_CSV)
    assert scan_csv(clean) == []
    bad = tmp_path / "bad.csv"
    bad.write_text(f"{header}\n{row}\n")
    found = scan_csv(bad)
    assert found and all(defect in f for f in found), found


def test_a_blank_cell_and_an_index_marked_as_noise_pass(tmp_path):
    table = tmp_path / "t.csv"
    table.write_text("response,parameter,S1,ST,noise,min_mde_mm,p\nr,x,3.48,-1.48,yes,,\n")
    assert scan_csv(table) == []


@pytest.mark.parametrize("line, defect", [
    ("| missing_angle_wrap | 10 | 100 % (100-100) |", "zero-width"),
    ("| pairwise | mutation score | 20 | 5 | 86 % (86-86) | 80 % |", "zero-width"),
    ("ratio 1.00 [1.00, 1.00]", "zero-width"),
    ("| m | 1 | fixed | inconclusive | 0.176 | nan | 27 |", "nan/inf"),
    ("the smallest detectable shift is inf mm", "nan/inf"),
    ("| m | -inf |", "nan/inf"),
    ("slope -0.046 (p = 0)", "p = 0"),
    ("Welch p=0.000 on 4 clusters", "p = 0"),
])
def test_the_markdown_scan_finds_each_planted_defect(tmp_path, line, defect):
    md = tmp_path / "t.md"
    md.write_text(f"# A report\n\n| a | b |\n|---|---|\n{line}\n")
    found = scan_markdown(md)
    assert len(found) == 1 and defect in found[0], found


def test_the_markdown_scan_passes_words_code_and_honest_intervals(tmp_path):
    md = tmp_path / "t.md"
    md.write_text("# Infinite loops and nanoseconds\n\n100 % (99.999-100.000); p = 0.03; p = 0.0625 (smallest "
                  "attainable); ratio 0.98 [0.94, 1.03]; the adapter answers with NaN; `--nan-policy inf`\n\n```\nnan inf p = 0\n```\n")
    assert scan_markdown(md) == []


def test_the_scan_covers_every_table_but_the_stores(tmp_path):
    (tmp_path / "study" / "store").mkdir(parents=True)
    (tmp_path / "study" / "store" / "raw.csv").write_text("p\n0\n")
    (tmp_path / "study" / "t.csv").write_text("p\n0\n")
    (tmp_path / "README.md").write_text("p = 0\n")
    found = scan(tmp_path)
    assert len(found) == 2 and not any("store" in f for f in found), found
