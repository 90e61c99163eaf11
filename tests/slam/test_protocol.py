from types import SimpleNamespace

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from faultlab.errors import SlamInputError, SlamOutputError
from faultlab.slam.protocol import (Estimate, Observations, SlamAdapter, _all_valid, as_control, as_start_pose,
                                    check_generator)


def test_observations_accept_empty_and_coerce_types():
    obs = Observations([1.0, 2.0], [0.1, -0.2], [3, 4])
    assert obs.ids.dtype == np.int64 and len(obs) == 2
    assert len(Observations.empty()) == 0


@pytest.mark.parametrize(
    "ranges, bearings, ids, message",
    [
        ([1.0, np.nan], [0.0, 0.0], [1, 2], "NaN"),
        ([1.0, -0.5], [0.0, 0.0], [1, 2], "negative range"),
        ([1.0], [0.0, 0.1], [1], "equal length"),
        ([[1.0]], [[0.0]], [[1]], "1-d"),
        ([1.0, 1.0], [0.0, 0.0], [1, 1], "twice"),
        ([1.0], [0.0], [1.5], "integers"),
    ],
)
def test_observations_reject_bad_input(ranges, bearings, ids, message):
    with pytest.raises(SlamInputError, match=message):
        Observations(ranges, bearings, ids)


def test_control_validation():
    np.testing.assert_array_equal(as_control((1, 2)), [1.0, 2.0])
    with pytest.raises(SlamInputError, match="shape"):
        as_control([1.0, 2.0, 3.0])
    with pytest.raises(SlamInputError, match="finite"):
        as_control([np.inf, 0.0])


def test_start_pose_validation_copies_and_names_the_slam():
    given = [1, 2, 3]
    pose = as_start_pose(given, where="mine")
    assert pose.dtype == float and pose.tolist() == [1.0, 2.0, 3.0]
    held = np.zeros(3)
    as_start_pose(held, where="mine")[0] = 5.0
    assert held[0] == 0.0  # a new array: the caller's pose is never changed
    for bad in ([1.0, 2.0], [0.0, np.nan, 0.0], [[0.0, 0.0, 0.0]]):
        with pytest.raises(SlamInputError, match="mine: start pose must be 3 finite numbers"):
            as_start_pose(bad, where="mine")
    check_generator(np.random.default_rng(0), where="mine")
    with pytest.raises(SlamInputError, match="mine: rng must be a numpy.random.Generator, got RandomState"):
        check_generator(np.random.RandomState(0), where="mine")


def test_estimate_validation_names_the_bad_landmark():
    est = Estimate(np.zeros(3), np.array([7, 9]), np.array([[0.0, 1.0], [np.nan, 2.0]]))
    with pytest.raises(SlamOutputError, match="landmark 9"):
        est.validate()
    with pytest.raises(SlamOutputError, match="shape"):
        Estimate(np.zeros(2), np.array([1]), np.zeros((1, 2))).validate()
    ok = Estimate(np.zeros(3), np.array([1]), np.array([[1.0, 2.0]])).validate()
    assert ok.as_dict() == {1: (1.0, 2.0)}


class _Recorder(SlamAdapter):
    def reset(self, pose, *, rng):
        self.calls = []

    def update(self, control, observations):
        self.calls.append((control, observations))

    def estimate(self):
        return Estimate(np.zeros(3), np.empty(0, dtype=np.int64), np.empty((0, 2)))


def test_step_validates_before_update():
    slam = _Recorder()
    slam.reset(np.zeros(3), rng=np.random.default_rng(0))
    slam.step([0.5, 0.1], ([1.0], [0.0], [2]))
    slam.step([0.0, 0.0])
    with pytest.raises(SlamInputError):
        slam.step([0.0, 0.0], ([-1.0], [0.0], [2]))
    assert len(slam.calls) == 2
    assert len(slam.calls[1][1]) == 0


@st.composite
def observation_streams(draw):
    """A scenario's observation arrays (a few steps), sometimes with a planted defect."""
    counts = draw(st.lists(st.integers(0, 4), min_size=1, max_size=5))
    m = sum(counts)
    ranges = draw(hnp.arrays(np.float64, m, elements=st.one_of(
        st.floats(0.0, 100.0), st.sampled_from([-0.0, -1.0, np.nan, np.inf]))))
    bearings = draw(hnp.arrays(np.float64, m, elements=st.one_of(st.floats(-4.0, 4.0), st.just(np.nan))))
    ids = draw(hnp.arrays(np.int64, m, elements=st.integers(0, 5)))
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    return SimpleNamespace(obs_range=ranges, obs_bearing=bearings, obs_ids=ids, obs_offsets=offsets)


@settings(max_examples=300, deadline=None)
@given(observation_streams())
def test_the_scenario_wide_observation_check_agrees_with_the_per_step_checks(sc):
    """Oracle: building every step's Observations with its own checks."""
    def per_step_ok():
        for t in range(sc.obs_offsets.size - 1):
            a, b = sc.obs_offsets[t], sc.obs_offsets[t + 1]
            try:
                Observations(sc.obs_range[a:b], sc.obs_bearing[a:b], sc.obs_ids[a:b])
            except SlamInputError:
                return False
        return True

    assert _all_valid(sc) == per_step_ok()
    if _all_valid(sc):
        a, b = sc.obs_offsets[-2], sc.obs_offsets[-1]
        fast = Observations._checked(sc.obs_range[a:b], sc.obs_bearing[a:b], sc.obs_ids[a:b])
        slow = Observations(sc.obs_range[a:b], sc.obs_bearing[a:b], sc.obs_ids[a:b])
        for name in ("ranges", "bearings", "ids"):
            got, want = getattr(fast, name), getattr(slow, name)
            assert got.dtype == want.dtype and np.array_equal(got, want, equal_nan=True)
        assert fast.hidden is slow.hidden is False and len(fast) == len(slow)
