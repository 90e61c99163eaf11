"""The sensor-fault contract: the CSR helpers against per-step Python oracles, seeding, validation."""

import pickle

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.errors import FaultError
from faultlab.faults import check_scenario
from faultlab.faults.sensor import SensorFault, gather_steps, select_observations, step_of_observations
from faultlab.faults.sensorfaults import BUILTIN_SENSOR_FAULTS
from faultlab.seeds import sensor_seed_sequence


@pytest.fixture(scope="module")
def scenario():
    return check_scenario(seed=0, n_steps=60)


def _steps(sc):
    """Per step, the list of (range, bearing, id) tuples: the slow oracle."""
    return [list(zip(*(a.tolist() for a in sc.observations(t)))) for t in range(sc.n_steps)]


def test_step_of_observations_matches_the_offsets(scenario):
    steps = step_of_observations(scenario)
    expected = [t for t in range(scenario.n_steps) for _ in range(len(scenario.observations(t)[0]))]
    assert steps.tolist() == expected


@settings(max_examples=30, deadline=None)
@given(data=st.data())
def test_gather_steps_delivers_the_source_step_batches(scenario, data):
    T = scenario.n_steps
    source = np.array(data.draw(st.lists(st.integers(-1, T - 1), min_size=T, max_size=T)))
    out = gather_steps(scenario, source)
    out.validate()
    orig = _steps(scenario)
    assert _steps(out) == [orig[s] if s >= 0 else [] for s in source]
    np.testing.assert_array_equal(out.controls, scenario.controls)


@settings(max_examples=30, deadline=None)
@given(seed=st.integers(0, 2**32 - 1))
def test_select_observations_keeps_exactly_the_marked_ones_in_their_steps(scenario, seed):
    keep = np.random.default_rng(seed).random(scenario.obs_range.size) < 0.5
    out = select_observations(scenario, keep)
    out.validate()
    it = iter(keep.tolist())
    expected = [[o for o in step if next(it)] for step in _steps(scenario)]
    assert _steps(out) == expected


def test_the_sensor_stream_is_separate_from_the_slam_stream():
    seed = 12345
    slam = np.random.default_rng(seed).random(4)
    a = np.random.default_rng(sensor_seed_sequence(seed, "obs_dropout")).random(4)
    b = np.random.default_rng(sensor_seed_sequence(seed, "wheel_slip")).random(4)
    assert not np.allclose(slam, a) and not np.allclose(a, b)


def test_a_fault_needs_exactly_one_of_perturbation_and_option():
    kw = dict(description="d", rationale="r", origin="o")
    with pytest.raises(FaultError, match="either a perturbation"):
        SensorFault(name="x", **kw)
    with pytest.raises(FaultError, match="reserved"):
        SensorFault(name="baseline", option="particles", configure=int, **kw)
    with pytest.raises(FaultError, match="invalid"):
        SensorFault(name="Bad Name", option="particles", configure=int, **kw)


def test_a_perturbation_that_touches_the_ground_truth_is_refused(scenario):
    import dataclasses

    def move_landmarks(sc, rng):
        return dataclasses.replace(sc, landmarks=sc.landmarks + 1.0)

    fault = SensorFault(name="cheat", description="d", rationale="r", origin="o", perturbation=move_landmarks)
    with pytest.raises(FaultError, match="ground truth"):
        fault.perturb(scenario, seed=0)


def test_builtins_pickle_and_name_their_parameters():
    for fault in BUILTIN_SENSOR_FAULTS:
        back = pickle.loads(pickle.dumps(fault))
        fn, fn_back = fault.perturbation or fault.configure, back.perturbation or back.configure
        assert back.name == fault.name and fn_back.func is fn.func and fn_back.keywords == fn.keywords
        assert fault.parameters and fault.parameter_text()
