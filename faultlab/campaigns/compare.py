"""``faultlab compare``: record the map errors of a SLAM on a declared suite, for a baseline and a candidate.

A *record* is a directory: ``record.json`` (the :class:`RecordSpec` -- the SLAM, the suite, its seed,
the repetitions and their seed -- with its digest and the case ids) and one ``cases/<case>.json`` per
case as it finishes (written atomically): the raw map error of every repetition (mm; ``null`` and
the error message for a run that failed), whether the SLAM was deterministic on the case, the
case's parameter values and size.  Every case file carries the SHA-256 of its content, so a
damaged file is refused with its path (never read as a wrong number nor silently recomputed), and
an interrupted recording resumes with the cases not yet recorded.  A baseline is recorded once and
reused for any number of candidates: the comparison reads the raw per-case errors, not a summary.

The suite is :mod:`faultlab.campaigns.check`'s (default pairwise over Table I, the same case
pipeline), so baseline and candidate see the same scenarios.  A SLAM is run twice on a case; when
the two runs (different seeds) give identical estimates it is deterministic there and that one
run is its error (no pseudo-replication), as when both runs fail with the same error; otherwise all
``K`` repetitions are run.
"""

from __future__ import annotations

import hashlib
import json
import os
from collections.abc import Mapping
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from joblib import Parallel, delayed

from faultlab.campaigns.checkspec import DEFAULT_SUITE, DEFAULT_TIMEOUT_S, executor, slam_factory, use_paths
from faultlab.errors import ConfigError
from faultlab.oracles import repetition_seeds
from faultlab.oracles.oracle import map_error_mm
from faultlab.scenario.suite import SuiteCase, draw_suite, generate_case
from faultlab.space import table1_space
from faultlab.space.parameters import space_from_mapping

__all__ = ["RecordSpec", "CaseErrors", "Record", "record", "read_record", "candidate_spec", "RECORD_FILE"]

#: The head file of a record directory.
RECORD_FILE = "record.json"
#: The suite fields baseline and candidate must share.
SUITE_FIELDS = ("suite", "n_cases", "n_steps", "seed", "repetitions", "space")


@dataclass(frozen=True)
class RecordSpec:
    """What a record holds: a SLAM (built-in name or ``package.module:factory``, or a process
    ``command``) on a suite (kind, size, steps, seed, Table I overrides ``space``), ``repetitions``
    runs per case with seeds from ``rep_seed`` (default: the suite's ``seed``; a candidate with the
    baseline's uses common random numbers), each within ``timeout_s`` (a run past it failed)."""

    slam: str = ""
    command: tuple[str, ...] = ()
    slam_options: Mapping[str, Any] = field(default_factory=dict)
    suite: str = DEFAULT_SUITE
    n_cases: int | None = None
    n_steps: int = 200
    seed: int = 1
    rep_seed: int | None = None
    repetitions: int = 8
    paths: tuple[str, ...] = ()
    space: Mapping[str, Any] = field(default_factory=dict)
    timeout_s: float = DEFAULT_TIMEOUT_S

    def validate(self) -> "RecordSpec":
        if not self.timeout_s > 0:
            raise ConfigError(f"--timeout must be > 0 s, got {self.timeout_s}")
        if bool(self.slam) == bool(self.command):
            raise ConfigError("name each SLAM either as a built-in name or package.module:factory, or as a "
                              "command, not both or neither")
        if self.repetitions < 2:
            raise ConfigError(f"--repetitions must be >= 2 (two seeds tell a deterministic SLAM), got {self.repetitions}")
        if self.n_steps < 1:
            raise ConfigError(f"--steps must be >= 1, got {self.n_steps}")
        with use_paths(self.paths):
            slam_factory(self)  # imports the factory: a wrong name or path is a usage error before any run
        return self

    @property
    def label(self) -> str:
        return " ".join(self.command) if self.command else self.slam

    @property
    def repetition_seed(self) -> int:
        return self.seed if self.rep_seed is None else int(self.rep_seed)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["command"], d["paths"] = list(self.command), list(self.paths)
        d["rep_seed"] = self.repetition_seed
        return d

    @classmethod
    def from_dict(cls, d: Mapping) -> "RecordSpec":
        return cls(**{**d, "command": tuple(d["command"]), "paths": tuple(d["paths"])})

    def suite_dict(self) -> dict:
        return {k: self.to_dict()[k] for k in SUITE_FIELDS}

    def digest(self) -> str:
        return hashlib.sha256(json.dumps(self.to_dict(), sort_keys=True).encode()).hexdigest()[:16]


