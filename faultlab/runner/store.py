"""The crash-safe results store: one SQLite file (WAL mode) per campaign.

Layout of an output directory ``out``::

    out/results.sqlite                    rows, metadata, sessions
    out/cases/run{r}/{suite}/case{c}.npz  saved test cases (+ .json), shared by all variants
    out/previous-<UTC time>/              an older store moved aside by ``force_new``
    out/mutation.json, out/study.json     a mutation campaign's selection, a study's settings

The jobs a worker returns together (the repetitions of one batch) are committed as one
transaction as soon as they arrive, so a run killed with SIGKILL loses at most the jobs in
flight.  ``UNIQUE (run, suite, case, variant,
rep)`` makes a duplicate row impossible.  The ``meta`` table holds the
experiment's hash and text, the package version, the root seed and the
creation time; the ``sessions`` table one row per invocation (wall time, new rows).

Row integrity.  Every row carries a checksum of its values (:func:`row_checksum`): a 16-byte
BLAKE2b digest of a type-tagged encoding of the :data:`RESULT_COLUMNS` values, followed by a
2-byte digest per column.  It is computed when the row is written and verified by every read
that feeds an analysis (:func:`load_results`), so a byte changed on disk (a bad sector, a stray
write) is one :class:`~faultlab.errors.ResultsError` naming the store, the row and the column
instead of a silently wrong number.  SQLite's own ``PRAGMA integrity_check`` only checks the
b-tree structure, not the values.  A store without row checksums (written before they existed, or
with its integrity entries removed: the two look the same) is refused by every reader and by a
resuming writer unless :func:`accept_unverified` (``faultlab --accept-unverified``); then it reads
with an :class:`UnverifiedStoreWarning`.

Reading never writes: :func:`load_results` and :func:`load_metadata` open the file read-only
(``immutable=1`` when no writer holds the store and no write-ahead log is pending), so reading
a committed store leaves no ``-wal``/``-shm`` files behind.
"""

from __future__ import annotations

import contextlib
import datetime as _dt
import functools
import hashlib
import json
import math
import os
import shutil
import sqlite3
import threading
import time
import urllib.parse
import warnings
from pathlib import Path
from typing import Iterator, Mapping

import numpy as np
import pandas as pd

from faultlab import __version__
from faultlab.errors import InvalidCaseError, ResultsError, ScenarioError
from faultlab.scenario.model import load_scenario
from faultlab.vocabulary import BASELINE, MAP_METRICS, METRICS, JobStatus
from faultlab.space.case import PARAMETER_NAMES, VALUE_KEYS

__all__ = [
    "usable_rows",
    "RESULTS_FILE",
    "CASES_DIR",
    "ID_COLUMNS",
    "RESULT_COLUMNS",
    "ResultStore",
    "load_results",
    "load_metadata",
    "load_sessions",
    "settle_sessions",
    "case_path",
    "results_path",
    "store_lock",
    "ensure_out_dir",
    "check_store",
    "check_store_meta",
    "row_checksum",
    "UnverifiedStoreWarning",
    "accept_unverified",
    "SKIPPED_VARIANTS_KEY",
    "METRICS_KEY",
    "recorded_metrics",
    "job_metrics",
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
#: Key of the store's metadata listing the metrics recorded for every job (the experiment's
#: ``metrics``); the others are NULL in every row.  Stores from before the key recorded both map
#: errors (:data:`~faultlab.vocabulary.MAP_METRICS`) and no trajectory error.
METRICS_KEY = "metrics"
#: File in a mutation campaign's output directory recording its mutant selection and level
#: (written by :func:`faultlab.campaigns.mutation.run_mutation`).
MUTATION_FILE = "mutation.json"
#: File in a mutation campaign on user code: the target module's source and every mutant's place,
#: diff and screening (written by :func:`faultlab.campaigns.mutation.run_mutation`).
MUTANTS_FILE = "mutants.json"
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
    "rms_mm": "REAL", "emd_mm": "REAL", "ate_mm": "REAL", "n_mapped": "INTEGER", "n_unmapped": "INTEGER",
    "runtime_s": "REAL", "status": "TEXT", "error": "TEXT",
}
#: Columns added to the results table after its first release: a store from before one lacks it (read as
#: NULL, added when the store is reopened to resume), and its rows' checksums stay valid (see
#: :data:`_DIGEST_ORDER`).
_ADDED_COLUMNS: tuple[str, ...] = ("ate_mm",)
#: Columns of :func:`load_results`, in order.
RESULT_COLUMNS: tuple[str, ...] = tuple(_COLUMN_TYPES)
_DTYPES = {"INTEGER": "int64", "REAL": "float64", "TEXT": "object"}
#: Metadata key naming the row checksum of a store (absent: a store written before checksums).
_CHECKSUM_KEY = "row_checksum"
_CHECKSUM_NAME = "blake2b-16+2/column v1"
_ROW_DIGEST, _COLUMN_DIGEST = 16, 2


class UnverifiedStoreWarning(UserWarning):
    """A store (or some of its rows) was written before row checksums existed: read without verification."""


_accepting_unverified = False


