"""One catalogue for every extension kind (faultlab.plugins): one result shape, one unknown-name error."""

import pickle

import pytest

from faultlab.cli import main
from faultlab.errors import ConfigError, FaultError, UnknownPluginError
from faultlab.faults import get_fault, load_plugins, load_sensor_plugins
from faultlab.metamorphic import get_relation, load_relation_plugins
from faultlab.mutation import get_operator, load_operator_plugins
from faultlab.oracles import get_oracle, load_oracle_plugins
from faultlab.plugins import PluginLoad
from faultlab.slam.registry import get_slam_kind, load_slam_plugins
from faultlab.space.registry import get_strategy, load_strategy_plugins
from tests.runner.suts import write_experiment

# kind -> (look-up, a misspelt name, the built-in it is close to, the kind's plural in the message)
LOOKUPS = {
    "SLAM": (get_slam_kind, "fastslan", "fastslam", "SLAMs"),
    "suite strategy": (get_strategy, "pairwize", "pairwise", "strategies"),
    "fault": (get_fault, "naive_resampler", "naive_resampling", "faults"),
    "sensor fault": (get_fault, "obs_dropot", "obs_dropout", "faults"),
    "mutation operator": (get_operator, "arithmetc", "arithmetic", "operators"),
    "metamorphic relation": (get_relation, "rigid_motoin", "rigid_motion", "relations"),
    "oracle": (get_oracle, "metamorphik", "metamorphic", "oracles"),
}
LOADERS = [load_slam_plugins, load_strategy_plugins, load_plugins, load_sensor_plugins, load_operator_plugins,
           load_relation_plugins, load_oracle_plugins]


@pytest.mark.parametrize("kind", LOOKUPS)
def test_an_unknown_name_of_every_kind_is_one_error_naming_kind_name_and_known_names(kind):
    lookup, wrong, close, plural = LOOKUPS[kind]
    assert lookup(close).name == close  # the reference: the close name is known
    with pytest.raises(UnknownPluginError) as info:
        lookup(wrong)
    err = info.value
    # what callers caught before: a setting's ConfigError, a fault's FaultError; both still catch it
    assert isinstance(err, ConfigError) and isinstance(err, FaultError)
    assert err.name == wrong and close in err.known
    text = str(err)
    assert "\n" not in text
    assert f"unknown {'fault' if kind == 'sensor fault' else kind} {wrong!r}; did you mean {close!r}" in text
    assert f"Known {plural}: " in text and close in text.split(f"Known {plural}: ")[1]
    again = pickle.loads(pickle.dumps(err))  # a worker process raises it to the parent
    assert type(again) is UnknownPluginError and str(again) == text and again.known == err.known


def test_the_message_without_a_close_name_and_the_plural_of_each_kind():
    err = UnknownPluginError("suite strategy", "zzz", ["systematic", "random"], where="exp.toml: suites")
    assert str(err) == "exp.toml: suites: unknown suite strategy 'zzz'. Known strategies: systematic, random"
    assert str(UnknownPluginError("SLAM", "x", [])) == "unknown SLAM 'x'. Known SLAMs: none"


@pytest.mark.parametrize("load", LOADERS, ids=lambda f: f.__name__)
def test_every_kind_loads_into_the_one_result_shape(load):
    report = load(warn=False)
    assert type(report) is PluginLoad
    assert set(report.sources) == {item.name for item in report.items} == set(report.by_name())
    assert report.ok == (not report.errors)


@pytest.mark.parametrize("change, code", [
    ({"slam": {"name": "orbslam"}}, 2),           # the look-up's own error
    ({"variants": ["baseline", "no_such"]}, 2),   # wrapped in the experiment's ConfigError
    ({"runs": 0}, 1),                             # any other setting: 1
])
def test_the_command_line_prints_one_line_and_exits_2_for_an_unknown_name(tmp_path, capsys, change, code):
    toml = write_experiment(tmp_path / "exp.toml", **change)
    assert main(["run", str(toml), "--out", str(tmp_path / "out"), "--jobs", "1", "--no-progress"]) == code
    err = capsys.readouterr().err
    assert err.startswith("faultlab: error: ") and err.count("\n") == 1
    assert not (tmp_path / "out").exists()  # refused before anything is written
