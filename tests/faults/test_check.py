"""Every fault changes the output, faults never leak, and the check flags equivalent mutants."""

import math

import numpy as np
import pytest

from faultlab.errors import FaultError
from faultlab.faults import Fault, all_faults, apply_faults, get_fault
from faultlab.faults.check import (
    CHECK_CASE_OVERRIDES,
    CheckStatus,
    check_faults,
    check_scenario,
    estimate_difference,
    estimates_identical,
)
from faultlab.slam import REFERENCE_STEPS, FastSlam, FastSlamConfig, FastSlamSteps, run_slam
from faultlab.slam.protocol import Estimate


def _identity(original):
    return original


def _raise_in_motion(original):
    def motion_model(poses, u, *, wrap):
        raise FloatingPointError("diverged")

    return motion_model


#: Replaces a unit by itself: an equivalent mutant by construction.
IDENTITY = Fault(name="test/identity", step="resample", description="returns the original unit",
                 rationale="equivalent by construction", origin="test", replacement=_identity)
#: A fault whose SLAM always raises.
CRASHER = Fault(name="test/crasher", step="motion_model", description="raises", rationale="crashes",
                origin="test", replacement=_raise_in_motion)

ALL_NAMES = [f.name for f in all_faults()]
#: Faults whose filter takes more than a few seconds on the check scenario (sequential sharer updates).
SLOW_FAULTS = {"paper_aliasing"}


def _run(slam, scenario, seed=0):
    return run_slam(slam, scenario, rng=np.random.default_rng(seed))


@pytest.fixture(scope="module")
def check_case():
    """The check's fixed scenario, shortened (150 active + 100 idle steps), and the reference estimate."""
    scenario = check_scenario(seed=0, n_steps=150)
    return scenario, _run(FastSlam(), scenario)


@pytest.mark.parametrize("name", [pytest.param(n, marks=pytest.mark.slow) if n in SLOW_FAULTS else n
                                  for n in ALL_NAMES])
def test_every_registered_fault_changes_the_output_on_the_fixed_scenario(check_case, name):
    scenario, reference = check_case
    fault = get_fault(name)
    try:
        with np.errstate(all="ignore"):
            est = _run(fault.apply(FastSlam()), scenario)
    except Exception as exc:  # a crash is a change of output too, but no built-in should crash here
        pytest.fail(f"{name} crashed on the check scenario: {exc}")
    assert not estimates_identical(est, reference), f"{name} is an equivalent mutant on the check scenario"


def test_check_scenario_exercises_angles_inactivity_and_landmarks_near_x0():
    sc = check_scenario(seed=0)
    assert CHECK_CASE_OVERRIDES["rotation_error"] == pytest.approx(2 * math.pi)
    assert np.max(sc.obs_bearing) > math.pi  # bearings offset by 2 pi: missing_angle_wrap matters
    empty = (np.diff(sc.obs_offsets) == 0) & np.all(sc.controls == 0.0, axis=1)
    assert empty.sum() == CHECK_CASE_OVERRIDES["inactivity"]  # empty updates: naive_resampling matters
    assert np.min(np.abs(sc.landmarks[:, 0])) < 0.01  # new_landmark_near_zero can misfire
    # the same seed gives the same scenario (a *fixed* scenario)
    np.testing.assert_array_equal(check_scenario(seed=0).obs_bearing, sc.obs_bearing)


def test_faults_never_leak_into_the_reference():
    scenario = check_scenario(seed=1, n_steps=40)
    cfg = FastSlamConfig(particles=20)
    reference = FastSlam(cfg)
    first = _run(reference, scenario, seed=7)
    for fault in all_faults():  # reference, fault A, reference, fault B, ...
        with np.errstate(all="ignore"):
            try:
                _run(fault.apply(reference), scenario, seed=7)
            except Exception:
                pass
        again = _run(reference, scenario, seed=7)
        assert estimates_identical(again, first), f"reference changed after running {fault.name}"
    assert estimates_identical(_run(FastSlam(cfg), scenario, seed=7), first)
    with get_fault("missing_angle_wrap").applied(reference) as faulty:
        assert faulty.steps.wrap_bearing is not REFERENCE_STEPS.wrap_bearing
        _run(faulty, scenario, seed=7)
    everything = apply_faults(reference, [f for f in all_faults() if f.step not in ("motion_model",)])
    assert len(everything.steps.replaced()) > 5
    assert reference.steps is REFERENCE_STEPS and REFERENCE_STEPS.replaced() == ()
    assert FastSlamSteps() == REFERENCE_STEPS
    assert estimates_identical(_run(reference, scenario, seed=7), first)


