"""``faultlab check``: a coverage-driven suite run on a SLAM under test and judged by oracles.

The suite
---------
The default suite is the **pairwise** suite over Table I (:func:`faultlab.space.registry.build_suite`
kind ``"pairwise"``): every pair of equivalence classes of two parameters appears in some case, so a
bug triggered by the interaction of two conditions (a loop path *and* outliers, a large map *and*
bearing bias) is reached with 20 cases instead of the thousands of the full product; single classes
alone (each-choice) miss such interactions, 3-wise triples the cost.  Every case is generated from
its own seed with the campaign's case pipeline (:func:`faultlab.scenario.suite.generate_case`), so
``faultlab generate --suite pairwise --seed S`` writes the same cases.

Each case is run ``K`` times (one seed per repetition, :func:`faultlab.oracles.repetition_seeds`) and
judged by the oracles (:func:`faultlab.oracles.judge_case`).  A failing case is reduced to a minimal
one (:mod:`faultlab.oracles.shrink`) and written as a reproducer.  Cases are judged in worker
processes (joblib); each case's judgement is written to ``out/cases/<case>.json`` as it finishes, so
an interrupted check resumes with the cases not yet judged.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from joblib import Parallel, delayed

from faultlab.campaigns.checkshrink import reduce_failure
from faultlab.campaigns.checkspec import DEFAULT_ORACLES, DEFAULT_SUITE, CheckSpec, judge_scenario
from faultlab.errors import ConfigError
from faultlab.scenario.suite import SuiteCase, draw_suite, generate_case

__all__ = ["DEFAULT_SUITE", "DEFAULT_ORACLES", "CheckSpec", "CaseRecord", "judge_scenario", "run_check",
           "case_records"]


@dataclass(frozen=True)
class CaseRecord:
    """One judged case as stored in ``out/cases/<case>.json``."""

    case_id: str
    values: Mapping[str, Any]
    n_steps: int
    n_landmarks: int
    deterministic: bool
    executions: int
    alpha_per_test: float
    results: tuple[dict, ...]
    reduction: Mapping[str, Any] | None = None

    @property
    def failed(self) -> bool:
        return any(r["status"] == "fail" for r in self.results)


def _case_id(case: SuiteCase) -> str:
    return f"{case.suite}-{case.run}-{case.case:03d}"


def _judge_and_store(spec: CheckSpec, case: SuiteCase, out: Path, shrink: bool) -> CaseRecord:
    case_id = _case_id(case)
    scenario = generate_case(case, n_steps=spec.n_steps)
    space = spec.parameter_space()
    classes = {name: space[name].class_names[index] for name, index in case.spec.classes.items()}
    judgement = judge_scenario(spec, case_id, scenario, classes)
    reduction = None
    if judgement.failed and shrink:
        reduction = reduce_failure(spec, case_id, scenario, judgement, out, classes)
    record = CaseRecord(case_id=case_id, values=dict(case.spec.values), n_steps=scenario.n_steps,
                        n_landmarks=int(scenario.landmarks.shape[0]), deterministic=judgement.deterministic,
                        executions=judgement.executions, alpha_per_test=judgement.alpha_per_test,
                        results=tuple(r.to_dict() for r in judgement.results), reduction=reduction)
    _write_json(out / "cases" / f"{case_id}.json", asdict(record))
    return record


def _write_json(path: Path, data) -> None:
    """Write atomically: a finished record is complete or absent, never half written."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(data, indent=1, default=str))
    os.replace(tmp, path)


def _read_record(path: Path) -> CaseRecord | None:
    try:
        data = json.loads(path.read_text())
        data["results"] = tuple(data["results"])
        return CaseRecord(**data)
    except (OSError, ValueError, TypeError, KeyError):
        return None  # damaged or from an interrupted write: judged again


def case_records(out: str | Path) -> list[CaseRecord]:
    """The judged cases of a check directory, in case order (ConfigError if it holds no check)."""
    out = Path(out)
    if not (out / "check.json").is_file():
        raise ConfigError(f"{out}: not a check directory (no check.json)")
    return [r for p in sorted((out / "cases").glob("*.json")) if (r := _read_record(p)) is not None]


def run_check(spec: CheckSpec, out: str | Path, *, jobs: int = 1, shrink: bool = True) -> list[CaseRecord]:
    """Run (or resume) a check into ``out``; returns the records of every case, in suite order.

    ``out/check.json`` holds the spec; a directory holding another spec's check is refused.
    """
    spec = spec.validate()
    out = Path(out)
    cases = draw_suite(spec.suite, spec.parameter_space(), root_seed=spec.seed, n_cases=spec.n_cases)
    head = out / "check.json"
    meta = {"spec": spec.to_dict(), "digest": spec.digest(), "cases": [_case_id(c) for c in cases]}
    if head.is_file():
        try:
            old = json.loads(head.read_text())
        except ValueError:
            raise ConfigError(f"{head}: damaged (not JSON); move it away to start afresh") from None
        if old.get("digest") != meta["digest"]:
            raise ConfigError(f"{out} holds a check of another SLAM or settings ({head}); use another --out")
    else:
        _write_json(head, meta)
    done = {}
    for c in cases:
        r = _read_record(out / "cases" / f"{_case_id(c)}.json")
        if r is not None:
            done[_case_id(c)] = r
    todo = [c for c in cases if _case_id(c) not in done]
    if todo:
        env_path = os.pathsep.join([str(Path(p).resolve()) for p in (*spec.paths, os.getcwd())]
                                   + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])
        os.environ["PYTHONPATH"] = env_path  # loky workers start afresh: the factory's module must import there
        for r in Parallel(n_jobs=jobs)(delayed(_judge_and_store)(spec, c, out, shrink) for c in todo):
            done[r.case_id] = r
    return [done[_case_id(c)] for c in cases]