@dataclass(frozen=True)
class CaseErrors:
    """One recorded case: the map error of each repetition (mm, NaN where the run failed)."""

    case_id: str
    values: Mapping[str, Any]
    n_steps: int
    n_landmarks: int
    deterministic: bool
    errors_mm: tuple[float, ...]
    failures: tuple[str, ...]

    @property
    def ok(self) -> bool:
        """Every recorded run finished with a scorable map."""
        return bool(self.errors_mm) and all(np.isfinite(self.errors_mm))

    @property
    def log_errors(self) -> np.ndarray:
        return np.log(np.asarray(self.errors_mm, dtype=float))

    def payload(self) -> dict:
        d = asdict(self)
        d["errors_mm"] = [None if not np.isfinite(e) else float(e) for e in self.errors_mm]
        d["failures"] = list(self.failures)
        return d


def _checksum(payload: Mapping) -> str:
    return hashlib.sha256(json.dumps(payload, sort_keys=True).encode()).hexdigest()


def _case_id(case: SuiteCase) -> str:
    return f"{case.suite}-{case.run}-{case.case:03d}"


def _write_json(path: Path, data) -> None:
    """Atomic: a case file is complete or absent, never half written."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(data, indent=1))
    os.replace(tmp, path)


def _read_case(path: Path) -> CaseErrors | None:
    """The case recorded at ``path``; None when absent; ConfigError when damaged."""
    if not path.is_file():
        return None
    try:
        data = json.loads(path.read_text())
        payload, digest = data["payload"], data["sha256"]
    except (OSError, ValueError, KeyError, TypeError):
        raise ConfigError(f"{path}: damaged record (not the JSON faultlab compare writes); "
                          "move it away to record the case again") from None
    if _checksum(payload) != digest:
        raise ConfigError(f"{path}: damaged record (checksum mismatch); move it away to record the case again")
    return CaseErrors(case_id=payload["case_id"], values=payload["values"], n_steps=int(payload["n_steps"]),
                      n_landmarks=int(payload["n_landmarks"]), deterministic=bool(payload["deterministic"]),
                      errors_mm=tuple(np.nan if e is None else float(e) for e in payload["errors_mm"]),
                      failures=tuple(payload["failures"]))


def _record_case(spec: RecordSpec, case: SuiteCase, out: Path) -> CaseErrors:
    case_id = _case_id(case)
    scenario = generate_case(case, n_steps=spec.n_steps)
    seeds = repetition_seeds(spec.repetition_seed, case_id, spec.repetitions)
    with use_paths(spec.paths):
        factory, execute = slam_factory(spec), executor(spec)  # each run within the wall-clock limit
        outcomes = [execute(factory, scenario, seeds[0]), execute(factory, scenario, seeds[1])]
        a, b = outcomes
        if a.ok and b.ok:
            deterministic = (np.array_equal(a.estimate.pose, b.estimate.pose)
                             and np.array_equal(a.estimate.landmark_ids, b.estimate.landmark_ids)
                             and np.array_equal(a.estimate.landmarks, b.estimate.landmarks))
        else:  # failed twice the same way: a deterministic failure
            deterministic = not a.ok and not b.ok and a.error == b.error
        if deterministic:
            outcomes = [a]
        else:
            outcomes += [execute(factory, scenario, s) for s in seeds[2:]]
    errors = [map_error_mm(scenario, o) for o in outcomes]
    rec = CaseErrors(case_id=case_id, values=dict(case.spec.values), n_steps=scenario.n_steps,
                     n_landmarks=int(scenario.landmarks.shape[0]), deterministic=bool(deterministic),
                     errors_mm=tuple(e if np.isfinite(e) else np.nan for e in errors),
                     failures=tuple(o.error if not o.ok else ("" if np.isfinite(e) else "map not scorable")
                                    for o, e in zip(outcomes, errors)))
    payload = rec.payload()
    _write_json(out / "cases" / f"{case_id}.json", {"payload": payload, "sha256": _checksum(payload)})
    return rec


def _cases(spec: RecordSpec) -> tuple[SuiteCase, ...]:
    space = space_from_mapping(spec.space, source="compare space") if spec.space else table1_space()
    return draw_suite(spec.suite, space, root_seed=spec.seed, n_cases=spec.n_cases)


@dataclass(frozen=True)
class Record:
    """A record directory read back: its spec, the suite's case ids and the cases recorded so far."""

    spec: RecordSpec
    case_ids: tuple[str, ...]
    cases: tuple[CaseErrors, ...]

    @property
    def complete(self) -> bool:
        return len(self.cases) == len(self.case_ids)


