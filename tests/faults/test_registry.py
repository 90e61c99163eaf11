"""Fault record and registry look-up (faultlab.faults.registry, faultlab.faults.fault)."""

import pickle

import pytest

from faultlab.errors import FaultError
from faultlab.vocabulary import BASELINE, PAPER_FAULTS
from faultlab.faults import (
    Fault,
    all_faults,
    apply_faults,
    builtin_faults,
    get_fault,
    resolve_fault,
    step_names,
)



from tests.faults.toy import ToySlam, ToySteps, double_unit, negate_result


def _fault(**kw):
    base = dict(name="toy", step="double", description="negates", rationale="r", origin="o",
                replacement=negate_result)
    return Fault(**{**base, **kw})


#: A fault importable as "tests.faults.test_registry:MODULE_FAULT" (module:attr variant specs).
MODULE_FAULT = _fault(name="tests/module_fault")
NOT_A_FAULT = 42


def test_patch_replaces_exactly_one_unit_and_wraps_the_original():
    steps = ToySteps()
    patched = _fault().patch(steps)
    assert patched.double(3) == -6  # wraps the original 2x
    assert patched.other is abs
    assert steps.double(3) == 6  # original table untouched
    assert type(patched) is ToySteps


def test_apply_returns_a_new_instance_and_leaves_the_slam_alone():
    slam = ToySlam()
    faulty = _fault().apply(slam)
    assert faulty is not slam
    assert faulty.steps.double(2) == -4 and slam.steps.double(2) == 4
    with _fault().applied(slam) as inside:
        assert inside.steps.double(1) == -2
    assert slam.steps.double(1) == 2
    twice = apply_faults(slam, [_fault(), _fault(name="toy2")])  # higher-order mutant: -(-(2x))
    assert twice.steps.double(5) == 10 and twice is not slam


@pytest.mark.parametrize(
    "kwargs, message",
    [
        (dict(name=BASELINE), "reserved"),
        (dict(name="Has Space"), "invalid"),
        (dict(name="a/b/c"), "invalid"),
        (dict(name=""), "non-empty"),
        (dict(step="not a field"), "step must be"),
        (dict(description="two\nlines"), "one line"),
        (dict(origin="  "), "origin must be"),
        (dict(replacement=3), "replacement must be callable"),
    ],
)
def test_fault_record_rejects_bad_fields(kwargs, message):
    with pytest.raises(FaultError, match=message):
        _fault(**kwargs)


def test_patch_errors_name_the_fault_and_the_step():
    with pytest.raises(FaultError, match=r"'toy' patches unknown step 'nope'.*double, other"):
        _fault(step="nope").patch(ToySteps())

    def broken(original):
        raise ValueError("bad factory")

    with pytest.raises(FaultError, match="bad factory"):
        _fault(replacement=broken).patch(ToySteps())
    with pytest.raises(FaultError, match="not a callable"):
        _fault(replacement=lambda original: 5).patch(ToySteps())
    with pytest.raises(FaultError, match="steps dataclass"):
        _fault().patch({"double": double_unit})
    with pytest.raises(FaultError, match="no steps/with_steps"):
        _fault().apply(object())


def test_builtins_are_registered_with_unique_plain_names_and_known_steps():
    faults = builtin_faults()
    names = list(faults)
    assert names[:3] == list(PAPER_FAULTS)
    assert len(names) >= 3 + 8
    known = set(step_names())
    for name, f in faults.items():
        assert f.name == name and f.provider is None
        assert f.step in known, name
        assert len(f.rationale) > 80 and f.origin.strip(), name
    assert len(set(names)) == len(names)


def test_faults_pickle_for_worker_processes():
    for f in all_faults():
        clone = pickle.loads(pickle.dumps(f))
        assert clone.name == f.name and clone.step == f.step
        assert clone.replacement is f.replacement  # module-level functions pickle by reference


def test_unknown_name_suggests_close_matches_and_lists_known_names():
    with pytest.raises(FaultError, match=r"unknown fault 'naive_resampler'.*did you mean 'naive_resampling'"):
        get_fault("naive_resampler")
    with pytest.raises(FaultError, match="Known faults: naive_resampling, missing_angle_wrap"):
        get_fault("zzz")
    with pytest.raises(FaultError, match="unmodified reference"):
        get_fault(BASELINE)


def test_resolve_fault_accepts_names_instances_and_import_paths():
    f = get_fault("missing_angle_wrap")
    assert resolve_fault("missing_angle_wrap") is f
    assert resolve_fault(f) is f
    assert resolve_fault("tests.faults.test_registry:MODULE_FAULT") is MODULE_FAULT
    with pytest.raises(FaultError, match="cannot import module 'no_such_module_xyz'"):
        resolve_fault("no_such_module_xyz:F")
    with pytest.raises(FaultError, match="has no attribute 'MISSING'"):
        resolve_fault("tests.faults.test_registry:MISSING")
    with pytest.raises(FaultError, match="is a int, not a faultlab.faults.Fault"):
        resolve_fault("tests.faults.test_registry:NOT_A_FAULT")
