"""Common random numbers by unit: a fault changes the random draws of the unit it replaces only.

The reference FastSLAM gives every unit in ``STREAM_UNITS`` its own generator (derived from the
SLAM's seed by unit name).  These tests instrument the random units -- a wrapper hands the unit a
proxy of its generator that logs every draw and records the generator's state before each call --
and compare a faulty run with the baseline run of the same seed.
"""

from __future__ import annotations

import dataclasses
import inspect

import numpy as np
import pytest

from faultlab.faults import Fault, all_faults
from faultlab.faults.builtin import BUILTIN_FAULTS
from faultlab.faults.check import check_scenario, estimates_identical
from faultlab.slam import REFERENCE_STEPS, FastSlam, FastSlamConfig, FastSlamSteps, run_slam
from faultlab.slam.streams import unit_streams
from faultlab.slam.contract import STREAM_UNITS

CFG = FastSlamConfig(particles=40)
SEED = 11


@pytest.fixture(scope="module")
def scenario():
    """The equivalent-mutant check's scenario, shortened: 100 idle steps + 80 active steps."""
    return check_scenario(seed=3, n_steps=80)


class RecordingGenerator:
    """Stands in for a ``numpy.random.Generator``: forwards every method and logs what it returns."""

    def __init__(self, rng: np.random.Generator, draws: list):
        self._rng = rng
        self._draws = draws

    def __getattr__(self, name):
        attr = getattr(self._rng, name)
        if not callable(attr):
            return attr

        def draw(*args, **kwargs):
            out = attr(*args, **kwargs)
            self._draws.append(np.array(out, dtype=float).ravel())
            return out

        return draw


@dataclasses.dataclass
class Log:
    """What one random unit saw in a run: its generator's state before each call and every draw."""

    states: list = dataclasses.field(default_factory=list)
    draws: list = dataclasses.field(default_factory=list)

    def values(self) -> np.ndarray:
        """All numbers drawn, in order."""
        return np.concatenate(self.draws) if self.draws else np.zeros(0)


def _recording(unit, log: Log, rng_position: int):
    def recorded(*args, **kwargs):
        args = list(args)
        rng = args[rng_position]
        log.states.append(rng.bit_generator.state)
        args[rng_position] = RecordingGenerator(rng, log.draws)
        return unit(*args, **kwargs)

    return recorded


def instrument(steps: FastSlamSteps, units) -> tuple[FastSlamSteps, dict[str, Log]]:
    """``steps`` with the random ``units`` wrapped by recorders; returns (steps, {unit: Log})."""
    logs = {}
    changes = {}
    for name in units:
        unit = getattr(steps, name)
        position = list(inspect.signature(getattr(REFERENCE_STEPS, name)).parameters).index("rng")
        logs[name] = Log()
        changes[name] = _recording(unit, logs[name], position)
    return dataclasses.replace(steps, **changes), logs


def run(steps, scenario, seed=SEED, slam_type=FastSlam):
    slam = slam_type(CFG, steps=steps)
    with np.errstate(all="ignore"):
        est = run_slam(slam, scenario, rng=np.random.default_rng(seed))
    return est, slam


# --------------------------------------------------------------------------- the contract


def test_stream_units_are_exactly_the_units_that_take_an_rng():
    with_rng = {name for name in FastSlamSteps.unit_names()
                if "rng" in inspect.signature(getattr(REFERENCE_STEPS, name)).parameters}
    assert with_rng == set(STREAM_UNITS) == {"sample_controls", "resample"}
    assert FastSlamSteps.stream_units == STREAM_UNITS
    assert "stream_units" not in FastSlamSteps.unit_names()  # a class constant, not a replaceable unit


