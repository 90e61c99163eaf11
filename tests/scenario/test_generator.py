import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.errors import ScenarioError
from faultlab.scenario import ScenarioConfig, fixed_case_scenario, generate_scenario
from faultlab.scenario.model import _ARRAYS
from faultlab.space import FIXED_VALUES, CaseSpec, build_suite, table1_space


def _case(**over):
    return CaseSpec(dict(FIXED_VALUES, **over))


def test_generates_every_systematic_case_consistently():
    cases = build_suite("systematic", table1_space(), rng=np.random.default_rng(3))
    for case in cases:
        sc = generate_scenario(case, rng=np.random.default_rng(1), n_steps=120, seed=1)
        cfg = ScenarioConfig.from_case(case, n_steps=120)
        assert sc.n_steps == 120 + cfg.inactivity
        assert sc.landmarks.shape == (cfg.n_landmarks, 2)
        assert sc.seed == 1 and sc.case is case
        assert sc.meta["config"]["n_landmarks"] == cfg.n_landmarks
        assert sc.obs_ids.dtype == np.int64 and sc.landmark_ids.dtype == np.int64
        assert set(np.unique(sc.obs_ids)) <= set(sc.landmark_ids)
        sc.validate()


@settings(max_examples=10, deadline=None)
@given(seed=st.integers(0, 2**63 - 1), suite_seed=st.integers(0, 1000))
def test_same_seed_gives_byte_identical_cases(seed, suite_seed):
    case = build_suite("random", table1_space(), rng=np.random.default_rng(suite_seed), n_cases=1)[0]
    case = CaseSpec(dict(case.values, inactivity=min(int(case.values["inactivity"]), 50),
                         map_size=min(float(case.values["map_size"]), 60.0)))
    a = generate_scenario(case, rng=np.random.default_rng(seed), n_steps=60)
    b = generate_scenario(case, rng=np.random.default_rng(seed), n_steps=60)
    for k in _ARRAYS:
        x, y = getattr(a, k), getattr(b, k)
        assert x.dtype == y.dtype and x.shape == y.shape
        assert x.tobytes() == y.tobytes(), k
    assert a.meta == b.meta
    c = generate_scenario(case, rng=np.random.default_rng(seed + 1), n_steps=60)
    assert c.landmarks.tobytes() != a.landmarks.tobytes()


def test_fixed_case_scenario_is_the_fixed_case_with_overrides_from_one_seed():
    sc = fixed_case_scenario({"map_size": 16.0, "inactivity": 10}, seed=7, n_steps=40)
    assert sc.case.values == {**FIXED_VALUES, "map_size": 16.0, "inactivity": 10}
    assert sc.seed == 7 and sc.n_steps == 40 + 10
    by_hand = generate_scenario(CaseSpec({**FIXED_VALUES, "map_size": 16.0, "inactivity": 10}),
                                rng=np.random.default_rng(np.random.SeedSequence(7)), n_steps=40)
    for k in _ARRAYS:
        assert getattr(sc, k).tobytes() == getattr(by_hand, k).tobytes(), k
    other = fixed_case_scenario({"map_size": 16.0, "inactivity": 10}, seed=8, n_steps=40)
    assert other.landmarks.tobytes() != sc.landmarks.tobytes()


def test_defaults_match_the_paper():
    sc = generate_scenario(_case(), rng=np.random.default_rng(0))
    assert sc.n_steps == 1000
    assert sc.meta["config"]["sensor_range"] == 2.0 and sc.meta["config"]["min_distance"] == 0.1
    assert sc.landmarks.shape == (320, 2)  # 64 m^2 x 5 lm/m^2
    np.testing.assert_array_equal(sc.start_pose, [0.0, 0.0, 0.0])


def test_sensor_range_is_respected():
    case = _case(field_of_view=2 * math.pi, **{k: 0.0 for k in ("variance_distance", "variance_angle",
                                                                   "outlier_probability")})
    sc = generate_scenario(case, rng=np.random.default_rng(0), n_steps=50, sensor_range=1.0)
    assert sc.obs_range.max() <= 1.0 and sc.obs_range.size > 0


def test_bad_input():
    with pytest.raises(TypeError, match="Generator"):
        generate_scenario(_case(), rng=0)
    with pytest.raises(ScenarioError, match="no landmarks"):
        generate_scenario(_case(map_size=0.5, landmark_density=1.0), rng=np.random.default_rng(0), n_steps=5)
    with pytest.raises(ScenarioError, match="cannot place"):
        generate_scenario(_case(map_size=4.0, landmark_density=15.0), rng=np.random.default_rng(0), n_steps=5,
                          min_distance=0.5)