@contextlib.contextmanager
def accept_unverified(accept: bool = True) -> Iterator[None]:
    """Within the block, read and resume stores whose rows carry no checksum (``--accept-unverified``).

    A store without integrity entries (no ``row_checksum`` entry, rows without checksums) is either
    one written before faultlab checked its stores or one whose entries were removed; the two
    cannot be told apart, so every reader and a resuming writer refuse it
    (:class:`~faultlab.errors.ResultsError` naming the store and this option) unless accepted
    here.  Accepted, its unchecked rows are read with an :class:`UnverifiedStoreWarning`.  The
    setting holds for the whole process (every thread) until the block ends.
    """
    global _accepting_unverified
    before, _accepting_unverified = _accepting_unverified, bool(accept)
    try:
        yield
    finally:
        _accepting_unverified = before


def _unverified_refusal(path: Path, n_unverified: int, n_rows: int) -> ResultsError:
    return ResultsError(f"{path} has no integrity entries for {n_unverified} of its {n_rows} rows (no row "
                        f"checksums): it was written before faultlab checked its stores, or they were removed, "
                        f"and its values cannot be verified. To read it anyway: faultlab --accept-unverified "
                        f"COMMAND ... (in Python: faultlab.runner.store.accept_unverified())")


def _encode(value) -> bytes:
    """Type-tagged bytes of one stored value (what SQLite returns: None, int, float, str or bytes)."""
    if value is None:
        return b"n"
    if isinstance(value, bool) or not isinstance(value, (int, float, str, bytes)):
        return b"?" + repr(value).encode()
    if isinstance(value, int):
        return b"i" + str(value).encode()
    if isinstance(value, float):
        return b"r" + value.hex().encode()
    if isinstance(value, str):
        return b"t" + value.encode("utf-8", "surrogatepass")
    return b"b" + value


#: Order of the per-column digests of a checksum.  Never reorder or shorten it: rows already stored
#: depend on it.  A column added to the table later is appended here (``ate_mm`` was; one not yet
#: listed is placed after these, in table order), and rows written before it existed (where it is
#: NULL) keep their checksum.
_DIGEST_ORDER: tuple[str, ...] = (
    "run", "suite", "case", "variant", "rep", *VALUE_KEYS, *(f"class_{p}" for p in PARAMETER_NAMES),
    "n_landmarks", "rms_mm", "emd_mm", "n_mapped", "n_unmapped", "runtime_s", "status", "error",
    "ate_mm")


def _digest_layout() -> tuple[str, ...]:
    return _DIGEST_ORDER + tuple(c for c in RESULT_COLUMNS if c not in _DIGEST_ORDER)


def _column_digest(column: str, value) -> bytes:
    return _encoded_digest(column, _encode(value))


@functools.lru_cache(maxsize=4096)
def _encoded_digest(column: str, encoded: bytes) -> bytes:
    """The column digest of a type-tagged value; remembered, since most columns of a row are its case's
    parameters and classes, the same in every row of the case (the tag keeps 1, 1.0 and "1" apart)."""
    return hashlib.blake2b(encoded, digest_size=_COLUMN_DIGEST, person=column.encode()[:16]).digest()


def row_checksum(values) -> bytes:
    """Checksum of one row's values (in :data:`RESULT_COLUMNS` order, as stored).

    A 16-byte BLAKE2b digest of every non-NULL value with its column name (length-prefixed,
    type-tagged: any change of a value, of its type, or from or to NULL changes it), followed by a
    2-byte BLAKE2b digest per column (which column differs, for the error message).  A column
    added to the table later leaves the checksums of older rows, where it is NULL, valid.

    Parameters
    ----------
    values : sequence, shape (len(RESULT_COLUMNS),)
        None, int, float or str per column.

    Returns
    -------
    bytes, shape (16 + 2 * len(RESULT_COLUMNS),)
    """
    by_name = dict(zip(RESULT_COLUMNS, values))
    return _row_digest(by_name) + b"".join(_column_digest(c, by_name.get(c)) for c in _digest_layout() if c in by_name)


def _row_digest(by_name: Mapping) -> bytes:
    h = hashlib.blake2b(digest_size=_ROW_DIGEST, person=b"faultlab-row-v1")
    for c in sorted(by_name):
        if by_name[c] is None:
            continue
        for part in (c.encode(), _encode(by_name[c])):
            h.update(len(part).to_bytes(8, "little"))
            h.update(part)
    return h.digest()


def _damaged_columns(values, checksum) -> list[str]:
    """Columns whose value does not match ``checksum`` ([] if it matches; ["checksum"] if only it is damaged)."""
    if isinstance(checksum, bytes) and checksum[:_ROW_DIGEST] == _row_digest(dict(zip(RESULT_COLUMNS, values))):
        return []
    n = (len(checksum) - _ROW_DIGEST) // _COLUMN_DIGEST if isinstance(checksum, bytes) else -1
    if n < 0 or len(checksum) != _ROW_DIGEST + _COLUMN_DIGEST * n:
        return ["checksum"]
    by_name = dict(zip(RESULT_COLUMNS, values))
    layout = [c for c in _digest_layout() if c in by_name]
    bad = [c for i, c in enumerate(layout)
           if (i < n and checksum[_ROW_DIGEST + i * _COLUMN_DIGEST:_ROW_DIGEST + (i + 1) * _COLUMN_DIGEST]
               != _column_digest(c, by_name[c])) or (i >= n and by_name[c] is not None)]
    return bad or ["checksum"]


