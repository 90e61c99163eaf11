"""Recording a SLAM's map errors for faultlab compare: resumable, checksummed, deterministic SLAMs run once."""

import json
from pathlib import Path

import numpy as np
import pytest

from faultlab.campaigns.compare import RecordSpec, candidate_spec, read_record, record
from faultlab.config import read_toml
from faultlab.errors import ConfigError
from faultlab.oracles import execute, repetition_seeds
from faultlab.oracles.oracle import map_error_mm
from faultlab.scenario.suite import draw_suite, generate_case
from faultlab.space.parameters import space_from_mapping

HERE = Path(__file__).parent
SPACE = read_toml(HERE.parent / "oracles" / "small_space.toml", what="space")[0]


def _spec(slam="compare_slams:fastslam20", **kw):
    return RecordSpec(slam=slam, suite="random", n_cases=3, n_steps=30, seed=4, repetitions=3, paths=(str(HERE),),
                      space=SPACE, **kw)


def test_record_holds_each_repetitions_map_error(tmp_path):
    spec = _spec()
    cases = record(spec, tmp_path / "b")
    assert [c.case_id for c in cases] == [f"random-1-00{i}" for i in (1, 2, 3)]
    # independent reference: run the same factory with the documented seeds by hand
    suite = draw_suite("random", space_from_mapping(SPACE, source="s"), root_seed=4, n_cases=3)
    from compare_slams import fastslam20

    sc = generate_case(suite[0], n_steps=30)
    seeds = repetition_seeds(4, cases[0].case_id, 3)
    expected = [map_error_mm(sc, execute(fastslam20, sc, s)) for s in seeds]
    assert cases[0].errors_mm == pytest.approx(expected, rel=1e-12)
    assert not cases[0].deterministic and cases[0].ok


def test_a_deterministic_slam_is_recorded_once_per_case(tmp_path):
    cases = record(_spec("compare_slams:odometry"), tmp_path / "b")
    assert all(c.deterministic and len(c.errors_mm) == 1 for c in cases)


def test_resume_records_only_the_missing_cases_and_gives_the_same_result(tmp_path):
    out = tmp_path / "b"
    full = record(_spec(), out)
    (out / "cases" / "random-1-002.json").unlink()
    before = (out / "cases" / "random-1-001.json").stat().st_mtime_ns
    again = record(_spec(), out)
    assert (out / "cases" / "random-1-001.json").stat().st_mtime_ns == before
    assert [c.errors_mm for c in again] == [c.errors_mm for c in full]


def test_a_damaged_case_file_is_refused_with_its_path(tmp_path):
    out = tmp_path / "b"
    record(_spec(), out)
    path = out / "cases" / "random-1-002.json"
    data = json.loads(path.read_text())
    data["payload"]["errors_mm"][0] *= 0.5  # silently wrong number
    path.write_text(json.dumps(data))
    with pytest.raises(ConfigError, match="random-1-002.json.*checksum"):
        read_record(out)
    path.write_text("{not json")
    with pytest.raises(ConfigError, match="random-1-002.json"):
        record(_spec(), out)


def test_a_record_of_another_spec_is_refused_and_left_untouched(tmp_path):
    out = tmp_path / "b"
    record(_spec(), out)
    snapshot = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    with pytest.raises(ConfigError, match="another SLAM or suite"):
        record(_spec("compare_slams:odometry"), out)
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == snapshot
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "x.txt").write_text("mine")
    with pytest.raises(ConfigError, match="not empty"):
        record(_spec(), tmp_path / "other")


def test_candidate_shares_the_suite_and_by_default_the_repetition_seeds():
    base = _spec()
    cand = candidate_spec(base, slam="compare_slams:miscalibrated")
    assert cand.suite_dict() == base.suite_dict() and cand.repetition_seed == base.repetition_seed
    assert candidate_spec(base, slam="x", rep_seed=99).repetition_seed == 99
    with pytest.raises(ConfigError):
        RecordSpec(slam="no_such_slam").validate()
