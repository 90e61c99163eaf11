"""The mutation-testing-report-schema JSON of a campaign on user code: valid against Stryker's schema."""

import json
import math
import re
import time
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
from tests.report.html.test_browser import assert_clean, browser  # noqa: F401  (fixture)

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


VIEWER = Path(__file__).parent / "data" / "mutation-testing-elements" / "mutation-test-elements.js"
REPO = Path(__file__).resolve().parents[2]
#: The viewer's metrics row of all files: two scores, then Killed, Survived, Timeout, No coverage, Ignored,
#: Runtime errors, Compile errors, Detected, Undetected, Total.
_ROW = re.compile(r"All files (?:[\d.]+|n/a) (?:[\d.]+|n/a)" + r" (\d+)" * 10)
_COUNTED = ("Killed", "Survived", "Timeout", "NoCoverage", "Ignored", "RuntimeError", "CompileError")


def _viewer_counts(browser, report: dict, tmp_path) -> list[int]:
    """The counts the viewer's summary table shows for ``report`` (the app's shadow DOM, as text)."""
    page = tmp_path / "viewer.html"
    data = json.dumps(report).replace("</", "<\\/")
    page.write_text(f'<!doctype html><html><head><meta charset="utf-8"><script src="{VIEWER.as_uri()}"></script>'
                    f'</head><body><mutation-test-report-app titlePostfix="faultlab"></mutation-test-report-app>'
                    f'<script>document.querySelector("mutation-test-report-app").report = {data};</script>'
                    f'</body></html>')
    browser.get(page.as_uri())
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline:
        text = " ".join(browser.execute_script("""
            const walk = n => (n.shadowRoot ? walk(n.shadowRoot) : '') + [...n.childNodes].map(
                c => c.nodeType === 3 ? c.textContent + ' ' : walk(c)).join('');
            return walk(document.body);""").split())
        found = _ROW.search(text)
        if found:
            return [int(x) for x in found.groups()]
        time.sleep(0.2)
    raise AssertionError(f"the viewer showed no summary: {text[:500]}")


@pytest.mark.parametrize("folder", ["mutation-user", "mutation-rtb"])
def test_the_committed_report_opens_in_strykers_viewer_with_every_mutant(folder, browser, tmp_path):
    report = json.loads((REPO / "reports" / folder / "mutation-report.json").read_text())
    mutants = [m for f in report["files"].values() for m in f["mutants"]]
    counts = _viewer_counts(browser, report, tmp_path)
    status = [m["status"] for m in mutants]
    assert counts[:7] == [status.count(s) for s in _COUNTED]
    assert counts[9] == len(mutants)  # Total
    assert_clean(browser)