def _stored_values(row: Mapping) -> list:
    """The values of ``row`` as they are stored: the column's type, None for NaN or missing (a column of
    :data:`_ADDED_COLUMNS` may be absent from ``row``; every other one must be there)."""
    values = []
    for c, t in _COLUMN_TYPES.items():
        v = row.get(c) if c in _ADDED_COLUMNS else row[c]
        if isinstance(v, np.generic):
            v = v.item()
        if v is None or (isinstance(v, float) and math.isnan(v)):
            v = None
        elif t == "REAL":
            v = float(v) + 0.0  # -0.0 -> 0.0: SQLite stores a negative zero as 0
        elif t == "INTEGER":
            v = int(v)
        else:
            v = str(v)
        values.append(v)
    return values


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


def ensure_out_dir(out: str | Path) -> Path:
    """Create the output directory ``out`` (and its parents); a ResultsError if it is a file."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ResultsError(f"output directory {out} is a file, not a directory; name a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
    except FileExistsError as exc:  # a parent is a file
        raise ResultsError(f"output directory {out} cannot be created: {exc.filename} is a file") from exc
    except OSError as exc:
        raise ResultsError(f"output directory {out} cannot be created ({exc.strerror or exc})") from exc
    return out


_held_locks: dict[Path, list] = {}  # resolved out -> [fd, depth]
_held_guard = threading.Lock()


@contextlib.contextmanager
def store_lock(out: str | Path) -> Iterator[None]:
    """Hold an exclusive lock on ``out`` so two campaigns never write the same store.

    The operating system releases it when the process dies, even by SIGKILL (which leaves the lock
    file ``.lock`` behind, unlocked); a clean exit removes the file while still holding the lock.
    A writer that locked a file just removed by the previous holder takes the new one instead, so two
    writers never hold locks on different files of the same name.  Re-entrant within a process (a
    driver holds it around a call that takes it again).
    """
    out = ensure_out_dir(out)
    try:
        import fcntl
    except ImportError:  # not POSIX: no lock
        yield
        return
    key = out.resolve()
    with _held_guard:
        if key in _held_locks:
            _held_locks[key][1] += 1
        else:
            while True:
                try:
                    fd = os.open(out / ".lock", os.O_RDWR | os.O_CREAT, 0o644)
                except OSError as exc:
                    raise ResultsError(f"{out}: cannot create the lock file ({exc.strerror or exc})") from exc
                try:
                    fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
                except OSError as exc:
                    os.close(fd)
                    raise ResultsError(f"{out} is in use by another faultlab run (lock {out / '.lock'})") from exc
                if _same_file(fd, out / ".lock"):
                    break
                os.close(fd)  # the previous holder removed it after we opened it: lock the current one
            _held_locks[key] = [fd, 1]
    try:
        yield
    finally:
        with _held_guard:
            held = _held_locks[key]
            held[1] -= 1
            if held[1] == 0:
                del _held_locks[key]
                with contextlib.suppress(OSError):
                    os.unlink(out / ".lock")  # removed while held: a writer that opened it retries
                os.close(held[0])


def _same_file(fd: int, path: Path) -> bool:
    """Whether ``path`` still names the file open as ``fd``."""
    try:
        here, there = os.fstat(fd), os.stat(path)
    except OSError:
        return False
    return (here.st_dev, here.st_ino) == (there.st_dev, there.st_ino)


def _is_written(path: Path) -> bool:
    """Whether a writer may be at work on store ``path``: a write-ahead log exists (a connection is open,
    or a killed writer left committed rows in it) or another process holds its lock."""
    if path.with_name(path.name + "-wal").exists():
        return True
    lock = path.parent / ".lock"
    if path.parent.resolve() in _held_locks:  # this process: its writing connection has a -wal file
        return False
    try:
        import fcntl
        fd = os.open(lock, os.O_RDONLY)
    except (ImportError, OSError):
        return False
    try:
        fcntl.flock(fd, fcntl.LOCK_SH | fcntl.LOCK_NB)
    except OSError:
        return True
    finally:
        os.close(fd)  # closing releases a lock taken here
    return False


def _database_error(path: Path, exc: sqlite3.Error, doing: str) -> ResultsError:
    """One clear error for an SQLite failure on store ``path`` while ``doing``."""
    text = str(exc)
    if "disk is full" in text or getattr(exc, "sqlite_errorcode", None) == 13:  # SQLITE_FULL
        return ResultsError(f"{path}: the disk is full while {doing}; the rows committed before are kept. "
                            f"Free some space and rerun the same command to resume")
    if isinstance(exc, sqlite3.OperationalError) and "locked" in text:
        return ResultsError(f"{path}: the store is locked by another process while {doing} ({text})")
    return ResultsError(f"{path} is damaged or not a faultlab results store ({text}, while {doing})")


def _connect(path: Path) -> sqlite3.Connection:
    try:
        conn = sqlite3.connect(path, timeout=30.0, isolation_level=None)  # explicit transactions
    except sqlite3.Error as exc:
        raise _database_error(path, exc, "opening it") from exc
    try:
        conn.execute("PRAGMA journal_mode=WAL")
        conn.execute("PRAGMA synchronous=FULL")
    except sqlite3.Error as exc:
        conn.close()
        raise _database_error(path, exc, "opening it") from exc
    return conn


def _connect_ro(path: Path) -> sqlite3.Connection:
    """A read-only connection that creates no file (``immutable=1`` unless a writer may be at work)."""
    mode = "mode=ro" if _is_written(path) else "mode=ro&immutable=1"
    uri = f"file:{urllib.parse.quote(str(path.resolve()))}?{mode}"
    try:
        return sqlite3.connect(uri, uri=True, timeout=30.0)
    except sqlite3.Error as exc:
        raise _database_error(path, exc, "opening it") from exc


def _schema_sql() -> list[str]:
    cols = ",\n  ".join(f"{_q(c)} {t} NOT NULL" if c in ID_COLUMNS or c == "status" else f"{_q(c)} {t}"
                        for c, t in _COLUMN_TYPES.items())
    return [
        "CREATE TABLE meta (key TEXT PRIMARY KEY, value TEXT NOT NULL)",
        "CREATE TABLE sessions (id INTEGER PRIMARY KEY, started TEXT NOT NULL, finished TEXT, "
        "state TEXT NOT NULL, jobs INTEGER, backend TEXT, faultlab_version TEXT, n_todo INTEGER, "
        "n_new INTEGER, wall_time_s REAL, started_unix REAL NOT NULL)",
        f"CREATE TABLE results (\n  {cols},\n  session INTEGER, written_unix REAL, checksum BLOB,\n"
        f"  UNIQUE (run, suite, \"case\", variant, rep))",
    ]


#: Metadata key of the checksum of every other metadata entry (absent: a store written before it existed).
META_CHECKSUM_KEY = "meta_checksum"


def meta_checksum(meta: Mapping) -> str:
    """Hex BLAKE2b-16 digest of the metadata entries other than :data:`META_CHECKSUM_KEY` (canonical JSON)."""
    body = {k: v for k, v in meta.items() if k != META_CHECKSUM_KEY}
    return hashlib.blake2b(json.dumps(body, sort_keys=True, separators=(",", ":")).encode(),
                           digest_size=16).hexdigest()


def _read_meta(conn: sqlite3.Connection, path: Path) -> dict:
    try:
        rows = conn.execute("SELECT key, value FROM meta").fetchall()
        meta = {k: json.loads(v) for k, v in rows}
    except sqlite3.Error as exc:
        raise ResultsError(f"{path} is damaged or not a faultlab results store ({exc})") from exc
    except (ValueError, TypeError) as exc:
        raise ResultsError(f"{path} is damaged: its metadata cannot be read ({exc})") from exc
    if meta.get("format") != FORMAT_VERSION:
        raise ResultsError(f"{path} is not a faultlab results store (format {meta.get('format')!r})")
    if META_CHECKSUM_KEY in meta and meta[META_CHECKSUM_KEY] != meta_checksum(meta):
        raise ResultsError(f"{path} is damaged: its metadata (experiment, hash, root seed, rule, ...) does not "
                           f"match its checksum. The store cannot be trusted; restore it from a copy or rerun the "
                           f"campaign into a new directory")
    return meta


def _is_checked(meta: Mapping) -> bool:
    """Whether every row of the store must carry a valid checksum (it was created with row checksums).

    The entry that says so is covered by the metadata checksum: removing it to read the store as
    one from before checksums breaks that checksum (no silent downgrade).
    """
    return _CHECKSUM_KEY in meta


def _has_checksum_column(conn: sqlite3.Connection) -> bool:
    return any(r[1] == "checksum" for r in conn.execute("PRAGMA table_info(results)"))


def _missing_columns(conn: sqlite3.Connection) -> list[str]:
    """The :data:`_ADDED_COLUMNS` a store's results table lacks (it was written before they existed)."""
    have = {r[1] for r in conn.execute("PRAGMA table_info(results)")}
    return [c for c in _ADDED_COLUMNS if c not in have]


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