def test_check_flags_equivalent_and_crashing_faults():
    scenario = check_scenario(seed=2, n_steps=40)
    report = check_faults([IDENTITY, "missing_angle_wrap", "tests.faults.test_check:CRASHER"],
                          scenario=scenario, n_seeds=2, particles=20)
    by_name = {c.name: c for c in report}
    assert len(report) == 3 and report[0].name == "test/identity"
    ident = by_name["test/identity"]
    assert ident.status is CheckStatus.EQUIVALENT and ident.equivalent
    assert (ident.n_identical, ident.n_seeds) == (2, 2)
    assert ident.map_diff_m == 0.0 and ident.pose_diff_m == 0.0
    wrap = by_name["missing_angle_wrap"]
    assert wrap.status is CheckStatus.DIFFERS and wrap.n_identical == 0 and wrap.map_diff_m > 0.05
    crash = by_name["test/crasher"]
    assert crash.status is CheckStatus.CRASH and "FloatingPointError: diverged" in crash.error
    assert report.equivalent == ["test/identity"] and not report.ok
    text = str(report)
    assert "EQUIVALENT" in text and "test/identity" in text and "crash of test/crasher" in text
    assert np.isfinite(report.reference_spread_m)
    assert 0 < report.reference_rms_mm < 1000 and wrap.rms_mm > report.reference_rms_mm
    assert ident.rms_mm == pytest.approx(report.reference_rms_mm) and np.isnan(crash.rms_mm)
    assert "baseline (reference)" in text


def test_check_passes_when_no_fault_is_equivalent():
    scenario = check_scenario(seed=2, n_steps=40)
    report = check_faults(["motion_sign_error"], scenario=scenario, n_seeds=1, particles=20)
    assert report.ok and report.equivalent == [] and "all 1 faults change the output" in str(report)
    with pytest.raises(FaultError, match="n_seeds"):
        check_faults(["motion_sign_error"], scenario=scenario, n_seeds=0)
    with pytest.raises(FaultError, match="unknown fault"):
        check_faults(["no_such_fault"], scenario=scenario)


def test_estimate_difference_by_hand():
    a = Estimate(np.array([0.0, 0.0, 0.1]), np.array([1, 2, 3]), np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 0.0]]))
    b = Estimate(np.array([3.0, 4.0, 0.1]), np.array([2, 3, 4]), np.array([[1.0, 2.0], [2.0, 3.0], [9.0, 9.0]]))
    rms, pose, mismatch = estimate_difference(a, b)
    assert rms == pytest.approx(math.sqrt((1.0 + 9.0) / 2))  # ids 2 and 3 in common
    assert pose == pytest.approx(5.0)
    assert mismatch == 2  # id 1 only in a, id 4 only in b
    assert estimates_identical(a, a) and not estimates_identical(a, b)
    c = Estimate(a.pose.copy(), a.landmark_ids.copy(), a.landmarks + 1e-15)
    assert not estimates_identical(a, c)  # bitwise, not approximate


def _dropout(p):
    import dataclasses
    import functools

    from faultlab.faults.sensorfaults import drop_observations

    return dataclasses.replace(get_fault("obs_dropout"), name=f"test/dropout_{p:g}".replace(".", "_"),
                               perturbation=functools.partial(drop_observations, p=p))


def test_sensor_faults_are_checked_on_their_stream_and_option_with_the_same_seeds():
    import dataclasses

    scenario = check_scenario(seed=2, n_steps=40)
    budget = get_fault("particle_budget")
    report = check_faults([_dropout(1.0), _dropout(0.0), budget], scenario=scenario, n_seeds=2, particles=20)
    by_name = {c.name: c for c in report}
    # planted references: the reference FastSLAM run by hand on the case without observations, and
    # with a quarter of the particles, each with the check's SeedSequence([seed, 1, k])
    seeds = [np.random.SeedSequence([0, 1, k]) for k in range(2)]
    config = FastSlamConfig(particles=20)
    blind = dataclasses.replace(scenario, obs_offsets=np.zeros_like(scenario.obs_offsets),
                                obs_range=scenario.obs_range[:0], obs_bearing=scenario.obs_bearing[:0],
                                obs_ids=scenario.obs_ids[:0])
    ref = [run_slam(FastSlam(config), scenario, rng=np.random.default_rng(ss)) for ss in seeds]
    none = [run_slam(FastSlam(config), blind, rng=np.random.default_rng(ss)) for ss in seeds]
    few = [run_slam(FastSlam(FastSlamConfig(particles=5)), scenario, rng=np.random.default_rng(ss)) for ss in seeds]
    total = by_name["test/dropout_1"]
    assert total.status is CheckStatus.DIFFERS and total.n_identical == 0
    assert total.pose_diff_m == pytest.approx(np.mean([estimate_difference(a, b)[1] for a, b in zip(none, ref)]))
    assert by_name["test/dropout_0"].status is CheckStatus.EQUIVALENT  # drops nothing: the stream is unchanged
    limited = by_name["particle_budget"]
    assert limited.status is CheckStatus.DIFFERS and limited.step == "slam option particles"
    assert limited.map_diff_m == pytest.approx(np.mean([estimate_difference(a, b)[0] for a, b in zip(few, ref)]))
