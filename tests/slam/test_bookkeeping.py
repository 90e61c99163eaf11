"""Unit tables and the landmark index (faultlab.slam.bookkeeping)."""

import dataclasses
from typing import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.errors import ConfigError
from faultlab.slam.bookkeeping import LandmarkIndex, UnitTable


def _double(x):
    return 2 * x


def _triple(x):
    return 3 * x


@dataclasses.dataclass(frozen=True)
class _Table(UnitTable):
    first: Callable = _double
    second: Callable = _triple


def test_unit_table_names_replacements_and_rejects_non_callables():
    assert _Table.unit_names() == ("first", "second")
    assert _Table().replaced() == ()
    t = dataclasses.replace(_Table(), second=lambda x: 3 * x)  # same behaviour, another function
    assert t.replaced() == ("second",)
    with pytest.raises(ConfigError, match=r"_Table\.first must be callable"):
        _Table(first=3)


@settings(max_examples=60, deadline=None)
@given(st.lists(st.lists(st.integers(-2**62, 2**62), max_size=12, unique=True), max_size=8))
def test_landmark_index_agrees_with_a_dict_in_order_of_first_observation(steps):
    index, ref = LandmarkIndex(), {}
    for ids in steps:
        ids = np.array(ids, dtype=np.int64)
        cols, seen = index.lookup(ids)
        assert seen.tolist() == [int(i) in ref for i in ids]
        assert cols[seen].tolist() == [ref[int(i)] for i in ids[seen]]
        new = ids[~seen]
        added = index.add(new)
        for i in new:
            ref[int(i)] = len(ref)
        assert added.tolist() == [ref[int(i)] for i in new]
    assert index.ids.tolist() == sorted(ref, key=ref.get) and len(index) == len(ref)
