"""The mutation-testing-report-schema JSON of a campaign on user code: valid against Stryker's schema."""

import json
import math
from pathlib import Path

import jsonschema
import pandas as pd
import pytest

from faultlab.analysis.mutation import OUTCOME_COLUMNS
from faultlab.mutation.probes import ProbeScreening
from faultlab.mutation.outcome import MutantOutcome
from faultlab.mutation.sourceselect import mutant_records
from faultlab.mutation.target import generate_source_mutants, parse_target
from faultlab.report.stryker import stryker_report
from tests.mutation.usercode import MODULE, user_package  # noqa: F401  (fixture)

SCHEMA = json.loads((Path(__file__).parent / "data" / "mutation-testing-report-schema.json").read_text())


def _outcome(mutant, suite, outcome, case=0, n=3, note=""):
    row = {c: "" for c in OUTCOME_COLUMNS}
    return row | dict(mutant=mutant, unit="f", operator="o", run=1, suite=suite, outcome=outcome, killing_case=case,
                      n_cases=n, n_cases_run=case or n, median_diff_mm=math.nan, ratio=math.nan, min_p=math.nan,
                      max_p_equivalence=math.nan, min_mde_mm=math.nan, n_stopped=0, note=note)


def test_the_report_validates_and_maps_every_class(user_package):
    found = generate_source_mutants(parse_target(MODULE))
    ids = [m.id for m in found][:6]
    screening = {i: ProbeScreening(i, None, "differs") for i in found.by_id}
    screening[ids[4]] = ProbeScreening(ids[4], MutantOutcome.INVALID, "cannot run: ZeroDivisionError")
    screening[ids[5]] = ProbeScreening(ids[5], MutantOutcome.DUPLICATE, "same as", duplicate_of=ids[0])
    records = mutant_records(found, screening)
    records["mutants"] = {i: records["mutants"][i] for i in ids}
    outcomes = pd.DataFrame([_outcome(ids[0], "random", "killed", 2), _outcome(ids[0], "fixed", "survived"),
                             _outcome(ids[1], "random", "crash", 1), _outcome(ids[2], "random", "survived"),
                             _outcome(ids[3], "random", "timeout", 3, note="verdict reused from old")],
                            columns=OUTCOME_COLUMNS)
    report = stryker_report(outcomes, records, meta={"kill": "exact", "alpha": 0.05, "target": {"target": MODULE}})
    jsonschema.validate(report, SCHEMA)
    (file,) = report["files"].values()
    assert file["source"] == found.module.text and list(report["files"]) == ["usermap/slam.py"]
    status = {m["id"]: m["status"] for m in file["mutants"]}
    assert status == {ids[0]: "Killed", ids[1]: "RuntimeError", ids[2]: "Survived", ids[3]: "Timeout",
                      ids[4]: "CompileError", ids[5]: "Ignored"}
    m0 = next(m for m in file["mutants"] if m["id"] == ids[0])
    assert m0["killedBy"] == ["run1/random/case2"] and "run1/fixed/case3" in m0["coveredBy"]
    lines = found.module.text.splitlines()
    start = m0["location"]["start"]
    assert lines[start["line"] - 1][start["column"] - 1:].strip()  # points at text of the changed line
    assert "reused" in next(m for m in file["mutants"] if m["id"] == ids[3])["statusReason"]
    tests = {t["id"] for f in report["testFiles"].values() for t in f["tests"]}
    assert {t for m in file["mutants"] for t in m.get("killedBy", []) + m.get("coveredBy", [])} <= tests


def test_a_report_missing_a_required_field_is_rejected_by_the_schema():
    with pytest.raises(jsonschema.ValidationError):
        jsonschema.validate({"schemaVersion": "2", "files": {}}, SCHEMA)  # no thresholds