def _refusal(out: Path, meta: Mapping, experiment) -> ResultsError:
    try:
        old = json.loads(meta.get("experiment", "{}"))
    except (TypeError, ValueError):
        old = {}
    changed = _diff_keys(old, json.loads(experiment.canonical_json()))
    return ResultsError(
        f"{out} holds results of a different experiment ({meta.get('experiment_source')}, "
        f"hash {str(meta.get('experiment_hash'))[:12]}) than {experiment.source} "
        f"(hash {experiment.hash[:12]}); changed: {', '.join(changed) or 'unknown'}. "
        f"Rerun with the original experiment to resume, or use --force-new (force_new=True) "
        f"to start a new store (the old one is moved aside, not deleted)")


def _is_blank(path: Path) -> bool:
    """Whether ``path`` is an SQLite file without any table (its creator died before committing the schema)."""
    if path.stat().st_size == 0:
        return True
    try:
        conn = _connect_ro(path)
        try:
            return conn.execute("SELECT COUNT(*) FROM sqlite_master").fetchone()[0] == 0
        finally:
            conn.close()
    except (sqlite3.Error, ResultsError):
        return False


def _has_cases(out: Path) -> bool:
    """Whether ``out`` holds a saved test case (a campaign committed its store's schema before saving any)."""
    return any((out / CASES_DIR).rglob("*.npz")) if (out / CASES_DIR).is_dir() else False


