import dataclasses
import json

import numpy as np
import pytest

from faultlab.errors import ScenarioError
from faultlab.scenario import generate_scenario, load_scenario, save_scenario
from faultlab.scenario.model import _ARRAYS
from faultlab.space import FIXED_VALUES, CaseSpec


@pytest.fixture(scope="module")
def scenario():
    case = CaseSpec(dict(FIXED_VALUES, inactivity=20, bias_angle=0.0123456789012345, directionality="loop"),
                    {"map_size": 1, "bias": 3})
    return generate_scenario(case, rng=np.random.default_rng(12), n_steps=80, seed=12)


@pytest.mark.parametrize("name", ["case1", "case1.npz", "case1.json"])
def test_save_load_round_trip_is_lossless(tmp_path, scenario, name):
    npz = save_scenario(scenario, tmp_path / "sub" / name)
    assert npz == tmp_path / "sub" / "case1.npz" and npz.with_suffix(".json").exists()
    back = load_scenario(tmp_path / "sub" / name)
    for k in _ARRAYS:
        x, y = getattr(scenario, k), getattr(back, k)
        assert x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes(), k
    assert back.case.values == scenario.case.values and back.case.classes == scenario.case.classes
    assert back.seed == 12 and back.meta == scenario.meta
    assert not list((tmp_path / "sub").glob("*.tmp*"))


def test_load_errors(tmp_path, scenario):
    with pytest.raises(ScenarioError, match="missing file"):
        load_scenario(tmp_path / "nope")
    save_scenario(scenario, tmp_path / "c")
    meta = json.loads((tmp_path / "c.json").read_text())
    meta["format"] = 99
    (tmp_path / "c.json").write_text(json.dumps(meta))
    with pytest.raises(ScenarioError, match="unsupported format 99"):
        load_scenario(tmp_path / "c")


def test_validate_catches_inconsistent_arrays(scenario):
    from dataclasses import replace

    with pytest.raises(ScenarioError, match="obs_offsets"):
        replace(scenario, obs_offsets=scenario.obs_offsets[:-1]).validate()
    with pytest.raises(ScenarioError, match="unique"):
        replace(scenario, landmark_ids=np.zeros_like(scenario.landmark_ids)).validate()


def test_observations_slice(scenario):
    t = int(np.argmax(np.diff(scenario.obs_offsets)))
    r, b, ids = scenario.observations(t)
    a, e = scenario.obs_offsets[t], scenario.obs_offsets[t + 1]
    np.testing.assert_array_equal(ids, scenario.obs_ids[a:e])
    assert len(r) == len(b) == e - a > 0


def _saved(tmp_path, scenario):
    save_scenario(scenario, tmp_path / "c")
    return tmp_path / "c.npz", tmp_path / "c.json"


def test_truncated_npz_is_one_scenario_error(tmp_path, scenario):
    npz, js = _saved(tmp_path, scenario)
    npz.write_bytes(npz.read_bytes()[: npz.stat().st_size // 2])
    with pytest.raises(ScenarioError, match=r"c.npz is damaged"):
        load_scenario(npz)
    meta = json.loads(js.read_text())  # a case from before checksums: numpy's own error, wrapped
    del meta["npz_blake2b"], meta["checksum"]
    js.write_text(json.dumps(meta))
    with pytest.raises(ScenarioError, match=r"unreadable \(BadZipFile"):
        load_scenario(npz)


def test_changed_byte_in_npz_is_detected(tmp_path, scenario):
    npz, _ = _saved(tmp_path, scenario)
    data = bytearray(npz.read_bytes())
    data[len(data) // 2] ^= 0x01  # one bit inside an array: np.load alone would not notice
    npz.write_bytes(bytes(data))
    with pytest.raises(ScenarioError, match="damaged"):
        load_scenario(npz)


def test_edited_json_is_detected_and_old_cases_still_load(tmp_path, scenario):
    npz, js = _saved(tmp_path, scenario)
    meta = json.loads(js.read_text())
    assert set(meta) >= {"npz_blake2b", "checksum"}
    meta["seed"] = 13
    js.write_text(json.dumps(meta))
    with pytest.raises(ScenarioError, match="does not match its checksum"):
        load_scenario(npz)
    meta["seed"] = 12
    del meta["npz_blake2b"], meta["checksum"]  # as saved before checksums existed
    js.write_text(json.dumps(meta))
    back = load_scenario(npz)
    assert back.seed == 12 and back.landmarks.tobytes() == scenario.landmarks.tobytes()


def test_disk_full_while_saving_is_one_error_and_leaves_no_partial_file(small_tmpfs, scenario):
    filler = small_tmpfs / "filler"
    with open(filler, "wb", buffering=0) as f:  # fill the file system up completely
        with pytest.raises(OSError, match="No space left"):
            while True:
                f.write(b"\0" * 4096)
    with pytest.raises(ScenarioError, match="cannot be written \\(the disk is full\\)"):
        save_scenario(scenario, small_tmpfs / "case1")
    assert sorted(p.name for p in small_tmpfs.iterdir()) == ["filler"]


@pytest.mark.parametrize("array, index", [("landmarks", (2, 1)), ("true_poses", (5, 0)), ("controls", (3, 1)),
                                          ("obs_range", (0,)), ("obs_bearing", (1,))])
@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_a_case_saved_with_a_non_finite_value_is_refused_on_load_naming_file_array_and_index(
        tmp_path, scenario, array, index, bad):
    from faultlab.errors import InvalidCaseError

    values = getattr(scenario, array).copy()
    values[index] = bad
    tampered = dataclasses.replace(scenario, **{array: values})
    path = save_scenario(tampered, tmp_path / "case")  # valid checksums: the content is what was saved
    with pytest.raises(InvalidCaseError) as info:
        load_scenario(path)
    shown = index if len(index) > 1 else index[0]
    assert str(info.value).startswith(f"test case {tmp_path / 'case.npz'}: {array} holds 1 non-finite value(s), "
                                      f"the first {bad} at index {shown}")