def test_each_unit_draws_from_the_stream_of_its_name(scenario):
    """The draws equal those of ``unit_streams(default_rng(seed), [name])[name]``, computed apart."""
    steps, logs = instrument(REFERENCE_STEPS, STREAM_UNITS)
    _, slam = run(steps, scenario)
    assert set(slam.streams) == set(STREAM_UNITS)
    n = CFG.particles
    controls = unit_streams(np.random.default_rng(SEED), ["sample_controls"])["sample_controls"]
    sc = logs["sample_controls"]
    assert len(sc.draws) == scenario.n_steps - 100  # one call per non-empty update
    np.testing.assert_array_equal(sc.values(), controls.standard_normal((len(sc.draws), n, 2)).ravel())
    resample = unit_streams(np.random.default_rng(SEED), ["resample"])["resample"]
    rs = logs["resample"]
    assert 0 < len(rs.draws) < len(rs.states) == scenario.n_steps  # called every update, draws sometimes
    np.testing.assert_array_equal(rs.values(), resample.uniform(0.0, 1.0 / n, len(rs.draws)))
    assert slam.n_resamples == len(rs.draws)


# --------------------------------------------------------------------------- no-op faults


def _identity(original):
    return original


def _transparent(original):
    def unit(*args, **kwargs):
        return original(*args, **kwargs)

    return unit


@pytest.mark.parametrize("replacement", [_identity, _transparent])
@pytest.mark.parametrize("unit", FastSlamSteps.unit_names())
def test_a_no_op_fault_gives_bit_identical_estimates(scenario, unit, replacement):
    reference, _ = run(REFERENCE_STEPS, scenario)
    fault = Fault(name="test/no_op", step=unit, description="no-op", rationale="no-op", origin="test",
                  replacement=replacement)
    patched = fault.patch(REFERENCE_STEPS)
    assert (patched.replaced() == ()) == (replacement is _identity)
    est, _ = run(patched, scenario)
    assert estimates_identical(est, reference)


# --------------------------------------------------------------------------- built-in faults


def _compare_unreplaced_draws(steps_faulty, replaced: str, scenario):
    """Run baseline and faulty with the same seed, recording every random unit the fault does not replace."""
    others = [u for u in STREAM_UNITS if u != replaced]
    base_steps, base_logs = instrument(REFERENCE_STEPS, others)
    faulty_steps, faulty_logs = instrument(steps_faulty, others)
    run(base_steps, scenario)
    try:
        run(faulty_steps, scenario)
    except Exception:  # a crash ends the faulty run early: compare what it drew until then
        pass
    return base_logs, faulty_logs


def _assert_same_stream(base: Log, faulty: Log, unit: str, fault: str):
    """The faulty run drew the same numbers from ``unit``'s stream, as far as both drew.

    Returns how many numbers were compared (0 when the faulty run never drew from it).
    """
    a, b = base.values(), faulty.values()
    assert a.size > 0, f"{unit} drew nothing in the baseline; the comparison would be empty"
    assert faulty.states and faulty.states[0] == base.states[0], f"{fault}: {unit} starts from another stream"
    m = min(a.size, b.size)
    np.testing.assert_array_equal(a[:m], b[:m], err_msg=f"{fault} changed the draws of {unit}")
    return m


@pytest.mark.parametrize("fault", BUILTIN_FAULTS, ids=lambda f: f.name)
def test_a_builtin_fault_leaves_the_draws_of_every_other_unit_unchanged(scenario, fault):
    base, faulty = _compare_unreplaced_draws(fault.patch(REFERENCE_STEPS), fault.step, scenario)
    assert set(base) == set(STREAM_UNITS) - {fault.step}
    if "sample_controls" in base:
        # called once per non-empty update whatever the fault: the whole sequence must agree,
        # state before every call and every number drawn
        b, f = base["sample_controls"], faulty["sample_controls"]
        assert len(f.states) == len(b.states) == scenario.n_steps - 100
        assert f.states == b.states, f"{fault.name} moved the sample_controls stream"
        np.testing.assert_array_equal(f.values(), b.values())
    if "resample" in base:
        # draws only when it resamples, which the fault may make more or less frequent: the
        # k-th number drawn is the same in both runs
        compared = _assert_same_stream(base["resample"], faulty["resample"], "resample", fault.name)
        # shared control noise keeps all particles identical: their weights stay equal and the
        # filter never resamples, so there is nothing to compare; every other fault resamples
        assert (compared == 0) == (fault.name == "shared_control_noise")