def check_store(out: str | Path, experiment, *, force_new: bool = False) -> None:
    """Refuse, writing nothing, what :meth:`ResultStore.open` would refuse.

    Drivers that write files of their own next to the store call it before their first write,
    so that a refused command leaves the output directory as it was.

    Raises
    ------
    ResultsError
        ``out`` is a file, or holds a damaged store (an empty store file next to saved cases
        included), the results of a different experiment (without ``force_new``), or a store
        whose rows carry no checksums (unless :func:`accept_unverified`).
    """
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ResultsError(f"output directory {out} is a file, not a directory; name a directory")
    path = results_path(out)
    if force_new or not path.exists():
        return
    if path.stat().st_size == 0 and not path.with_name(path.name + "-wal").exists() and _has_cases(out):
        raise ResultsError(f"{path} is empty (0 bytes) although {out / CASES_DIR} holds saved test cases: the "
                           f"store was truncated or replaced, and its rows are lost. Use --force-new to start a "
                           f"new store (the old files are moved aside, not deleted)")
    if _is_blank(path):
        return
    conn = _connect_ro(path)
    try:
        meta = _read_meta(conn, path)
        unverified = n_rows = 0
        if not _is_checked(meta) and not _accepting_unverified:
            n_rows = conn.execute("SELECT COUNT(*) FROM results").fetchone()[0]
            unverified = (conn.execute("SELECT COUNT(*) FROM results WHERE checksum IS NULL").fetchone()[0]
                          if _has_checksum_column(conn) else n_rows)
    except sqlite3.Error as exc:
        raise _database_error(path, exc, "reading its rows") from exc
    finally:
        conn.close()
    if meta.get("experiment_hash") != experiment.hash:
        raise _refusal(out, meta, experiment)
    if unverified:
        raise _unverified_refusal(path, unverified, n_rows)


