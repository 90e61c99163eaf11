"""A mutation campaign on user code in the mutation-testing-report-schema (Stryker's report format).

The JSON that Stryker's ``mutation-testing-elements`` viewer and dashboards read (schema version
2): one file entry with the target module's source as the campaign ran it, one mutant entry per
generated mutant with its place and replacement, and one test per (run, suite, case) of the
campaign.  A mutant's status is over the whole campaign (every suite's cases together): killed
by some case -> ``Killed`` (the map error differed or the test rejected), ``RuntimeError`` (the
mutant alone crashed) or ``Timeout``; otherwise ``Survived``.  Screening classes: ``invalid`` ->
``CompileError``; ``equivalent``, ``duplicate`` and ``unsampled`` (left out by the sample budget
before screening) -> ``Ignored`` with the reason.  A reused
verdict says so in ``statusReason``.
"""

from __future__ import annotations

import pandas as pd

__all__ = ["stryker_report", "SCHEMA_VERSION"]

SCHEMA_VERSION = "2"
_KILL_STATUS = {"killed": "Killed", "crash": "RuntimeError", "timeout": "Timeout"}
_SCREEN_STATUS = {"invalid": "CompileError", "equivalent": "Ignored", "duplicate": "Ignored", "unsampled": "Ignored"}


def _test_id(run, suite, case) -> str:
    return f"run{int(run)}/{suite}/case{int(case)}"


def stryker_report(outcomes: pd.DataFrame, records: dict, *, meta: dict) -> dict:
    """The report (a JSON-ready dict) of a campaign's ``outcomes`` (:func:`~faultlab.analysis.mutation.mutant_outcomes`
    rows) and its ``mutants.json`` ``records`` (module source and per-mutant place and screening)."""
    runs = outcomes[outcomes["outcome"].isin([*_KILL_STATUS, "survived"])]
    tests = {}
    for (run, suite), n in runs.groupby(["run", "suite"])["n_cases"].max().items():
        for c in range(1, int(n) + 1):
            tests.setdefault(str(suite), []).append({"id": _test_id(run, suite, c),
                                                     "name": f"run {int(run)}, {suite} case {c}"})
    mutants = []
    by_mutant = {m: g for m, g in outcomes.groupby("mutant")}
    for mid, rec in records["mutants"].items():
        sl, sc, el, ec = rec["span"]
        entry = {"id": mid, "mutatorName": rec["operator"], "description": rec["description"],
                 "replacement": rec["replacement"],
                 "location": {"start": {"line": int(sl), "column": int(sc)}, "end": {"line": int(el), "column": int(ec)}}}
        g = by_mutant.get(mid)
        if rec["screening"] != "live":
            entry["status"] = _SCREEN_STATUS[rec["screening"]]
            entry["statusReason"] = rec["reason"]
        elif g is None:
            entry["status"] = "Ignored"
            entry["statusReason"] = "not in the campaign's sample"
        else:
            kills = g[g["outcome"].isin(list(_KILL_STATUS))]
            ran = g[g["outcome"].isin([*_KILL_STATUS, "survived"])]
            covered = [_test_id(r, s, c) for r, s, n in zip(ran["run"], ran["suite"], ran["n_cases_run"])
                       for c in range(1, int(n) + 1)]
            entry["coveredBy"] = covered
            entry["testsCompleted"] = len(covered)
            if len(kills):
                first = kills.iloc[0]
                entry["status"] = _KILL_STATUS[first["outcome"]]
                entry["killedBy"] = [_test_id(r, s, c) for r, s, c in
                                     zip(kills["run"], kills["suite"], kills["killing_case"])]
            elif len(ran):
                entry["status"] = "Survived"
            else:
                entry["status"] = "Pending"
            notes = sorted(set(str(x) for x in g["note"] if str(x) and str(x) != "nan"))
            if rec.get("trivial"):
                notes.insert(0, "fails on every probe (trivially killed; left out of the informative score)")
            if notes:
                entry["statusReason"] = "; ".join(notes)
        mutants.append(entry)
    return {
        "schemaVersion": SCHEMA_VERSION,
        "thresholds": {"high": 80, "low": 60},
        "projectRoot": ".",
        "config": {"tool": "faultlab mutate", "kill": meta.get("kill"), "alpha": meta.get("alpha"),
                   "case_alpha": meta.get("case_alpha"), "target": (meta.get("target") or {}).get("target")},
        "files": {records["path"]: {"language": "python", "source": records["source"], "mutants": mutants}},
        "testFiles": {suite: {"tests": t} for suite, t in tests.items()},
        "framework": {"name": "faultlab"},
    }
