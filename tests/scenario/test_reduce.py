"""Reductions of a case stay consistent and keep exactly what they say."""

import numpy as np
import pytest

from faultlab.errors import ScenarioError
from faultlab.metamorphic.check import metamorphic_scenario
from faultlab.scenario.generator import fixed_case_scenario
from faultlab.scenario.reduce import drop_idle_steps, idle_steps, keep_landmarks, size, truncate


def _observations(s):
    step = np.repeat(np.arange(s.n_steps), np.diff(s.obs_offsets))
    return list(zip(step.tolist(), s.obs_ids.tolist(), s.obs_range.tolist()))


def test_truncate_is_the_prefix():
    s = metamorphic_scenario(seed=1, n_steps=50)
    t = truncate(s, 20)
    assert t.n_steps == 20 and np.array_equal(t.true_poses, s.true_poses[:21])
    assert _observations(t) == [o for o in _observations(s) if o[0] < 20]
    with pytest.raises(ScenarioError):
        truncate(s, 0)


def test_keep_landmarks_removes_exactly_their_observations():
    s = metamorphic_scenario(seed=1, n_steps=50)
    keep = [int(i) for i in s.landmark_ids[::3]]
    k = keep_landmarks(s, keep)
    assert sorted(k.landmark_ids.tolist()) == sorted(keep)
    assert _observations(k) == [o for o in _observations(s) if o[1] in set(keep)]
    assert np.array_equal(k.controls, s.controls)
    assert size(k)["landmarks"] == len(keep)


def test_drop_idle_steps_keeps_motion_and_observations():
    s = fixed_case_scenario({"map_size": 16.0, "inactivity": 30}, seed=2, n_steps=40)
    idle = idle_steps(s)
    assert idle.size > 0
    d = drop_idle_steps(s)
    assert d.n_steps == s.n_steps - idle.size
    assert np.array_equal(d.controls, np.delete(s.controls, idle, axis=0))
    assert sorted((i, r) for _, i, r in _observations(d)) == sorted((i, r) for _, i, r in _observations(s))
    assert np.array_equal(d.true_poses[-1], s.true_poses[-1])
