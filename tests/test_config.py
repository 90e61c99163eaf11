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
