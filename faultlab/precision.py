"""The precision a written table carries, and comparing two tables at it.

A float computed by numpy, scipy, pandas or statsmodels may move in its last bits from one release
to the next (another summation order, another vectorised ``log``); the largest such move seen
between releases on a committed table was a relative 3.4e-13.  Tables therefore hold floats to
:data:`SIGNIFICANT_DIGITS` significant digits (``%.10g``): a last-bit move changes a written value
only where it straddles a rounding boundary, and then by one unit in its last digit.

:func:`same_at_precision` compares two table texts (CSV, Markdown, LaTeX, JSON) at the precision
they were written with: the text between numbers must be equal, and each number may differ from its
counterpart by at most one unit in its last written digit (one rounding step), whatever format wrote
it (``%.10g`` here, ``%.1f`` in a Markdown cell); integers (counts, ids) must be equal.

A table never prints ``nan`` or ``inf`` as a number: :func:`write_csv` leaves such a cell blank, and a
blank cell means the value does not exist for that row (not testable, nothing detectable, not computed;
each table's docstring says which).
"""

from __future__ import annotations

import re
from decimal import Decimal
from pathlib import Path

import numpy as np
import pandas as pd

__all__ = ["SIGNIFICANT_DIGITS", "FLOAT_FORMAT", "write_csv", "same_at_precision"]

#: Significant digits of every float in a written CSV table.
SIGNIFICANT_DIGITS = 10
#: The ``float_format`` of :meth:`pandas.DataFrame.to_csv` that writes them.
FLOAT_FORMAT = f"%.{SIGNIFICANT_DIGITS}g"

_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")


def write_csv(frame: pd.DataFrame, path: str | Path) -> Path:
    """Write ``frame`` as CSV (header, one line per row, no index), floats to :data:`SIGNIFICANT_DIGITS`,
    a NaN or infinite value as a blank cell."""
    path = Path(path)
    frame.replace([np.inf, -np.inf], np.nan).to_csv(path, index=False, float_format=FLOAT_FORMAT)
    return path


def _unit(token: str) -> Decimal:
    """One unit in the last written digit of ``token`` (``"12.30"`` -> 0.01, ``"1.5e-07"`` -> 1e-08)."""
    return Decimal(1).scaleb(Decimal(token).as_tuple().exponent)


def same_at_precision(a: str, b: str) -> bool:
    """Whether two table texts are equal at the precision they were written with.

    The text outside numbers must be identical; integers must be equal; every other number must equal
    its counterpart to within one unit in the last digit of the finer of the two (``%g`` drops
    trailing zeros: ``1`` and ``1.000000001`` are one rounding step apart, ``1`` and ``1.000000002`` two).
    """
    if a == b:
        return True
    parts_a, parts_b = _NUMBER.split(a), _NUMBER.split(b)
    if parts_a != parts_b:
        return False
    for x, y in zip(_NUMBER.findall(a), _NUMBER.findall(b)):
        if x == y:
            continue
        if not any(c in x + y for c in ".eE"):  # integers (counts, ids) are exact
            return False
        dx, dy = Decimal(x), Decimal(y)
        if abs(dx - dy) > min(_unit(x), _unit(y)):
            return False
    return True