def test_every_builtin_fault_that_draws_random_numbers_replaces_a_stream_unit():
    """Faults on other units never see a generator, so they cannot draw from anyone's stream."""
    for fault in all_faults(plugins=False):
        params = inspect.signature(getattr(fault.patch(REFERENCE_STEPS), fault.step)).parameters
        assert ("rng" in params) == (fault.step in STREAM_UNITS), fault.name


def _extra_resample_draws(original):
    def resample(w, n_eff, empty, rng, config):
        idx = original(w, n_eff, empty, rng, config)
        rng.random(3)  # consumed and thrown away
        return idx

    return resample


def _extra_control_draws(original):
    def sample_controls(u, n, rng, config):
        rng.standard_normal(5)
        return original(u, n, rng, config)

    return sample_controls


EXTRA_RESAMPLE_DRAWS = Fault(name="test/extra_resample_draws", step="resample",
                             description="draws three extra uniforms per update", rationale="test",
                             origin="test", replacement=_extra_resample_draws)
EXTRA_CONTROL_DRAWS = Fault(name="test/extra_control_draws", step="sample_controls",
                            description="draws five extra normals per update", rationale="test",
                            origin="test", replacement=_extra_control_draws)


class SharedStreamSlam(FastSlam):
    """The design CRN by unit replaces: every unit draws from the one generator the SLAM was reset with."""

    def _unit_streams(self, rng):
        return {name: rng for name in self.steps.stream_units}


def test_extra_draws_in_resample_leave_the_control_noise_identical(scenario):
    base_steps, base = instrument(REFERENCE_STEPS, ["sample_controls"])
    faulty_steps, faulty = instrument(EXTRA_RESAMPLE_DRAWS.patch(REFERENCE_STEPS), ["sample_controls"])
    ref, _ = run(base_steps, scenario)
    est, _ = run(faulty_steps, scenario)
    assert faulty["sample_controls"].states == base["sample_controls"].states
    np.testing.assert_array_equal(faulty["sample_controls"].values(), base["sample_controls"].values())
    assert not estimates_identical(est, ref)  # the shifted resampling draws do change the run
    # the instrument detects the failure it guards against: with one shared generator the extra
    # draws shift every later control-noise draw
    shared_base_steps, shared_base = instrument(REFERENCE_STEPS, ["sample_controls"])
    shared_faulty_steps, shared_faulty = instrument(EXTRA_RESAMPLE_DRAWS.patch(REFERENCE_STEPS),
                                                    ["sample_controls"])
    run(shared_base_steps, scenario, slam_type=SharedStreamSlam)
    run(shared_faulty_steps, scenario, slam_type=SharedStreamSlam)
    assert not np.array_equal(shared_faulty["sample_controls"].values(), shared_base["sample_controls"].values())


def test_extra_draws_in_sample_controls_leave_the_resampling_draws_identical(scenario):
    base, faulty = _compare_unreplaced_draws(EXTRA_CONTROL_DRAWS.patch(REFERENCE_STEPS), "sample_controls",
                                             scenario)
    assert _assert_same_stream(base["resample"], faulty["resample"], "resample", EXTRA_CONTROL_DRAWS.name) > 0


def test_a_faulty_variant_and_the_baseline_share_the_streams_of_a_seed(scenario):
    """Same seed -> the same per-unit generator states at reset, whatever the fault."""
    for fault in BUILTIN_FAULTS:
        faulty = fault.apply(FastSlam(CFG))
        faulty.reset(scenario.start_pose, rng=np.random.default_rng(SEED))
        ref = FastSlam(CFG)
        ref.reset(scenario.start_pose, rng=np.random.default_rng(SEED))
        assert {k: g.bit_generator.state for k, g in faulty.streams.items()} == \
               {k: g.bit_generator.state for k, g in ref.streams.items()}
