"""Fault record, registry look-up and plugin discovery through real entry-point metadata."""

import dataclasses
import importlib.metadata
import pickle
import warnings

import numpy as np
import pytest

from faultlab.errors import ConfigError, FaultError, PluginError
from faultlab.vocabulary import BASELINE, PAPER_FAULTS
from faultlab.faults import (
    ENTRY_POINT_GROUP,
    Fault,
    PluginWarning,
    all_faults,
    applicable_faults,
    apply_faults,
    fault_applies,
    known_steps,
    not_applicable,
    slam_units,
    builtin_faults,
    get_fault,
    list_faults,
    load_plugins,
    resolve_fault,
    step_names,
)
from tests.distributions import make_distribution



# --------------------------------------------------------------------------- a toy step table

def _double(x):
    return 2 * x


def _negate_result(original):
    def unit(x):
        return -original(x)

    return unit


@dataclasses.dataclass(frozen=True)
class ToySteps:
    double: object = _double
    other: object = abs


class ToySlam:
    def __init__(self, steps=ToySteps()):
        self.steps = steps

    def with_steps(self, steps):
        return ToySlam(steps)


def _fault(**kw):
    base = dict(name="toy", step="double", description="negates", rationale="r", origin="o",
                replacement=_negate_result)
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
        _fault().patch({"double": _double})
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


# --------------------------------------------------------------------------- real entry-point metadata

def _make_distribution(site, dist, version, entry_points, modules):
    make_distribution(site, dist, ENTRY_POINT_GROUP, entry_points, modules, version=version)


GOOD_PLUGIN = """
    from faultlab.faults import Fault

    def _identity_factory(original):
        def unit(*args, **kwargs):
            return original(*args, **kwargs)
        return unit

    FAULTS = [Fault(name="acme/{name}", step="{step}", description="d", rationale="r", origin="o",
                    replacement=_identity_factory)]
"""


def _good(name, step="wrap_bearing"):
    return GOOD_PLUGIN.replace("{name}", name).replace("{step}", step)


def test_broken_plugin_is_reported_clearly_and_the_others_still_load(site):
    _make_distribution(site, "broken-faults", "1.0", {"broken": "broken_faults_mod:FAULTS"},
                       {"broken_faults_mod": "raise RuntimeError('boom while importing')\n"})
    _make_distribution(site, "acme-faults", "2.0", {"acme": "acme_faults_mod:FAULTS"},
                       {"acme_faults_mod": _good("fine")})
    with pytest.warns(PluginWarning, match=r"fault plugin 'broken'.*broken-faults 1\.0.*RuntimeError: boom"):
        report = load_plugins()
    assert not report.ok
    assert [e.plugin for e in report.errors] == ["broken"]
    assert "RuntimeError: boom while importing" in report.errors[0].error
    assert "broken_faults_mod:FAULTS" in report.errors[0].source
    names = [f.name for f in report.faults]
    assert "acme/fine" in names
    assert "acme-faults 2.0" in report.sources["acme/fine"]
    # the example plugin (installed in the test environment) still loads too
    assert any(n.startswith("example/") for n in names), "example plugin not installed (see README)"
    with pytest.raises(PluginError, match="broken"):
        report.raise_for_errors()
    # look-ups keep working and mention the broken plugin for plugin names
    assert get_fault("acme/fine").name == "acme/fine"
    with pytest.raises(FaultError, match="Plugins that failed to load: fault plugin 'broken'"):
        get_fault("broken/thing")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", PluginWarning)
        assert "acme/fine" in [f.name for f in all_faults()]
    listing = list_faults()
    assert "acme/fine" in [f.name for f in listing.faults]
    assert "fault plugin 'broken'" in listing.format()