def check_store_meta(out: str | Path, entries: Mapping, *, force_new: bool = False) -> None:
    """Refuse, writing nothing, a store whose metadata would not hold ``entries`` as recorded before its rows.

    A store that holds one of the keys with another value, or that lacks one while already holding
    rows (the entry would be recorded after the run began), is refused; a new or empty store, or
    ``force_new``, passes.

    Raises
    ------
    ResultsError
        Naming the store, the key and what to do (a new ``--out`` or ``--force-new``).
    """
    out = Path(out)
    path = results_path(out)
    if force_new or not path.exists() or _is_blank(path):
        return
    conn = _connect_ro(path)
    try:
        meta = _read_meta(conn, path)
        n_rows = conn.execute("SELECT COUNT(*) FROM results").fetchone()[0]
    except sqlite3.Error as exc:
        raise _database_error(path, exc, "reading its metadata") from exc
    finally:
        conn.close()
    for key, value in entries.items():
        value = json.loads(json.dumps(value))
        if key not in meta and n_rows:
            raise ResultsError(f"{path}: the store holds {n_rows:,} rows and no {key!r}, which must be recorded "
                               f"before the first row; run into a new --out (or --force-new: the old store is "
                               f"moved aside, not deleted)")
        if key in meta and meta[key] != value:
            raise ResultsError(f"{path}: the store was started with another {key!r} than the one given now; it "
                               f"cannot change once recorded. Restore the file's {key} as it was, or run into a "
                               f"new --out (or --force-new: the old store is moved aside, not deleted)")


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
        Reopening closes the sessions a killed process left ``running`` as ``killed``
        (the caller holds :func:`store_lock`, so no other process is running).  A store written
        before row checksums gets the checksum column: its new rows are verified, its old ones
        are not.

        Raises
        ------
        ResultsError
            If ``out`` holds the results of a different experiment (another
            hash) and ``force_new`` is False, or a file that is not a store
            (checked before anything is written).
        """
        out = Path(out)
        check_store(out, experiment, force_new=force_new)
        out = ensure_out_dir(out)
        path = results_path(out)
        if path.exists() and not force_new and _is_blank(path):
            path.unlink()  # killed before its schema was committed: nothing to keep
        if path.exists() and force_new:
            cls._move_aside(out)
        elif path.exists():
            conn = _connect(path)
            try:
                meta = _read_meta(conn, path)
                if meta.get("experiment_hash") != experiment.hash:  # changed since check_store
                    raise _refusal(out, meta, experiment)
                store = cls(out, conn, meta)
                store._close_stale_sessions()
                if not _has_checksum_column(conn):
                    conn.execute("ALTER TABLE results ADD COLUMN checksum BLOB")
                for c in _missing_columns(conn):  # NULL in the rows already stored: their checksums hold
                    conn.execute(f"ALTER TABLE results ADD COLUMN {_q(c)} {_COLUMN_TYPES[c]}")
            except sqlite3.Error as exc:
                conn.close()
                raise _database_error(path, exc, "reopening it") from exc
            except ResultsError:
                conn.close()
                raise
            return store
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
            METRICS_KEY: list(experiment.metrics),
            "detection": experiment.detection.to_dict(),
            "suites": list(experiment.suite_kinds),
            "variants": list(experiment.variants),
            "created": _now(),
            _CHECKSUM_KEY: _CHECKSUM_NAME,
        }
        meta = json.loads(json.dumps(meta))  # as it reads back
        meta[META_CHECKSUM_KEY] = meta_checksum(meta)
        try:
            conn.execute("BEGIN")
            for stmt in _schema_sql():
                conn.execute(stmt)
            conn.executemany("INSERT INTO meta (key, value) VALUES (?, ?)",
                             [(k, json.dumps(v)) for k, v in meta.items()])
            conn.execute("COMMIT")
        except sqlite3.Error as exc:
            conn.close()
            raise _database_error(path, exc, "creating it") from exc
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

    def _execute(self, doing: str, statements) -> None:
        """Run ``statements`` ((sql, params) pairs) in one committed transaction; ResultsError on failure."""
        try:
            with self.conn:
                self.conn.execute("BEGIN")
                for sql, params in statements:
                    self.conn.execute(sql, params)
        except sqlite3.IntegrityError:
            raise
        except sqlite3.Error as exc:
            raise _database_error(self.path, exc, doing) from exc

    def set_meta(self, key: str, value) -> None:
        """Set one metadata entry (JSON-serialisable ``value``; committed at once, replacing an older one,
        together with the metadata checksum)."""
        meta = {**self.meta, key: json.loads(json.dumps(value))}
        meta[META_CHECKSUM_KEY] = meta_checksum(meta)
        self._execute(f"setting {key!r}", [("INSERT OR REPLACE INTO meta (key, value) VALUES (?, ?)",
                                           (k, json.dumps(meta[k]))) for k in (key, META_CHECKSUM_KEY)])
        self.meta = meta

    # ------------------------------------------------------------ sessions
    def _close_stale_sessions(self) -> int:
        """Mark the sessions left ``running`` by a killed process as ``killed``, with the wall time until
        their last stored row and their stored rows as ``n_new``; returns how many."""
        stale = self.conn.execute("SELECT id, started_unix FROM sessions WHERE state = 'running'").fetchall()
        if stale:
            self._execute("closing killed sessions", [
                ("UPDATE sessions SET state = 'killed', finished = ?, "
                 "n_new = (SELECT COUNT(*) FROM results WHERE session = ?), "
                 "wall_time_s = MAX(0.0, COALESCE((SELECT MAX(written_unix) FROM results WHERE session = ?), "
                 "started_unix) - started_unix) WHERE id = ?", (_now(), sid, sid, sid))
                for sid, _ in stale])
        return len(stale)

    def begin_session(self, *, jobs: int, backend: str, n_todo: int) -> int:
        try:
            cur = self.conn.execute(
                "INSERT INTO sessions (started, state, jobs, backend, faultlab_version, n_todo, n_new, started_unix) "
                "VALUES (?, 'running', ?, ?, ?, ?, 0, ?)", (_now(), jobs, backend, __version__, n_todo, time.time()))
        except sqlite3.Error as exc:
            raise _database_error(self.path, exc, "starting a session") from exc
        return int(cur.lastrowid)

    def end_session(self, session: int, *, state: str, n_new: int, wall_time_s: float) -> None:
        self._execute("ending a session", [(
            "UPDATE sessions SET finished = ?, state = ?, n_new = ?, wall_time_s = ? WHERE id = ?",
            (_now(), state, n_new, wall_time_s, session))])

    # ------------------------------------------------------------ rows
    def done_keys(self) -> set[tuple]:
        """Identities (run, suite, case, variant, rep) of the rows already stored, each verified against its
        checksum first (a resumed campaign never counts a damaged row as done)."""
        try:
            missing = set(_missing_columns(self.conn))
            cols = ", ".join("NULL" if c in missing else _q(c) for c in RESULT_COLUMNS)
            checksum = "checksum" if _has_checksum_column(self.conn) else "NULL"
            rows = self.conn.execute(f"SELECT {cols}, rowid, {checksum} FROM results").fetchall()
        except sqlite3.Error as exc:
            raise _database_error(self.path, exc, "reading the stored jobs") from exc
        _verify(self.path, rows, checked=_is_checked(self.meta))
        return {tuple(r[:len(ID_COLUMNS)]) for r in rows}

    def status_counts(self) -> dict[str, int]:
        try:
            return dict(self.conn.execute("SELECT status, COUNT(*) FROM results GROUP BY status").fetchall())
        except sqlite3.Error as exc:
            raise _database_error(self.path, exc, "counting the stored rows") from exc

    def write(self, row: Mapping, *, session: int | None = None) -> None:
        """Insert one row (keys = :data:`RESULT_COLUMNS`) with its checksum, in its own committed transaction."""
        self.write_many([row], session=session)

    def write_many(self, rows, *, session: int | None = None) -> None:
        """Insert ``rows`` (keys = :data:`RESULT_COLUMNS`), each with its checksum, in one committed transaction.

        All of them are stored or none (a job already stored refuses the whole group).  The rows are
        exactly those :meth:`write` stores one at a time; grouping the jobs a worker returns
        together (the repetitions of a batch) saves a commit, and its ``fsync``, per row.
        """
        rows = list(rows)
        if not rows:
            return
        cols = ", ".join(_q(c) for c in RESULT_COLUMNS)
        marks = ", ".join("?" for _ in RESULT_COLUMNS)
        insert = f"INSERT INTO results ({cols}, session, written_unix, checksum) VALUES ({marks}, ?, ?, ?)"
        now = time.time()
        statements = []
        for row in rows:
            values = _stored_values(row)
            statements.append((insert, values + [session, now, row_checksum(values)]))
        if session is not None:
            statements.append(("UPDATE sessions SET n_new = n_new + ? WHERE id = ?", (len(rows), session)))
        keys = [tuple(row[c] for c in ID_COLUMNS) for row in rows]
        what = f"job {keys[0]}" if len(keys) == 1 else f"{len(keys)} jobs from {keys[0]} on"
        try:
            self._execute(f"writing {what}", statements)
        except sqlite3.IntegrityError as exc:
            stored = "is" if len(keys) == 1 else "include a job that is"
            raise ResultsError(f"{self.path}: {what} {stored} already stored ({exc})") from exc


# ---------------------------------------------------------------------- reading
def _open_existing(out: str | Path) -> tuple[Path, sqlite3.Connection]:
    path = results_path(out)
    if not path.is_file():
        raise ResultsError(f"no results store at {path}")
    return path, _connect_ro(path)


def load_metadata(out: str | Path) -> dict:
    """Metadata of a store: experiment hash/text/source, version, root seed, created, sessions.

    ``sessions`` lists every invocation (started, finished, state, jobs, backend,
    n_new, wall_time_s); ``wall_time_s`` is their sum (a session killed before
    it finished counts until its last stored row, its ``n_new`` is its stored rows);
    ``n_rows`` the stored rows.  Reads the file without writing to it.
    """
    path, conn = _open_existing(out)
    try:
        meta = _read_meta(conn, path)
        sessions = _sessions(conn)
        n_rows = conn.execute("SELECT COUNT(*) FROM results").fetchone()[0]
    except sqlite3.Error as exc:
        raise _database_error(path, exc, "reading its metadata") from exc
    finally:
        conn.close()
    for s in sessions:
        del s["started_unix"]
    try:
        meta["experiment"] = json.loads(meta["experiment"])
    except (KeyError, TypeError, ValueError) as exc:
        raise ResultsError(f"{path} is damaged: its experiment cannot be read ({exc})") from exc
    meta["sessions"] = sessions
    meta["wall_time_s"] = float(sum(s["wall_time_s"] for s in sessions))
    meta["n_rows"] = int(n_rows)
    meta["path"] = str(path)
    return meta


def recorded_metrics(metadata: Mapping) -> tuple[str, ...]:
    """The metrics a store recorded (its :data:`METRICS_KEY` entry; both map errors when it has none).

    A store keeps what it was created with: resuming it records the trajectory error only if it
    did from the start (:func:`job_metrics`).
    """
    names = metadata.get(METRICS_KEY)
    return MAP_METRICS if names is None else tuple(m for m in METRICS if m in names)


def job_metrics(experiment_metrics, metadata: Mapping) -> tuple[str, ...]:
    """The metrics the jobs of an experiment record in a store: the experiment's, with the trajectory
    error (``"ate"``) only if the store recorded it from the start.

    The experiment's hash leaves ``"ate"`` out (:meth:`faultlab.runner.Experiment.canonical_json`), so
    a store created before the trajectory error existed, or without it, resumes under an experiment
    that asks for it; its rows then keep one layout (``ate_mm`` NULL in every row) and its metadata
    stays true.
    """
    stored = recorded_metrics(metadata)
    return tuple(m for m in METRICS if m in experiment_metrics and (m != "ate" or m in stored))


def _sessions(conn: sqlite3.Connection) -> list[dict]:
    """Every session of a store, a killed one's wall time counted until its last stored row and its
    stored rows as ``n_new``."""
    conn.row_factory = sqlite3.Row
    try:
        sessions = [dict(r) for r in conn.execute("SELECT * FROM sessions ORDER BY id")]
    finally:
        conn.row_factory = None
    last = dict(conn.execute("SELECT session, MAX(written_unix) FROM results GROUP BY session").fetchall())
    rows = dict(conn.execute("SELECT session, COUNT(*) FROM results GROUP BY session").fetchall())
    for s in sessions:
        if s["wall_time_s"] is None:  # killed: count until its last row
            s["wall_time_s"] = max(0.0, (last.get(s["id"]) or s["started_unix"]) - s["started_unix"])
            if s["state"] == "running":
                s["state"] = "killed"
                s["n_new"] = int(rows.get(s["id"], 0))
    return sessions


def load_sessions(out: str | Path) -> list[dict]:
    """The sessions of a store as :func:`load_metadata` lists them, each with its ``started_unix`` (s since
    the epoch); [] if there is no store yet."""
    path = results_path(out)
    if not path.is_file():
        return []
    conn = _connect_ro(path)
    try:
        return _sessions(conn)
    except sqlite3.Error as exc:
        raise _database_error(path, exc, "reading its sessions") from exc
    finally:
        conn.close()


def settle_sessions(sessions: list, store_sessions: list) -> list:
    """A driver's session records (e.g. ``study.json``'s) with every unfinished one settled from the store's.

    A driver session that did not end normally (killed: still ``running``; interrupted; or a
    record with a missing or non-finite wall time) gets the new rows the store committed in its
    time window (from its start to the next record's start: the runner's sessions started
    in it) and the wall time until its last such row; a killed one is marked ``killed``.

    Parameters
    ----------
    sessions : list of dict
        The driver's records (``started``: s since the epoch; ``state``, ``n_new``, ``wall_time_s``).
    store_sessions : list of dict
        :func:`load_sessions`.

    Returns
    -------
    list of dict
        New records; finished ones unchanged.
    """
    out = []
    for i, rec in enumerate(sessions):
        rec = dict(rec)
        wall = rec.get("wall_time_s")
        finite = isinstance(wall, (int, float)) and math.isfinite(wall)
        if rec.get("state") != "complete" or not finite:
            start = float(rec.get("started") or 0.0)
            end = float(sessions[i + 1].get("started") or math.inf) if i + 1 < len(sessions) else math.inf
            mine = [s for s in store_sessions if start <= s["started_unix"] < end]
            rec["n_new"] = int(sum(s["n_new"] or 0 for s in mine))
            if not finite:
                ends = [s["started_unix"] + s["wall_time_s"] for s in mine]
                rec["wall_time_s"] = max(0.0, max(ends, default=start) - start)
            if rec.get("state") == "running":
                rec["state"] = "killed"
        out.append(rec)
    return out


_noted: set = set()  # (store, unverified rows) already noted in this process


def _verify(path: Path, rows: list, checked: bool) -> None:
    """Raise ResultsError at the first row whose values do not match its checksum.

    ``rows``: (values..., rowid, checksum) tuples.  ``checked``: whether the store was created
    with checksums (then a row without one is damaged too).  Rows without a checksum in a store
    from before checksums are refused unless :func:`accept_unverified`, then counted for the warning.
    """
    n = len(RESULT_COLUMNS)
    unverified = 0
    for r in rows:
        values, rowid, checksum = r[:n], r[n], r[n + 1]
        if checksum is None and not checked:
            unverified += 1
            continue
        bad = _damaged_columns(values, checksum)
        if bad:
            key = ", ".join(f"{c} {v!r}" for c, v in zip(ID_COLUMNS, values))
            what = "its checksum is missing or damaged" if bad == ["checksum"] else \
                f"column{'s' if len(bad) > 1 else ''} {', '.join(bad)} {'do' if len(bad) > 1 else 'does'} " \
                f"not match its checksum"
            raise ResultsError(f"{path} is damaged: row {rowid} ({key}): {what}. The store's values cannot be "
                               f"trusted; restore it from a copy or rerun the campaign into a new directory")
    if unverified and not _accepting_unverified:
        raise _unverified_refusal(path, unverified, len(rows))
    if unverified and (path.resolve(), unverified, len(rows)) not in _noted:
        _noted.add((path.resolve(), unverified, len(rows)))
        warnings.warn(f"{path}: {unverified} of {len(rows)} rows were written before row checksums existed "
                      f"and are read without verification", UnverifiedStoreWarning, stacklevel=3)


def usable_rows(frame: pd.DataFrame, column: str) -> np.ndarray:
    """True for the stored rows a test can use: the job finished ``ok`` with a finite ``column``.

    A job ``ok`` without a finite error mapped nothing and counts as a failure, like a crash.
    """
    return (frame["status"].astype(str).to_numpy() == JobStatus.OK.value) & np.isfinite(
        frame[column].to_numpy(dtype=float))


def _check_failed_cases(path: Path, df: pd.DataFrame) -> None:
    """ResultsError ``case invalid: <file>`` if a saved case on which the baseline failed is not a valid case.

    A case with a NaN or an infinity saved with valid checksums is refused on load before any job
    runs (:func:`faultlab.scenario.model.load_scenario`); a store written before that check holds
    its jobs as crashes, which an analysis would read as "baseline failed".  Only the cases with a
    failed baseline row are read (a store of healthy cases reads none); a case file that is absent
    or damaged is left to the readers that picture cases.
    """
    failed = df.loc[(df["variant"] == BASELINE) & (df["status"] != JobStatus.OK.value), ["run", "suite", "case"]]
    for run, suite, case in failed.drop_duplicates().itertuples(index=False):
        npz = case_path(path, run, suite, case)
        if not npz.is_file():
            continue
        try:
            load_scenario(npz)
        except InvalidCaseError as exc:
            n = int(((df["run"] == run) & (df["suite"] == suite) & (df["case"] == case)).sum())
            raise ResultsError(f"case invalid: {npz}: the {n} rows of {path} on it are failures of the case, not "
                               f"results of the SLAM ({str(exc).removeprefix(f'test case {npz}: ')})") from None
        except ScenarioError:
            continue


def load_results(out: str | Path) -> pd.DataFrame:
    """All rows of a store as a DataFrame (columns :data:`RESULT_COLUMNS`), each verified against its checksum.

    Sorted by run, suite (experiment order), case, variant (experiment order), rep.
    ``rms_mm``/``emd_mm`` are NaN unless ``status == "ok"``; ``error`` is "" when ok.
    Reads the file without writing to it.

    Raises
    ------
    ResultsError
        No store, a damaged store (SQLite cannot read it, or a row's values do not match its
        checksum: the message names the store, the row and the column), or not a store; a saved
        case on which the baseline failed that is not a valid case (``case invalid: <file>``).
    """
    path, conn = _open_existing(out)
    try:
        meta = _read_meta(conn, path)
        missing = set(_missing_columns(conn))
        cols = ", ".join("NULL" if c in missing else _q(c) for c in RESULT_COLUMNS)
        checksum = "checksum" if _has_checksum_column(conn) else "NULL"
        rows = conn.execute(f"SELECT {cols}, rowid, {checksum} FROM results").fetchall()
    except sqlite3.Error as exc:
        raise _database_error(path, exc, "reading its rows") from exc
    finally:
        conn.close()
    _verify(path, rows, checked=_is_checked(meta))
    n = len(RESULT_COLUMNS)
    df = pd.DataFrame.from_records([r[:n] for r in rows], columns=list(RESULT_COLUMNS))
    try:
        for c, t in _COLUMN_TYPES.items():
            df[c] = df[c].astype(_DTYPES[t])
    except (TypeError, ValueError) as exc:  # only an unverified row can get here
        raise ResultsError(f"{path} is damaged: a column has values of the wrong type ({exc})") from exc
    df["error"] = df["error"].fillna("")
    _check_failed_cases(path, df)
    order_s = {s: i for i, s in enumerate(meta.get("suites", []))}
    order_v = {v: i for i, v in enumerate(meta.get("variants", []))}
    df = df.sort_values(["run", "suite", "case", "variant", "rep"], kind="mergesort", key=lambda s: (
        s.map(lambda x: (order_s if s.name == "suite" else order_v).get(x, len(order_s) + len(order_v)))
        if s.name in ("suite", "variant") else s))
    return df.reset_index(drop=True)
