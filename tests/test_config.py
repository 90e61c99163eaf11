import pytest

from faultlab.errors import ConfigError
from faultlab.config import read_toml


def test_reads_table_and_text(tmp_path):
    f = tmp_path / "a.toml"
    f.write_text('x = 1\n[t]\ny = "z"\n', encoding="utf-8")
    data, text = read_toml(f, what="test file")
    assert data == {"x": 1, "t": {"y": "z"}}
    assert text == f.read_text(encoding="utf-8")


def test_errors_name_the_file_and_what_it_is(tmp_path):
    with pytest.raises(ConfigError, match=r"^.*missing\.toml: test file cannot be read"):
        read_toml(tmp_path / "missing.toml", what="test file")
    bad = tmp_path / "bad.toml"
    bad.write_text("[unclosed\n", encoding="utf-8")
    with pytest.raises(ConfigError, match=r"bad\.toml: test file is not valid TOML \(.*line 1"):
        read_toml(bad, what="test file")


def test_merge_tables_replaces_a_table_key_by_key_and_copies():
    from faultlab.config import merge_tables

    data = {"n_steps": 1000, "slam": {"name": "fastslam", "particles": 200}, "variants": ["baseline"]}
    merged = merge_tables(data, {"n_steps": 60, "slam": {"particles": 20}, "variants": ["a", "b"]})
    assert merged == {"n_steps": 60, "slam": {"name": "fastslam", "particles": 20}, "variants": ["a", "b"]}
    merged["slam"]["name"] = "ekf"
    assert data["slam"] == {"name": "fastslam", "particles": 200}  # the input is never aliased


def test_a_file_that_is_not_utf8_is_invalid_toml_naming_file_byte_and_line(tmp_path):
    bad = tmp_path / "latin1.toml"
    bad.write_bytes('seed = 1\nname = "caf\u00e9"\n'.encode("latin-1"))
    with pytest.raises(ConfigError) as info:
        read_toml(bad, what="test file")
    assert str(info.value) == f"{bad}: test file is not valid TOML (not UTF-8 text: byte 0xe9 at line 2)"


def test_experiment_overrides_are_checked_on_construction_and_normalised():
    from faultlab.config import ExperimentOverrides

    o = ExperimentOverrides(repetitions=5, suites={"systematic": "auto", "random": 2}, variants=["baseline"],
                            slam={"name": "ekf"})
    assert o.suites == (("systematic", None), ("random", 2)) and o.variants == ("baseline",)
    assert o.slam == (("name", "ekf"),)
    assert o.tables() == ({"repetitions": 5, "suites": {"systematic": "auto", "random": 2},
                           "variants": ["baseline"], "slam": {"name": "ekf"}}, {})
    assert ExperimentOverrides(particles=30, rule="statistical").tables() == (
        {}, {"slam": {"particles": 30}, "detection": {"rule": "statistical"}})
    for bad, match in [({"repetitions": 0}, r"ExperimentOverrides.repetitions must be >= 1"),
                       ({"particles": 2.5}, r"ExperimentOverrides.particles must be an integer"),
                       ({"runs": True}, r"ExperimentOverrides.runs must be an integer"),
                       ({"suites": {"random": 0}}, r"ExperimentOverrides.suites\['random'\] must be >= 1"),
                       ({"suites": {}}, r"at least one suite"),
                       ({"variants": "baseline"}, r"ExperimentOverrides.variants"),
                       ({"fov_bug": 1}, r"ExperimentOverrides.fov_bug"),
                       ({"slam": ["name"]}, r"ExperimentOverrides.slam")]:
        with pytest.raises(ConfigError, match=match):
            ExperimentOverrides(**bad)


def test_experiment_overrides_then_lets_the_later_set_fields_win():
    from faultlab.config import ExperimentOverrides

    first = ExperimentOverrides(runs=1, repetitions=1, particles=60)
    both = first.then(ExperimentOverrides(repetitions=10, n_steps=25))
    assert both == ExperimentOverrides(runs=1, repetitions=10, particles=60, n_steps=25)
    assert first.then(ExperimentOverrides()) == first and ExperimentOverrides().then(first) == first