def test_invalid_plugin_objects_and_duplicates_are_rejected_one_by_one(site):
    _make_distribution(site, "acme-one", "1.0", {"acme": "acme_one_mod:FAULTS"}, {"acme_one_mod": _good("dup")})
    _make_distribution(site, "acme-two", "1.0", {"acme2": "acme_two_mod:FAULTS"}, {"acme_two_mod": _good("dup")})
    _make_distribution(
        site, "odd-faults", "0.1",
        {"plain": "odd_mod:PLAIN", "notfault": "odd_mod:NUMBER", "badstep": "odd_mod:BADSTEP",
         "single": "odd_mod:SINGLE"},
        {"odd_mod": """
            from faultlab.faults import Fault
            def _f(original):
                return original
            PLAIN = Fault(name="plain_name", step="wrap_bearing", description="d", rationale="r",
                          origin="o", replacement=_f)
            NUMBER = 7
            BADSTEP = Fault(name="odd/badstep", step="no_such_unit", description="d", rationale="r",
                            origin="o", replacement=_f)
            SINGLE = Fault(name="odd/single", step="wrap_bearing", description="d", rationale="r",
                           origin="o", replacement=_f)
        """})
    with pytest.warns(PluginWarning):
        report = load_plugins()
    errors = {e.plugin: e.error for e in report.errors}
    assert "needs a 'provider/name' name" in errors["plain"]
    assert "not a Fault" in errors["notfault"] or "iterable of Faults" in errors["notfault"]
    assert "unknown step 'no_such_unit'" in errors["badstep"]
    dup = errors["acme2"]
    assert "duplicate fault name 'acme/dup'" in dup and "acme-one 1.0" in dup and "acme-two 1.0" in dup
    loaded = [f.name for f in report.faults]
    assert loaded.count("acme/dup") == 1 and "odd/single" in loaded  # a single Fault is fine too
    assert report.sources["acme/dup"].startswith("entry point acme = acme_one_mod:FAULTS")


def test_no_warning_when_asked_not_to(site):
    _make_distribution(site, "broken-faults", "1.0", {"broken": "broken_mod2:FAULTS"},
                       {"broken_mod2": "import not_a_real_module_abc\n"})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        report = load_plugins(warn=False)
    assert "ModuleNotFoundError" in report.errors[0].error


def test_example_plugin_is_installed_and_discovered_through_entry_points():
    try:
        dist = importlib.metadata.distribution("faultlab-example-plugin")
    except importlib.metadata.PackageNotFoundError:
        pytest.fail("the example fault plugin is not installed; run "
                    "`python -m pip install -e examples/faultlab-example-plugin` (the README's test command "
                    "installs it)")
    eps = [ep for ep in dist.entry_points if ep.group == ENTRY_POINT_GROUP]
    assert [ep.name for ep in eps] == ["example"]
    report = load_plugins()
    example = [f for f in report.faults if f.provider == "example"]
    assert example, f"no example/* fault discovered; plugin errors: {report.errors}"
    for f in example:
        assert report.sources[f.name].startswith("entry point example = faultlab_example_plugin:")
        assert get_fault(f.name).name == f.name
    # ... and runs: injected into the reference FastSLAM it changes the estimate
    from faultlab.faults.check import check_scenario, estimates_identical
    from faultlab.slam import FastSlam, FastSlamConfig, run_slam

    scenario = check_scenario(seed=3, n_steps=30)
    slam = FastSlam(FastSlamConfig(n_particles=20))
    ref = run_slam(slam, scenario, rng=np.random.default_rng(0))
    est = run_slam(get_fault("example/double_range_offset").apply(slam), scenario, rng=np.random.default_rng(0))
    assert not estimates_identical(est, ref)
    np.testing.assert_array_equal(est.landmark_ids, ref.landmark_ids)


# --------------------------------------------------------------------------- applicability

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
    with pytest.raises(ConfigError, match="slam must be one of"):
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


def test_plugins_may_replace_units_of_any_builtin_slam(site):
    _make_distribution(site, "ekf-faults", "1.0", {"acme": "ekf_faults_mod:FAULTS"},
                       {"ekf_faults_mod": _good("gain", step="kalman_update")})
    report = load_plugins(warn=False)
    gain = report.by_name()["acme/gain"]
    assert "kalman_update" in known_steps() and set(step_names()) < set(known_steps())
    assert fault_applies(gain, "ekf") and not fault_applies(gain, "fastslam")
