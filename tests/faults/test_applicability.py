"""Which faults apply to which SLAM, against a brute-force patch of each (faultlab.faults.applicability)."""

import dataclasses

import pytest

from faultlab.errors import ConfigError, FaultError, UnknownPluginError
from faultlab.faults import (
    applicable_faults,
    fault_applies,
    not_applicable,
    slam_units,
    builtin_faults,
    step_names,
)
from tests.faults.toy import ToySlam, ToySteps


def test_step_names_takes_the_steps_class_of_any_slam():
    from faultlab.slam import EkfSlamSteps, FastSlam2Steps, FastSlamSteps

    assert step_names() == step_names(FastSlamSteps) == FastSlamSteps.unit_names()
    assert step_names(EkfSlamSteps) == tuple(f.name for f in dataclasses.fields(EkfSlamSteps))
    assert "kalman_update" in step_names(EkfSlamSteps) and "resample" not in step_names(EkfSlamSteps)
    assert "sample_proposal" in step_names(FastSlam2Steps) and "sample_controls" not in step_names(FastSlam2Steps)
    assert step_names(ToySteps) == ("double", "other")
    with pytest.raises(FaultError, match="steps dataclass type"):
        step_names(ToySteps())  # an instance, not the class


def test_each_builtin_slam_kind_names_its_steps_class():
    from faultlab.slam import DeadReckoning, EkfSlam, FastSlam, FastSlam2
    from faultlab.slam.registry import BUILTIN_SLAMS

    # the kind's steps class is exactly the table its adapter carries
    for name, cls in [("fastslam", FastSlam), ("fastslam2", FastSlam2), ("ekf", EkfSlam)]:
        kind = BUILTIN_SLAMS[name]
        assert type(cls().steps) is kind.steps
        assert kind.units == step_names(kind.steps) == slam_units(name) == slam_units(cls())
    assert BUILTIN_SLAMS["dead_reckoning"].units == () == slam_units(DeadReckoning())
    assert slam_units(ToySlam()) == ("double", "other")
    assert slam_units(object()) == ()
    with pytest.raises(UnknownPluginError, match="slam: unknown SLAM .no_such_slam.. Known SLAMs: fastslam, "):
        slam_units("no_such_slam")


def test_applicable_faults_agree_with_a_brute_force_patch_of_each_slam():
    from faultlab.slam import DeadReckoning, EkfSlam, FastSlam, FastSlam2

    faults = list(builtin_faults().values())
    for name, slam in [("fastslam", FastSlam()), ("fastslam2", FastSlam2()), ("ekf", EkfSlam()),
                       ("dead_reckoning", DeadReckoning())]:
        fit = applicable_faults(name, faults)
        # independent oracle: a fault applies iff patching the SLAM's steps works
        oracle = []
        for f in faults:
            try:
                f.apply(slam)
                oracle.append(f.name)
            except FaultError:
                pass
        assert [f.name for f in fit.applicable] == oracle, name
        assert [r.fault for r in fit.not_applicable] == [f.name for f in faults if f.name not in oracle]
        assert all(fault_applies(f, slam) == (f.name in oracle) for f in faults)
    # every built-in fault applies to the reference FastSLAM
    assert applicable_faults("fastslam", faults).summary() == ""
    ekf = applicable_faults("ekf", faults)
    reason = next(r for r in ekf.not_applicable if r.fault == "naive_resampling")
    assert str(reason) == ("fault 'naive_resampling' replaces unit 'resample', which SLAM 'ekf' does not have "
                           "(it has 13 other units)")
    assert ekf.summary().startswith(f"{len(ekf.not_applicable)} of {len(faults)} faults do not apply to 'ekf'")
    assert "resample (naive_resampling, inverted_resampling_threshold)" in ekf.summary()
    dr = applicable_faults("dead_reckoning", faults)
    assert dr.applicable == () and dr.summary().endswith("it has no replaceable units")
    assert str(not_applicable(faults[0], "dead_reckoning")).endswith("has no replaceable units")
    assert not_applicable(faults[0], "fastslam") is None
