import numpy as np
import pandas as pd
import pytest

from faultlab.errors import ConfigError
from faultlab.scenario import generate_scenario, load_scenario, write_suite
from faultlab.scenario.model import _ARRAYS
from faultlab.space import PARAMETER_NAMES, VALUE_KEYS, space_from_mapping


def test_write_systematic_suite(tmp_path):
    res = write_suite("systematic", seed=7, out=tmp_path / "s", n_steps=40)
    assert [p.name for p in res.paths] == [f"case{i}.npz" for i in range(1, 6)]
    assert all(p.with_suffix(".json").exists() for p in res.paths)
    assert res.coverage.ratio == 1.0
    cov = pd.read_csv(res.coverage_csv)
    assert cov["coverage"].iloc[-1] == 1.0 and cov["parameter"].iloc[-1] == "overall"
    cases = pd.read_csv(res.cases_csv)
    assert list(cases.columns) == ["case", *VALUE_KEYS, *[f"class_{p}" for p in PARAMETER_NAMES]]
    assert list(cases["case"]) == [1, 2, 3, 4, 5]
    # a saved case regenerates from its recorded seed
    sc = load_scenario(res.paths[2])
    again = generate_scenario(sc.case, rng=np.random.default_rng(sc.seed), n_steps=40, seed=sc.seed)
    for k in _ARRAYS:
        assert getattr(sc, k).tobytes() == getattr(again, k).tobytes()
    assert len({s.seed for s in res.scenarios}) == 5


def test_same_seed_same_files_other_seed_other_suite(tmp_path):
    a = write_suite("random", seed=3, out=tmp_path / "a", n_steps=20, n_cases=2)
    b = write_suite("random", seed=3, out=tmp_path / "b", n_steps=20, n_cases=2)
    c = write_suite("random", seed=4, out=tmp_path / "c", n_steps=20, n_cases=2)
    for x, y in zip(a.paths, b.paths):
        assert x.read_bytes() == y.read_bytes()
        assert x.with_suffix(".json").read_text() == y.with_suffix(".json").read_text()
    assert a.scenarios[0].case.values != c.scenarios[0].case.values


def test_fixed_suite_cases_differ_only_by_seed(tmp_path):
    res = write_suite("fixed", seed=1, out=tmp_path, n_steps=10, n_cases=2)
    s1, s2 = res.scenarios
    assert s1.case.values == s2.case.values
    assert s1.landmarks.tobytes() != s2.landmarks.tobytes()


def test_custom_space_and_errors(tmp_path):
    space = space_from_mapping({"map_size": {"classes": {"tiny": [4, 9]}}}, source="m")
    res = write_suite("random", seed=0, out=tmp_path / "x", n_steps=10, n_cases=3, space=space)
    assert all(s.case.values["map_size"] <= 9 for s in res.scenarios)
    with pytest.raises(ConfigError, match="unknown suite strategy .nope."):
        write_suite("nope", seed=0, out=tmp_path / "y")
    with pytest.raises(ConfigError, match="at least 5 cases"):
        write_suite("systematic", seed=0, out=tmp_path / "z", n_cases=2)
    assert not (tmp_path / "z").exists() and not (tmp_path / "y").exists()
