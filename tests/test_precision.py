"""Tables at their written precision: ``write_csv`` rounds floats to 10 significant digits, and
``same_at_precision`` lets a written number move by one rounding step, never more."""

import math

import numpy as np
import pandas as pd
from hypothesis import given
from hypothesis import strategies as st

from faultlab.precision import FLOAT_FORMAT, SIGNIFICANT_DIGITS, same_at_precision, write_csv

finite = st.floats(allow_nan=False, allow_infinity=False, min_value=-1e300, max_value=1e300).filter(
    lambda v: abs(v) > 1e-300)  # a relative move: not of zero


def _csv(values, tmp_path, name="t.csv") -> str:
    return write_csv(pd.DataFrame({"case": range(len(values)), "rms_mm": values}), tmp_path / name).read_text()


def test_floats_are_written_to_ten_significant_digits(tmp_path):
    assert SIGNIFICANT_DIGITS == 10 and FLOAT_FORMAT == "%.10g"
    text = _csv([math.pi * 1000, 1 / 3, 2.5e-17, -0.0, math.nan], tmp_path)
    # the reference: Python's own rounding of each value to 10 significant digits
    assert text.splitlines() == ["case,rms_mm", "0,3141.592654", "1,0.3333333333", "2,2.5e-17", "3,-0", "4,"]


@given(finite, st.integers(1, 4))
def test_a_move_in_the_last_bits_is_the_same_at_precision(value, ulps):
    moved = value
    for _ in range(ulps):
        moved = np.nextafter(moved, math.inf)
    a, b = (f"case,x\n0,{FLOAT_FORMAT % v}\n" for v in (value, moved))
    assert same_at_precision(a, b)


@given(finite, st.integers(2, 9))
def test_a_move_of_two_or_more_units_in_the_last_written_digit_is_not(value, units):
    written = FLOAT_FORMAT % value
    exponent = math.floor(math.log10(abs(float(written)))) - (SIGNIFICANT_DIGITS - 1)
    moved = FLOAT_FORMAT % (float(written) + units * 10.0 ** exponent)
    if float(moved) != float(written):  # not lost in a float's own precision
        assert not same_at_precision(f"x\n{written}\n", f"x\n{moved}\n")


def test_a_rounding_boundary_crossed_by_one_bit_passes_and_a_real_change_does_not():
    half = 1.2345678905  # halfway between two 10-digit values
    below, above = np.nextafter(half, 0), np.nextafter(half, 2)
    assert FLOAT_FORMAT % below != FLOAT_FORMAT % above  # the bit flips the written last digit
    assert same_at_precision(f"{FLOAT_FORMAT % below}", f"{FLOAT_FORMAT % above}")
    assert not same_at_precision("1.234567890", "1.234567893")
    # a Markdown cell written with one decimal: one step is a rounding flip, two are a change
    assert same_at_precision("| rms | 12.3 mm |", "| rms | 12.4 mm |")
    assert not same_at_precision("| rms | 12.3 mm |", "| rms | 12.5 mm |")


def test_integers_and_text_must_be_equal():
    assert not same_at_precision("killed 15/15", "killed 14/15")
    assert not same_at_precision("systematic,0.5", "random,0.5")
    assert not same_at_precision("a,1.0", "a,1.0,2")
    assert same_at_precision("same text 1", "same text 1")
