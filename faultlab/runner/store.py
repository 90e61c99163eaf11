"""The crash-safe results store: one SQLite file (WAL mode) per campaign.

Layout of an output directory ``out``::

    out/results.sqlite                    rows, metadata, sessions
    out/cases/run{r}/{suite}/case{c}.npz  saved test cases (+ .json), shared by all variants
    out/previous-<UTC time>/              an older store moved aside by ``force_new``
    out/mutation.json, out/study.json     a mutation campaign's selection, a study's settings

Each finished job is committed as its own transaction, so a run killed with
SIGKILL loses at most the jobs in flight.  ``UNIQUE (run, suite, case, variant,
rep)`` makes a duplicate row impossible.  The ``meta`` table holds the
experiment's hash and text, the package version, the root seed and the
creation time; the ``sessions`` table one row per invocation (wall time, new rows).
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import json
import math
import os
import shutil
import sqlite3
import time
from pathlib import Path
from typing import Iterator, Mapping

import numpy as np
import pandas as pd

from faultlab import __version__
from faultlab.errors import ResultsError
from faultlab.space.case import PARAMETER_NAMES, VALUE_KEYS

__all__ = [
    "RESULTS_FILE",
    "CASES_DIR",
    "ID_COLUMNS",
    "RESULT_COLUMNS",
    "ResultStore",
    "load_results",
    "load_metadata",
    "case_path",
    "results_path",
    "store_lock",
    "SKIPPED_VARIANTS_KEY",
    "MUTATION_FILE",
    "STUDY_FILE",
]

RESULTS_FILE = "results.sqlite"
CASES_DIR = "cases"
FORMAT_VERSION = 1
#: Key of the store's metadata (:func:`load_metadata`) listing the variants skipped because their
#: fault does not apply to the SLAM: one dict per variant with ``fault`` (the variant), ``step``,
#: ``slam``, ``n_units`` and ``reason`` (one sentence).
SKIPPED_VARIANTS_KEY = "skipped_variants"
#: File in a mutation campaign's output directory recording its mutant selection and level
#: (written by :func:`faultlab.campaigns.mutation.run_mutation`).
MUTATION_FILE = "mutation.json"
#: File in a study's output directory recording its settings and sessions
#: (written by :func:`faultlab.campaigns.study.run_study`).
STUDY_FILE = "study.json"

ID_COLUMNS: tuple[str, ...] = ("run", "suite", "case", "variant", "rep")

#: Column -> SQLite type, in table order: job identity, the case's parameter values and classes, results.
_COLUMN_TYPES: dict[str, str] = {
    "run": "INTEGER", "suite": "TEXT", "case": "INTEGER", "variant": "TEXT", "rep": "INTEGER",
    **{k: ("TEXT" if k == "directionality" else "REAL") for k in VALUE_KEYS},
    **{f"class_{p}": "INTEGER" for p in PARAMETER_NAMES},
    "n_landmarks": "INTEGER",
    "rms_mm": "REAL", "emd_mm": "REAL", "n_mapped": "INTEGER", "n_unmapped": "INTEGER",
    "runtime_s": "REAL", "status": "TEXT", "error": "TEXT",
}
#: Columns of :func:`load_results`, in order.
RESULT_COLUMNS: tuple[str, ...] = tuple(_COLUMN_TYPES)
_DTYPES = {"INTEGER": "int64", "REAL": "float64", "TEXT": "object"}


def _q(name: str) -> str:
    return '"' + name.replace('"', '""') + '"'


def _now() -> str:
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def results_path(out: str | Path) -> Path:
    """The SQLite file of output directory ``out`` (``out`` may already be that file)."""
    p = Path(out)
    return p if p.suffix == ".sqlite" else p / RESULTS_FILE


def case_path(out: str | Path, run: int, suite: str, case: int) -> Path:
    """Path (``.npz``) of a saved test case; :func:`faultlab.scenario.model.load_scenario` reads it."""
    p = Path(out)
    if p.suffix == ".sqlite":
        p = p.parent
    return p / CASES_DIR / f"run{int(run)}" / str(suite) / f"case{int(case)}.npz"


@contextlib.contextmanager
def store_lock(out: str | Path) -> Iterator[None]:
    """Hold an exclusive lock on ``out`` so two campaigns never write the same store.

    The operating system releases it when the process dies, even by SIGKILL.
    """
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock
        yield
        return
    fd = os.open(out / ".lock", os.O_RDWR | os.O_CREAT, 0o644)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as exc:
            raise ResultsError(f"{out} is in use by another faultlab run (lock {out / '.lock'})") from exc
        yield
    finally:
        os.close(fd)


def _connect(path: Path) -> sqlite3.Connection:
    conn = sqlite3.connect(path, timeout=30.0, isolation_level=None)  # explicit transactions
    conn.execute("PRAGMA journal_mode=WAL")
    conn.execute("PRAGMA synchronous=FULL")
    return conn


def _schema_sql() -> list[str]:
    cols = ",\n  ".join(f"{_q(c)} {t} NOT NULL" if c in ID_COLUMNS or c == "status" else f"{_q(c)} {t}"
                        for c, t in _COLUMN_TYPES.items())
    return [
        "CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)",
        "CREATE TABLE sessions (id INTEGER PRIMARY KEY, started TEXT NOT NULL, finished TEXT, "
        "state TEXT NOT NULL, jobs INTEGER, backend TEXT, faultlab_version TEXT, n_todo INTEGER, "
        "n_new INTEGER, wall_time_s REAL, started_unix REAL NOT NULL)",
        f"CREATE TABLE results (\n  {cols},\n  session INTEGER, written_unix REAL,\n"
        f"  UNIQUE (run, suite, \"case\", variant, rep))",
    ]


def _read_meta(conn: sqlite3.Connection, path: Path) -> dict:
    try:
        rows = conn.execute("SELECT key, value FROM meta").fetchall()
    except sqlite3.DatabaseError as exc:
        raise ResultsError(f"{path} is not a faultlab results store ({exc})") from exc
    meta = {k: json.loads(v) for k, v in rows}
    if meta.get("format") != FORMAT_VERSION:
        raise ResultsError(f"{path} is not a faultlab results store (format {meta.get('format')!r})")
    return meta


def _diff_keys(old: Mapping, new: Mapping, prefix: str = "") -> list[str]:
    keys = []
    for k in sorted(set(old) | set(new), key=str):
        a, b = old.get(k), new.get(k)
        name = f"{prefix}{k}"
        if isinstance(a, Mapping) and isinstance(b, Mapping):
            keys += _diff_keys(a, b, name + ".")
        elif a != b:
            keys.append(name)
    return keys


class ResultStore:
    """Open results store of one campaign (used by the parent process only).

    Use :meth:`open`; rows are added with :meth:`write`, one committed
    transaction each.
    """

    def __init__(self, out: Path, conn: sqlite3.Connection, meta: dict):
        self.out = out
        self.path = results_path(out)
        self.conn = conn
        self.meta = meta

    # ------------------------------------------------------------ lifecycle
    @classmethod
    def open(cls, out: str | Path, experiment, *, force_new: bool = False) -> "ResultStore":
        """Create the store of ``experiment`` in ``out``, or reopen it to resume.

        With ``force_new`` an existing store and its cases are first moved to
        ``out/previous-<UTC time>/`` (never deleted) and a fresh store is created.

        Raises
        ------
        ResultsError
            If ``out`` holds the results of a different experiment (another
            hash) and ``force_new`` is False, or a file that is not a store.
        """
        out = Path(out)
        out.mkdir(parents=True, exist_ok=True)
        path = results_path(out)
        if path.exists() and force_new:
            cls._move_aside(out)
        elif path.exists():
            conn = _connect(path)
            try:
                meta = _read_meta(conn, path)
            except ResultsError:
                conn.close()
                raise
            if meta.get("experiment_hash") == experiment.hash:
                return cls(out, conn, meta)
            conn.close()
            old = json.loads(meta.get("experiment", "{}"))
            changed = _diff_keys(old, json.loads(experiment.canonical_json()))
            raise ResultsError(
                f"{out} holds results of a different experiment ({meta.get('experiment_source')}, "
                f"hash {str(meta.get('experiment_hash'))[:12]}) than {experiment.source} "
                f"(hash {experiment.hash[:12]}); changed: {', '.join(changed) or 'unknown'}. "
                f"Rerun with the original experiment to resume, or use --force-new (force_new=True) "
                f"to start a new store (the old one is moved aside, not deleted)")
        elif force_new and (out / CASES_DIR).exists():
            cls._move_aside(out)  # cases without a store: keep them too
        conn = _connect(path)
        meta = {
            "format": FORMAT_VERSION,
            "experiment_hash": experiment.hash,
            "experiment_source": experiment.source,
            "experiment_text": experiment.text,
            "experiment": experiment.canonical_json(),
            "description": experiment.description,
            "faultlab_version": __version__,
            "root_seed": experiment.seed,
            "metric": experiment.metric,
            "detection": experiment.detection.to_dict(),
            "suites": list(experiment.suite_kinds),
            "variants": list(experiment.variants),
            "created": _now(),
        }
        conn.execute("BEGIN")
        for stmt in _schema_sql():
            conn.execute(stmt)
        conn.executemany("INSERT INTO meta (key, value) VALUES (?, ?)",
                         [(k, json.dumps(v)) for k, v in meta.items()])
        conn.execute("COMMIT")
        return cls(out, conn, meta)

    @staticmethod
    def _move_aside(out: Path) -> Path:
        stamp = _dt.datetime.now(_dt.timezone.utc).strftime("%Y%m%dT%H%M%SZ")
        dest = out / f"previous-{stamp}"
        n = 1
        while dest.exists():
            n += 1
            dest = out / f"previous-{stamp}-{n}"
        dest.mkdir()
        for name in (RESULTS_FILE, RESULTS_FILE + "-wal", RESULTS_FILE + "-shm", CASES_DIR):
            if (out / name).exists():
                shutil.move(str(out / name), str(dest / name))
        return dest

    def close(self) -> None:
        self.conn.close()

    def __enter__(self) -> "ResultStore":
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def set_meta(self, key: str, value) -> None:
        """Set one metadata entry (JSON-serialisable ``value``; committed at once, replacing an older one)."""
        with self.conn:
            self.conn.execute("INSERT OR REPLACE INTO meta (key, value) VALUES (?, ?)", (key, json.dumps(value)))
        self.meta[key] = value

    # ------------------------------------------------------------ sessions
    def begin_session(self, *, jobs: int, backend: str, n_todo: int) -> int:
        cur = self.conn.execute(
            "INSERT INTO sessions (started, state, jobs, backend, faultlab_version, n_todo, n_new, started_unix) "
            "VALUES (?, 'running', ?, ?, ?, ?, 0, ?)", (_now(), jobs, backend, __version__, n_todo, time.time()))
        return int(cur.lastrowid)

    def end_session(self, session: int, *, state: str, n_new: int, wall_time_s: float) -> None:
        self.conn.execute("UPDATE sessions SET finished = ?, state = ?, n_new = ?, wall_time_s = ? WHERE id = ?",
                          (_now(), state, n_new, wall_time_s, session))

    # ------------------------------------------------------------ rows
    def done_keys(self) -> set[tuple]:
        """Identities (run, suite, case, variant, rep) of the rows already stored."""
        return set(self.conn.execute('SELECT run, suite, "case", variant, rep FROM results').fetchall())

    def status_counts(self) -> dict[str, int]:
        return dict(self.conn.execute("SELECT status, COUNT(*) FROM results GROUP BY status").fetchall())

    def write(self, row: Mapping, *, session: int | None = None) -> None:
        """Insert one row (keys = :data:`RESULT_COLUMNS`) in its own committed transaction."""
        values = []
        for c in RESULT_COLUMNS:
            v = row[c]
            if isinstance(v, np.generic):
                v = v.item()
            if isinstance(v, float) and math.isnan(v):
                v = None
            values.append(v)
        cols = ", ".join(_q(c) for c in RESULT_COLUMNS)
        marks = ", ".join("?" for _ in RESULT_COLUMNS)
        try:
            with self.conn:  # noqa: SIM117 - commit per row
                self.conn.execute("BEGIN")
                self.conn.execute(f"INSERT INTO results ({cols}, session, written_unix) VALUES ({marks}, ?, ?)",
                                  values + [session, time.time()])
                if session is not None:
                    self.conn.execute("UPDATE sessions SET n_new = n_new + 1 WHERE id = ?", (session,))
        except sqlite3.IntegrityError as exc:
            key = tuple(row[c] for c in ID_COLUMNS)
            raise ResultsError(f"{self.path}: job {key} is already stored ({exc})") from exc


# ---------------------------------------------------------------------- reading
def _open_existing(out: str | Path) -> tuple[Path, sqlite3.Connection]:
    path = results_path(out)
    if not path.is_file():
        raise ResultsError(f"no results store at {path}")
    return path, sqlite3.connect(path, timeout=30.0)


def load_metadata(out: str | Path) -> dict:
    """Metadata of a store: experiment hash/text/source, version, root seed, created, sessions.

    ``sessions`` lists every invocation (started, finished, state, jobs, backend,
    n_new, wall_time_s); ``wall_time_s`` is their sum (a session killed before
    it finished counts until its last stored row); ``n_rows`` the stored rows.
    """
    path, conn = _open_existing(out)
    try:
        meta = _read_meta(conn, path)
        conn.row_factory = sqlite3.Row
        sessions = [dict(r) for r in conn.execute("SELECT * FROM sessions ORDER BY id")]
        last = dict(conn.execute("SELECT session, MAX(written_unix) FROM results GROUP BY session").fetchall())
        n_rows = conn.execute("SELECT COUNT(*) FROM results").fetchone()[0]
    finally:
        conn.close()
    for s in sessions:
        if s["wall_time_s"] is None:  # killed: count until its last row
            s["wall_time_s"] = max(0.0, (last.get(s["id"]) or s["started_unix"]) - s["started_unix"])
            if s["state"] == "running":
                s["state"] = "killed"
        del s["started_unix"]
    meta["experiment"] = json.loads(meta["experiment"])
    meta["sessions"] = sessions
    meta["wall_time_s"] = float(sum(s["wall_time_s"] for s in sessions))
    meta["n_rows"] = int(n_rows)
    meta["path"] = str(path)
    return meta


def load_results(out: str | Path) -> pd.DataFrame:
    """All rows of a store as a DataFrame (columns :data:`RESULT_COLUMNS`).

    Sorted by run, suite (experiment order), case, variant (experiment order), rep.
    ``rms_mm``/``emd_mm`` are NaN unless ``status == "ok"``; ``error`` is "" when ok.
    """
    path, conn = _open_existing(out)
    try:
        meta = _read_meta(conn, path)
        cols = ", ".join(_q(c) for c in RESULT_COLUMNS)
        rows = conn.execute(f"SELECT {cols} FROM results").fetchall()
    finally:
        conn.close()
    df = pd.DataFrame.from_records(rows, columns=list(RESULT_COLUMNS))
    for c, t in _COLUMN_TYPES.items():
        df[c] = df[c].astype(_DTYPES[t])
    df["error"] = df["error"].fillna("")
    order_s = {s: i for i, s in enumerate(meta.get("suites", []))}
    order_v = {v: i for i, v in enumerate(meta.get("variants", []))}
    df = df.sort_values(["run", "suite", "case", "variant", "rep"], kind="mergesort", key=lambda s: (
        s.map(lambda x: (order_s if s.name == "suite" else order_v).get(x, len(order_s) + len(order_v)))
        if s.name in ("suite", "variant") else s))
    return df.reset_index(drop=True)
