"""Third-party faults discovered through real entry-point metadata (faultlab.faults.discovery)."""

import importlib.metadata
import warnings

import numpy as np
import pytest

from faultlab.errors import FaultError, PluginError
from faultlab.faults import (
    ENTRY_POINT_GROUP,
    PluginWarning,
    all_faults,
    fault_applies,
    known_steps,
    get_fault,
    list_faults,
    load_plugins,
    step_names,
)
from tests.distributions import make_distribution


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
    names = [f.name for f in report.items]
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
    loaded = [f.name for f in report.items]
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
    example = [f for f in report.items if f.provider == "example"]
    assert example, f"no example/* fault discovered; plugin errors: {report.errors}"
    for f in example:
        assert report.sources[f.name].startswith("entry point example = faultlab_example_plugin:")
        assert get_fault(f.name).name == f.name
    # ... and runs: injected into the reference FastSLAM it changes the estimate
    from faultlab.faults.check import check_scenario, estimates_identical
    from faultlab.slam import FastSlam, FastSlamConfig, run_slam

    scenario = check_scenario(seed=3, n_steps=30)
    slam = FastSlam(FastSlamConfig(particles=20))
    ref = run_slam(slam, scenario, rng=np.random.default_rng(0))
    est = run_slam(get_fault("example/double_range_offset").apply(slam), scenario, rng=np.random.default_rng(0))
    assert not estimates_identical(est, ref)
    np.testing.assert_array_equal(est.landmark_ids, ref.landmark_ids)


def test_plugins_may_replace_units_of_any_builtin_slam(site):
    _make_distribution(site, "ekf-faults", "1.0", {"acme": "ekf_faults_mod:FAULTS"},
                       {"ekf_faults_mod": _good("gain", step="kalman_update")})
    report = load_plugins(warn=False)
    gain = report.by_name()["acme/gain"]
    assert "kalman_update" in known_steps() and set(step_names()) < set(known_steps())
    assert fault_applies(gain, "ekf") and not fault_applies(gain, "fastslam")


def test_broken_sensor_fault_plugin_is_a_plugin_failure_like_a_code_fault_plugin(site):
    from faultlab.faults import SENSOR_ENTRY_POINT_GROUP, PluginFailure, load_sensor_plugins

    make_distribution(site, "broken-sensors", SENSOR_ENTRY_POINT_GROUP, {"shaky": "broken_sensors_mod:FAULTS"},
                      {"broken_sensors_mod": "raise RuntimeError('boom in a sensor plugin')\n"}, version="1.0")
    with pytest.warns(PluginWarning, match=r"sensor-fault plugin 'shaky'.*broken-sensors 1\.0.*RuntimeError: boom"):
        report = load_sensor_plugins()
    assert [type(e) for e in report.errors] == [PluginFailure]
    failure = report.errors[0]
    assert (failure.plugin, failure.kind) == ("shaky", "sensor-fault")
    assert failure.error == "RuntimeError: boom in a sensor plugin"
    assert "broken_sensors_mod:FAULTS" in failure.source
    # listings and look-ups report it like a code-fault plugin
    assert "sensor-fault plugin 'shaky'" in list_faults().format()
    with pytest.raises(FaultError, match="Plugins that failed to load: sensor-fault plugin 'shaky'"):
        get_fault("shaky/thing")
