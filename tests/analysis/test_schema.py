"""Table schemas: columns defined once, CSV round trips exact, bad tables refused with a clear error."""

import math

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.analysis.schema import (
    BY_SUITE,
    DETECTION_RATES,
    FALSE_ALARMS,
    ORACLE,
    PARAMETER_EFFECTS,
    SUITE_COMPARISONS,
    TABLES,
    TableSchema,
)
from faultlab.errors import ResultsError
from faultlab.precision import SIGNIFICANT_DIGITS
from faultlab.stats import (
    by_suite,
    compare_suites,
    detection_rates,
    false_alarm_rate,
    oracle_detections,
    parameter_effects,
)
from tests.stats.synthetic import frame, job

ALL_KINDS = TableSchema("all_kinds", "one column of every kind", ("i", "ni", "f", "s", "b"),
                        ("int", "Int", "float", "str", "bool"))


def _write_read(schema, df, tmp_path):
    path = schema.to_csv(df, tmp_path / f"{schema.name}.csv")
    return schema.read_csv(path)


rows = st.lists(st.tuples(
    st.integers(-2**62, 2**62),
    st.one_of(st.none(), st.integers(-2**62, 2**62)),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(alphabet=st.characters(blacklist_categories=("Cs",), blacklist_characters="\r"), max_size=12),
    st.booleans()), max_size=8)


@settings(max_examples=60, deadline=None)
@given(rows)
def test_csv_round_trip_keeps_every_kind_and_floats_to_their_written_digits(tmp_path_factory, values):
    df = ALL_KINDS.conform(pd.DataFrame(values, columns=list(ALL_KINDS.columns)))
    directory = tmp_path_factory.mktemp("rt")
    back = _write_read(ALL_KINDS, df, directory)
    pd.testing.assert_frame_equal(back.drop(columns="f"), df.drop(columns="f"), check_exact=True)
    # floats: the value rounded to SIGNIFICANT_DIGITS, as Python's own formatting rounds it, sign of zero kept;
    # an infinite value is a blank cell, read back as NaN (a table never prints inf as a number)
    expected = np.array([float(f"{v:.{SIGNIFICANT_DIGITS}g}") if not np.isinf(v) else np.nan for v in df["f"]])
    a, b = expected, back["f"].to_numpy()
    assert np.array_equal(np.isnan(a), np.isnan(b))
    assert np.array_equal(a.view(np.int64)[~np.isnan(a)], b.view(np.int64)[~np.isnan(b)])
    # what was read back writes the same file again (a value within a rounding step of the largest double
    # reads back as inf, which is then written blank)
    assert _write_read(ALL_KINDS, back, directory).equals(back.replace([np.inf, -np.inf], np.nan))


def test_awkward_values_survive(tmp_path):
    df = ALL_KINDS.conform(pd.DataFrame({
        "i": [0, -1], "ni": pd.array([None, 7], dtype="Int64"), "f": [0.1 + 0.2, 5e-324],
        "s": ['a, "quoted"\nline', ""], "b": [True, False]}))
    back = _write_read(ALL_KINDS, df, tmp_path)
    assert back["f"].tolist() == [0.3, 5e-324]  # 0.30000000000000004 to 10 significant digits
    assert back["s"].tolist() == ['a, "quoted"\nline', ""]
    assert back["ni"].isna().tolist() == [True, False] and back["ni"].iloc[1] == 7
    assert [str(d) for d in back.dtypes] == ["int64", "Int64", "float64", "object", "bool"]


def test_empty_tables_round_trip(tmp_path):
    for schema in TABLES:
        back = _write_read(schema, schema.empty(), tmp_path)
        pd.testing.assert_frame_equal(back, schema.empty())


def test_conform_orders_columns_and_refuses_missing_or_incomplete_ones():
    df = pd.DataFrame({"b": [True], "s": [math.nan], "f": [1], "ni": [math.nan], "i": [3.0], "extra": [0]})
    out = ALL_KINDS.conform(df)
    assert list(out.columns) == ["i", "ni", "f", "s", "b"]
    assert out["s"].tolist() == [""] and out["i"].dtype == np.int64 and out["f"].dtype == np.float64
    with pytest.raises(ResultsError, match="table all_kinds: missing column\\(s\\) s"):
        ALL_KINDS.conform(df.drop(columns="s"))
    with pytest.raises(ResultsError, match="all_kinds.i must not have missing values"):
        ALL_KINDS.conform(df.assign(i=[math.nan]))
    with pytest.raises(ResultsError, match="all_kinds.s holds a carriage return"):
        ALL_KINDS.conform(df.assign(s=["a\rb"]))


def test_a_file_with_other_columns_or_bad_values_is_refused(tmp_path):
    path = tmp_path / "x.csv"
    path.write_text("i,ni,f,s\n1,,2.0,a\n")
    with pytest.raises(ResultsError, match="x.csv: columns i, ni, f, s are not those of table all_kinds"):
        ALL_KINDS.read_csv(path)
    path.write_text("i,ni,f,s,b\n1,,2.0,a,yes\n")
    with pytest.raises(ResultsError, match="x.csv: column b"):
        ALL_KINDS.read_csv(path)
    with pytest.raises(ResultsError, match="cannot read table all_kinds"):
        ALL_KINDS.read_csv(tmp_path / "missing.csv")


def test_schemas_are_well_formed():
    names = [s.name for s in TABLES]
    assert len(set(names)) == len(names)
    with pytest.raises(ValueError, match="no kind for column 'mystery'"):
        TableSchema.define("t", "", ("suite", "mystery"))
    with pytest.raises(ValueError, match="unknown column kind"):
        TableSchema("t", "", ("a",), ("complex",))
    # a name keeps its kind across tables unless a table says otherwise
    assert ORACLE.dtypes["detected"] == "bool" and DETECTION_RATES.dtypes["detected"] == "int64"


def _results():
    rows = []
    for suite in ("systematic", "random"):
        for case in (1, 2, 3):
            for rep in (0, 1):
                base = 100.0 + 10 * case + rep
                rows.append(job(1, suite, case, "baseline", rep, base, map_size=20.0 * case))
                rows.append(job(1, suite, case, "motion_sign_error", rep,
                                base + (900.0 if case > 1 or suite == "random" else 5.0), map_size=20.0 * case))
    return frame(rows)


def test_statistics_tables_have_exactly_the_columns_of_their_functions():
    res = _results()
    assert tuple(by_suite(res).columns) == BY_SUITE.columns
    assert tuple(false_alarm_rate(res).columns) == FALSE_ALARMS.columns
    assert tuple(oracle_detections(res).columns) == ORACLE.columns
    assert tuple(compare_suites(res).columns) == SUITE_COMPARISONS.columns
    assert tuple(parameter_effects(res, parameters=["map_size"]).columns) == PARAMETER_EFFECTS.columns
    rates = detection_rates(res)
    assert DETECTION_RATES.columns[:len(rates.columns)] == ("suite", "variant") + tuple(rates.columns[2:])
