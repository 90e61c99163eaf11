"""Unit tables and the landmark index (faultlab.slam.bookkeeping)."""

import dataclasses
from typing import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.errors import ConfigError
from faultlab.slam.bookkeeping import LandmarkIndex, TrajectoryLog, UnitTable, mean_pose


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
@given(st.integers(1, 4), st.integers(1, 30), st.integers(0, 2 ** 32 - 1))
def test_mean_pose_is_the_weighted_mean_position_and_circular_mean_heading(b, n, seed):
    rng = np.random.default_rng(seed)
    poses = np.concatenate([rng.normal(0, 5, (b, n, 2)), rng.uniform(-np.pi, np.pi, (b, n, 1))], axis=2)
    logw = rng.normal(0, 3, (b, n)) + 40.0  # unnormalised
    got = mean_pose(poses, logw)
    assert got.shape == (b, 3)
    for i in range(b):  # the slow way, filter by filter
        w = np.exp(logw[i] - logw[i].max())
        np.testing.assert_allclose(got[i, :2], np.average(poses[i, :, :2], axis=0, weights=w), rtol=0, atol=1e-9)
        z = np.sum(w * np.exp(1j * poses[i, :, 2]))
        if abs(z) > 1e-6 * w.sum():  # the heading of a near-zero mean vector is ill-defined
            assert abs(np.angle(np.exp(1j * (got[i, 2] - np.angle(z))))) < 1e-9


def test_a_trajectory_log_grows_past_its_buffer_and_returns_a_copy():
    log = TrajectoryLog((2, 3))
    rows = np.arange(200 * 6, dtype=float).reshape(200, 2, 3)
    for r in rows:
        log.append(r)
    got = log.poses()
    np.testing.assert_array_equal(got, rows)
    got[0] = -1
    assert log.poses()[0, 0, 0] == 0 and len(log) == 200
