"""The oracles on hand-made SLAMs whose verdict is known, the sign test, and the plugin catalogue."""

import functools
import math

import numpy as np
import pytest
from scipy.stats import binom

from faultlab.errors import ConfigError
from faultlab.metamorphic.check import metamorphic_scenario
from faultlab.campaigns.checkspec import DEFAULT_ORACLES
from faultlab.oracles import BUILTIN_ORACLES, all_oracles, get_oracle, judge_case, repetition_seeds, sign_test
from faultlab.slam import Estimate, SlamAdapter
from faultlab.slam.deadreckoning import DeadReckoning
from faultlab.slam.registry import build_slam


def test_sign_test_is_the_binomial_tail():
    rejected, p = sign_test([True] * 7 + [False], alpha=0.05)
    assert p == pytest.approx(binom.sf(6, 8, 0.5)) and rejected
    rejected, p = sign_test([True] * 4 + [False] * 4, alpha=0.05)
    assert p == pytest.approx(binom.sf(3, 8, 0.5)) and not rejected


class _Crashing(DeadReckoning):
    def estimate(self):
        est = super().estimate()
        return Estimate(est.pose * np.nan, est.landmark_ids, est.landmarks)


class _Shifted(DeadReckoning):
    """Dead reckoning whose map is moved 1 m east only when the world is rotated (breaks rigid motion)."""

    def reset(self, pose, *, rng):
        self._start = np.array(pose, dtype=float)
        super().reset(pose, rng=rng)

    def estimate(self):
        est = super().estimate()
        shift = 0.0 if self._start[2] == 0 else 1.0
        return Estimate(est.pose, est.landmark_ids, est.landmarks + [shift, 0.0])


class _Noisy(SlamAdapter):
    """Dead reckoning plus seed noise of 2 m on every landmark: stochastic and far worse than the floor."""

    def reset(self, pose, *, rng):
        self.dr, self.rng = DeadReckoning(), rng
        self.dr.reset(pose, rng=rng)

    def update(self, control, observations):
        self.dr.update(control, observations)

    def estimate(self):
        est = self.dr.estimate()
        return Estimate(est.pose, est.landmark_ids, est.landmarks + self.rng.normal(0, 2.0, est.landmarks.shape))


#: The oracles faultlab check applies by default.
CHECK_DEFAULT = [get_oracle(name) for name in DEFAULT_ORACLES]


def _judge(factory, **kw):
    s = metamorphic_scenario(seed=0, n_steps=60)
    return {r.oracle: r for r in judge_case("c", s, factory, oracles=CHECK_DEFAULT, seeds=repetition_seeds(0, "c", 8),
                                            alpha=0.05, reference=functools.partial(build_slam, "ekf", {}), **kw).results}


def test_correct_deterministic_slam_passes_every_oracle():
    res = _judge(DeadReckoning)
    assert {k: r.status for k, r in res.items()} == dict.fromkeys(res, "pass")
    assert math.isnan(res["floor"].p_value)  # judged exactly, no test over identical repetitions


def test_execution_oracle_flags_a_non_finite_estimate():
    res = _judge(_Crashing)
    assert res["execution"].failed
    assert "not finite" in res["execution"].message
    assert res["floor"].status == "skip"


def test_metamorphic_oracle_flags_a_broken_rigid_motion():
    res = _judge(_Shifted)
    assert res["metamorphic"].failed and res["metamorphic"].details["violated"] == ["rigid_motion"]


def test_floor_oracle_flags_a_map_worse_than_dead_reckoning_by_a_sign_test():
    res = _judge(_Noisy)
    assert res["floor"].failed and res["floor"].p_value <= 0.05 / 5
    assert res["execution"].status == "pass"


def test_the_catalogue_serves_the_builtins_by_name():
    assert [o.name for o in all_oracles(plugins=False)] == ["execution", "metamorphic", "floor", "differential",
                                                         "consistency", "budget"]
    assert get_oracle("floor") is BUILTIN_ORACLES[2]
    with pytest.raises(ConfigError, match="did you mean 'floor'"):
        get_oracle("flor")


class _ShiftedIds(DeadReckoning):
    """Maps every landmark under its id + 1 (an off-by-one a user might write)."""

    def estimate(self):
        est = super().estimate()
        return Estimate(est.pose, est.landmark_ids + 1, est.landmarks)


def test_metamorphic_oracle_flags_ids_the_case_does_not_have_instead_of_raising():
    res = _judge(_ShiftedIds)
    assert res["metamorphic"].failed and "id_permutation" in res["metamorphic"].details["violated"]
