"""Unit examples: recorded calls of the reference FastSLAM with realistic shapes, replayed exactly."""

import numpy as np
import pytest

from faultlab.errors import FaultError
from faultlab.faults.builtin import BUILTIN_FAULTS
from faultlab.faults.check import check_scenario, outputs_equal
from faultlab.mutation.examples import (
    EXAMPLE_PARTICLES,
    EXAMPLE_STEPS,
    EXTRA_EXAMPLES,
    fault_unit_examples,
    record_unit_examples,
    unit_examples,
)
from faultlab.mutation.source import unit_sources
from faultlab.slam import REFERENCE_STEPS, DeadReckoning, FastSlam, FastSlamConfig, FastSlamSteps
from faultlab.slam import units as U


@pytest.fixture(scope="module")
def examples():
    return unit_examples()


def _recorded(exs):
    return [e for e in exs if e.note.startswith("recorded")]


def test_every_unit_has_at_least_two_recorded_examples_with_realistic_shapes(examples):
    assert set(examples) == set(FastSlamSteps.unit_names())
    N = EXAMPLE_PARTICLES
    for unit, exs in examples.items():
        assert len(_recorded(exs)) >= 2, unit
    for e in _recorded(examples["ekf_update"]):
        (mu, P, H, S, nu), _ = e.make_args()
        k = mu.shape[1]
        assert k >= 2 and mu.shape == (N, k, 2) and P.shape == H.shape == S.shape == (N, k, 2, 2)
    for e in _recorded(examples["apply_resample"]):
        (state, idx), _ = e.make_args()
        assert state.poses.shape == (N, 3) and idx.shape == (N,)


def test_recorded_arguments_are_those_of_the_run():
    scenario = check_scenario(seed=0, n_steps=EXAMPLE_STEPS)
    first = _recorded(unit_examples()["motion_model"])[0]
    (poses, u), kwargs = first.make_args()
    np.testing.assert_array_equal(poses, np.tile(scenario.start_pose, (EXAMPLE_PARTICLES, 1)))
    assert kwargs["wrap"] is U.wrap_heading  # the unit itself, not the recorder that stood in for it
    # the first resampling that returns indices was kept (an output of another kind than None)
    outputs = [REFERENCE_STEPS.resample(*e.make_args()[0]) for e in _recorded(unit_examples()["resample"])]
    assert any(o is None for o in outputs) and any(o is not None for o in outputs)


def test_replays_are_fresh_copies_with_the_same_random_state(examples):
    for unit, exs in examples.items():
        f = getattr(REFERENCE_STEPS, unit)
        for e in exs:
            a1, k1 = e.make_args()
            out1 = f(*a1, **k1)
            a2, k2 = e.make_args()
            assert outputs_equal(out1, f(*a2, **k2)), (unit, e.note)  # same draws for random units
    (w, *_), _ = examples["resample"][-1].make_args()
    w[:] = -1.0
    assert (examples["resample"][-1].make_args()[0][0] >= 0).all()


def test_the_reference_writes_every_output_element(examples):
    """Built against NaN-poisoned np.empty, every unit gives the same outputs as the real reference."""
    sources, _ = unit_sources(REFERENCE_STEPS)
    for unit, exs in examples.items():
        poisoned = sources[unit].build(poison=True)
        for e in exs:
            a, k = e.make_args()
            expected = getattr(REFERENCE_STEPS, unit)(*a, **k)
            a, k = e.make_args()
            assert outputs_equal(poisoned(*a, **k), expected), (unit, e.note)


def test_builtin_fault_examples_and_extra_examples_are_included_once(examples):
    by_unit = fault_unit_examples()
    distinct = {(f.step, id(e.make_args)) for f in BUILTIN_FAULTS for e in f.examples}
    assert sum(len(v) for v in by_unit.values()) == len(distinct)
    assert len(by_unit["init_landmarks"]) == 1  # one example shared by two faults
    for unit, exs in {**by_unit, **EXTRA_EXAMPLES}.items():
        for e in exs:
            assert sum(x is e for x in examples[unit]) == 1


def test_recording_needs_units():
    with pytest.raises(FaultError, match="no replaceable units"):
        record_unit_examples(DeadReckoning(), check_scenario(n_steps=5), rng=np.random.default_rng(0))


def test_another_configuration_records_its_own_examples(examples):
    assert unit_examples(FastSlam(FastSlamConfig(particles=7))) is examples  # particles do not matter
    exs = unit_examples(FastSlam(FastSlamConfig(particles=7, std_v=0.2)), n_steps=20)
    (poses, u), _ = _recorded(exs["motion_model"])[0].make_args()
    assert poses.shape == (7, 3)
    (u, n, rng, config), _ = _recorded(exs["sample_controls"])[0].make_args()
    assert n == 7 and config.std_v == 0.2
    assert len(exs["extract_map"]) > len(_recorded(exs["extract_map"]))  # hand-written ones added
