"""Unit tables and the landmark index (faultlab.slam.bookkeeping)."""

import dataclasses
from typing import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.errors import ConfigError
from faultlab.slam.bookkeeping import LandmarkIndex, TrajectoryLog, UnitTable, best_pose


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


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 4), st.integers(1, 30), st.integers(0, 2 ** 32 - 1), st.booleans())
def test_best_pose_is_each_filters_highest_weight_particle_lowest_index_on_ties(b, n, seed, uniform):
    rng = np.random.default_rng(seed)
    poses = rng.normal(0, 5, (b, n, 3))
    logw = np.full((b, n), -np.log(n)) if uniform else rng.normal(0, 3, (b, n))
    got = best_pose(poses, logw)
    assert got.shape == (b, 3)
    for i in range(b):  # the slow way, filter by filter
        top = max(range(n), key=lambda j: (logw[i, j], -j))
        np.testing.assert_array_equal(got[i], poses[i, top])


def test_a_trajectory_log_grows_past_its_buffer_and_returns_a_copy():
    log = TrajectoryLog((2, 3))
    rows = np.arange(200 * 6, dtype=float).reshape(200, 2, 3)
    for r in rows:
        log.append(r)
    got = log.poses()
    np.testing.assert_array_equal(got, rows)
    got[0] = -1
    assert log.poses()[0, 0, 0] == 0 and len(log) == 200