def read_record(out: str | Path) -> Record:
    """The record in ``out`` (ConfigError if it holds none, or a damaged one)."""
    out = Path(out)
    head = out / RECORD_FILE
    if not head.is_file():
        raise ConfigError(f"{out}: not a faultlab compare record (no {RECORD_FILE})")
    try:
        meta = json.loads(head.read_text())
        spec = RecordSpec.from_dict(meta["spec"])
        ids = list(meta["cases"])
    except (OSError, ValueError, KeyError, TypeError):
        raise ConfigError(f"{head}: damaged (not the JSON faultlab compare writes)") from None
    if meta.get("digest") != spec.digest():
        raise ConfigError(f"{head}: damaged (its digest does not match its spec)")
    cases = tuple(r for i in ids if (r := _read_case(out / "cases" / f"{i}.json")) is not None)
    return Record(spec, tuple(ids), cases)


def record(spec: RecordSpec, out: str | Path, *, jobs: int = 1) -> list[CaseErrors]:
    """Record (or resume recording) ``spec`` into ``out``; the records of every case, in suite order.

    A directory holding a record of another spec is refused (ConfigError) and left untouched.
    """
    spec = spec.validate()
    out = Path(out)
    cases = _cases(spec)
    meta = {"spec": spec.to_dict(), "digest": spec.digest(), "cases": [_case_id(c) for c in cases]}
    head = out / RECORD_FILE
    if head.is_file():
        old = read_record(out).spec
        if old.digest() != spec.digest():
            raise ConfigError(f"{out} holds a record of another SLAM or suite ({head}); use another directory")
    elif out.exists() and any(out.iterdir()):
        raise ConfigError(f"{out} is not empty and holds no compare record; use another directory")
    else:
        _write_json(head, meta)
    done = {r.case_id: r for r in read_record(out).cases}
    todo = [c for c in cases if _case_id(c) not in done]
    if todo:
        env_path = os.pathsep.join([str(Path(p).resolve()) for p in (*spec.paths, os.getcwd())]
                                   + [p for p in os.environ.get("PYTHONPATH", "").split(os.pathsep) if p])
        os.environ["PYTHONPATH"] = env_path  # loky workers start afresh: the factory's module must import there
        for r in Parallel(n_jobs=jobs)(delayed(_record_case)(spec, c, out) for c in todo):
            done[r.case_id] = r
    return [done[_case_id(c)] for c in cases]


def candidate_spec(baseline: RecordSpec, *, slam: str = "", command: tuple[str, ...] = (),
                   slam_options: Mapping[str, Any] | None = None, rep_seed: int | None = None,
                   paths: tuple[str, ...] = ()) -> RecordSpec:
    """The candidate's spec: the baseline's suite and repetitions, another SLAM (and repetition seed)."""
    return replace(baseline, slam=slam, command=tuple(command), slam_options=dict(slam_options or {}),
                   rep_seed=baseline.repetition_seed if rep_seed is None else rep_seed,
                   paths=tuple(dict.fromkeys((*baseline.paths, *paths))))
