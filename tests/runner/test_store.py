import math
import sqlite3
import struct
import warnings

import numpy as np
import pandas as pd
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from faultlab.errors import ResultsError
from faultlab.runner.experiment import parse_experiment
from faultlab.runner.store import (
    RESULT_COLUMNS,
    ResultStore,
    case_path,
    load_metadata,
    load_results,
    UnverifiedStoreWarning,
    accept_unverified,
    check_store,
    results_path,
    row_checksum,
    store_lock,
)
from faultlab.space.case import FIXED_VALUES, PARAMETER_NAMES, VALUE_KEYS
from tests.runner.suts import tiny_experiment


def _row(run, suite, case, variant, rep, *, status="ok", rms=100.0):
    row = {"run": run, "suite": suite, "case": case, "variant": variant, "rep": rep}
    row.update({k: FIXED_VALUES[k] for k in VALUE_KEYS})
    row.update({f"class_{p}": i % 3 for i, p in enumerate(PARAMETER_NAMES)})
    ok = status == "ok"
    row.update(n_landmarks=320, rms_mm=rms if ok else math.nan, emd_mm=2 * rms if ok else math.nan,
               n_mapped=300 if ok else 0, n_unmapped=20 if ok else 0, runtime_s=0.5, status=status,
               error="" if ok else "ZeroDivisionError: boom")
    return row


@pytest.fixture
def exp():
    return parse_experiment(tiny_experiment(), source="tiny.toml", text="seed = 11\n")


def test_schema_columns():
    assert RESULT_COLUMNS[:5] == ("run", "suite", "case", "variant", "rep")
    assert set(VALUE_KEYS) <= set(RESULT_COLUMNS)
    assert {f"class_{p}" for p in PARAMETER_NAMES} <= set(RESULT_COLUMNS)
    for c in ("n_landmarks", "rms_mm", "emd_mm", "n_mapped", "n_unmapped", "runtime_s", "status", "error"):
        assert c in RESULT_COLUMNS


def test_write_and_load_roundtrip_sorted_with_types(tmp_path, exp):
    rows = [_row(2, "random", 1, "baseline", 0, rms=1.0),
            _row(1, "fixed", 1, "tests.runner.suts:BIAS", 1, status="crash"),
            _row(1, "fixed", 1, "baseline", 1, rms=2.0),
            _row(1, "random", 2, "baseline", 0, rms=3.0),
            _row(1, "random", 1, "tests.runner.suts:BIAS", 0, rms=4.0),
            _row(1, "random", 1, "baseline", 0, rms=5.0)]
    with ResultStore.open(tmp_path, exp) as store:
        for r in rows:
            store.write(r)
        assert store.done_keys() == {(r["run"], r["suite"], r["case"], r["variant"], r["rep"]) for r in rows}
        assert store.status_counts() == {"ok": 5, "crash": 1}
    df = load_results(tmp_path)
    assert list(df.columns) == list(RESULT_COLUMNS)
    # sorted by run, suite (experiment order: random before fixed), case, variant (experiment order), rep
    assert list(zip(df.run, df.suite, df.case, df.variant, df.rep)) == [
        (1, "random", 1, "baseline", 0), (1, "random", 1, "tests.runner.suts:BIAS", 0),
        (1, "random", 2, "baseline", 0), (1, "fixed", 1, "baseline", 1),
        (1, "fixed", 1, "tests.runner.suts:BIAS", 1), (2, "random", 1, "baseline", 0)]
    np.testing.assert_array_equal(df.rms_mm.to_numpy(), [5.0, 4.0, 3.0, 2.0, np.nan, 1.0])
    crash = df[df.status == "crash"].iloc[0]
    assert math.isnan(crash.emd_mm) and crash.error == "ZeroDivisionError: boom" and crash.n_mapped == 0
    assert (df[df.status == "ok"].error == "").all()
    for c in ("run", "case", "rep", "n_landmarks", "n_mapped", "n_unmapped", "class_bias"):
        assert df[c].dtype == np.int64, c
    for c in ("rms_mm", "emd_mm", "runtime_s", "map_size", "inactivity"):
        assert df[c].dtype == np.float64, c
    assert set(df.directionality) == {"random"}
    assert df.field_of_view.iloc[0] == FIXED_VALUES["field_of_view"]


def test_empty_store_loads_empty_frame(tmp_path, exp):
    ResultStore.open(tmp_path, exp).close()
    df = load_results(tmp_path)
    assert len(df) == 0 and list(df.columns) == list(RESULT_COLUMNS)


def test_duplicate_row_is_refused(tmp_path, exp):
    with ResultStore.open(tmp_path, exp) as store:
        store.write(_row(1, "random", 1, "baseline", 0))
        with pytest.raises(ResultsError, match="already stored"):
            store.write(_row(1, "random", 1, "baseline", 0, rms=7.0))
    assert len(load_results(tmp_path)) == 1
    assert load_results(tmp_path).rms_mm.iloc[0] == 100.0


def test_wal_mode_and_metadata(tmp_path, exp):
    from faultlab import __version__

    with ResultStore.open(tmp_path, exp) as store:
        s = store.begin_session(jobs=2, backend="loky", n_todo=1)
        store.write(_row(1, "random", 1, "baseline", 0), session=s)
        store.end_session(s, state="complete", n_new=1, wall_time_s=1.25)
        assert store.conn.execute("PRAGMA journal_mode").fetchone()[0] == "wal"
    meta = load_metadata(tmp_path)
    assert meta["experiment_hash"] == exp.hash and meta["root_seed"] == 11
    assert meta["faultlab_version"] == __version__
    assert meta["experiment_text"] == "seed = 11\n" and meta["experiment"]["runs"] == 2
    assert meta["sessions"][0]["n_new"] == 1 and meta["wall_time_s"] == 1.25 and meta["n_rows"] == 1
    assert meta["created"]


def test_killed_session_counts_until_last_row(tmp_path, exp):
    with ResultStore.open(tmp_path, exp) as store:
        store.begin_session(jobs=2, backend="loky", n_todo=5)  # never ended: like a SIGKILL
    meta = load_metadata(tmp_path)
    assert meta["sessions"][0]["state"] == "killed" and meta["sessions"][0]["wall_time_s"] >= 0.0


def test_changed_experiment_is_refused_unless_force_new(tmp_path, exp):
    with ResultStore.open(tmp_path, exp) as store:
        store.write(_row(1, "random", 1, "baseline", 0))
    (tmp_path / "cases").mkdir()
    (tmp_path / "cases" / "marker").write_text("old case")
    changed = exp.merge(repetitions=3, slam={"options": {"noise": 0.5}})
    with pytest.raises(ResultsError, match=r"different experiment.*changed: repetitions, slam.options.noise"):
        ResultStore.open(tmp_path, changed)
    assert load_metadata(tmp_path)["experiment_hash"] == exp.hash  # untouched
    # reopening with the same experiment resumes
    with ResultStore.open(tmp_path, exp) as store:
        assert len(store.done_keys()) == 1
    with ResultStore.open(tmp_path, changed, force_new=True) as store:
        assert store.done_keys() == set()
    assert load_metadata(tmp_path)["experiment_hash"] == changed.hash
    # the old store and its cases were moved aside, not deleted
    (old,) = tmp_path.glob("previous-*")
    assert load_results(old / "results.sqlite").rms_mm.tolist() == [100.0]
    assert (old / "cases" / "marker").read_text() == "old case"
    assert not (tmp_path / "cases").exists()


def test_force_new_with_the_same_experiment_starts_afresh(tmp_path, exp):
    with ResultStore.open(tmp_path, exp) as store:
        store.write(_row(1, "random", 1, "baseline", 0))
    with ResultStore.open(tmp_path, exp, force_new=True) as store:
        assert store.done_keys() == set()
    (old,) = tmp_path.glob("previous-*")
    assert len(load_results(old)) == 1 and len(load_results(tmp_path)) == 0


def test_foreign_file_is_refused(tmp_path, exp):
    conn = sqlite3.connect(results_path(tmp_path))
    conn.execute("CREATE TABLE x (a)")
    conn.close()
    with pytest.raises(ResultsError, match="not a faultlab results store"):
        ResultStore.open(tmp_path, exp)
    with pytest.raises(ResultsError, match="not a faultlab results store"):
        load_results(tmp_path)


def test_missing_store(tmp_path):
    with pytest.raises(ResultsError, match="no results store"):
        load_results(tmp_path / "nothing")
    with pytest.raises(ResultsError, match="no results store"):
        load_metadata(tmp_path)


def _other_process_holds(lock_file):
    """Whether another open file description (as another process has) can take the lock: False if held."""
    import fcntl
    import os
    fd = os.open(lock_file, os.O_RDWR)
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return True
    finally:
        os.close(fd)
    return False


def test_lock_excludes_a_second_writer(tmp_path):
    import fcntl
    import os
    with store_lock(tmp_path):
        assert _other_process_holds(tmp_path / ".lock")
        with store_lock(tmp_path):  # re-entrant within the process holding it
            assert _other_process_holds(tmp_path / ".lock")
        assert _other_process_holds(tmp_path / ".lock")  # the inner exit keeps it
    assert not (tmp_path / ".lock").exists()  # released: a clean exit leaves no lock file
    fd = os.open(tmp_path / ".lock", os.O_RDWR | os.O_CREAT)  # another writer holds it
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        with pytest.raises(ResultsError, match="in use"):
            with store_lock(tmp_path):
                pass
    finally:
        os.close(fd)
    with store_lock(tmp_path):
        pass
    assert not (tmp_path / ".lock").exists()


def test_a_lock_file_removed_by_its_previous_holder_is_not_taken(tmp_path, monkeypatch):
    import fcntl
    import os
    # A stale lock file (left by a killed run) is taken, then removed on a clean exit.
    (tmp_path / ".lock").touch()
    with store_lock(tmp_path):
        assert _other_process_holds(tmp_path / ".lock")
    assert not (tmp_path / ".lock").exists()
    # The race: this writer opens .lock, the previous holder removes it and exits before the flock.
    real_flock = fcntl.flock
    removed = []

    def flock_after_the_holder_left(fd, op):
        if not removed:
            removed.append(True)
            os.unlink(tmp_path / ".lock")
        return real_flock(fd, op)

    (tmp_path / ".lock").touch()
    monkeypatch.setattr(fcntl, "flock", flock_after_the_holder_left)
    with store_lock(tmp_path):
        monkeypatch.setattr(fcntl, "flock", real_flock)
        # it holds the file that now carries the name, so another writer is refused
        assert _other_process_holds(tmp_path / ".lock")
    assert removed == [True]


def test_case_path_layout(tmp_path):
    assert case_path(tmp_path, 2, "random", 3) == tmp_path / "cases" / "run2" / "random" / "case3.npz"
    assert case_path(tmp_path / "results.sqlite", 1, "fixed", 1) == tmp_path / "cases" / "run1" / "fixed" / "case1.npz"


# ---------------------------------------------------------------------- integrity
def _finished_store(tmp_path, exp, emd=1565.9):
    """A closed store of three rows; the middle one's EMD is ``emd`` (other rows' EMD: 200.0)."""
    with ResultStore.open(tmp_path, exp) as store:
        session = store.begin_session(jobs=1, backend="loky", n_todo=3)
        store.write(_row(1, "random", 1, "baseline", 0), session=session)
        row = _row(1, "random", 2, "baseline", 0)
        row["emd_mm"] = emd
        store.write(row, session=session)
        store.write(_row(1, "random", 3, "baseline", 0), session=session)
        store.end_session(session, state="complete", n_new=3, wall_time_s=1.0)
    return results_path(tmp_path)


def _overwrite(path, old: bytes, new: bytes):
    data = path.read_bytes()
    assert data.count(old) == 1, "the planted value must occur once in the file"
    path.write_bytes(data.replace(old, new))


def test_checksum_is_a_function_of_every_value_and_its_type():
    values = [None if c not in ("run", "case", "rep") else 1 for c in RESULT_COLUMNS]
    base = row_checksum(values)
    assert len(base) == 16 + 2 * len(RESULT_COLUMNS)
    for i, c in enumerate(RESULT_COLUMNS):
        for other in (2, 1.0, "1", 0.5):
            changed = list(values)
            changed[i] = other
            if changed[i] == values[i] and type(changed[i]) is type(values[i]):
                continue
            assert row_checksum(changed) != base, (c, other)


def test_overwritten_value_inside_a_page_is_refused_naming_row_and_column(tmp_path, exp):
    path = _finished_store(tmp_path, exp)
    assert not path.with_name("results.sqlite-wal").exists()  # checkpointed: the value is in the main file
    # SQLite stores a REAL as 8 big-endian bytes: overwrite the EMD 1565.9 with 2261634.5 (as in a bad sector)
    _overwrite(path, struct.pack(">d", 1565.9), struct.pack(">d", 2261634.5))
    conn = sqlite3.connect(path)
    assert conn.execute("PRAGMA integrity_check").fetchone()[0] == "ok"  # SQLite does not see it
    assert conn.execute("SELECT emd_mm FROM results WHERE \"case\" = 2").fetchone()[0] == 2261634.5
    conn.close()
    with pytest.raises(ResultsError) as err:
        load_results(tmp_path)
    msg = str(err.value)
    assert str(path) in msg and "emd_mm" in msg and "case 2" in msg and "rms_mm" not in msg


def test_overwritten_text_is_refused(tmp_path, exp):
    with ResultStore.open(tmp_path, exp) as store:
        store.write(_row(1, "random", 1, "baseline", 0))
        store.write(_row(1, "random", 1, "tests.runner.suts:BIAS", 0, status="crash"))
    _overwrite(results_path(tmp_path), b"ZeroDivisionError: boom", b"ZeroDivisionError: bang")
    with pytest.raises(ResultsError, match=r"damaged: row 2 \(run 1, suite 'random', case 1, variant "
                                           r"'tests.runner.suts:BIAS', rep 0\): column error does not match"):
        load_results(tmp_path)


def test_truncated_and_random_byte_stores_give_one_clear_error(tmp_path, exp):
    path = _finished_store(tmp_path / "t", exp)
    path.write_bytes(path.read_bytes()[:4096 + 100])
    rnd = tmp_path / "r" / "results.sqlite"
    rnd.parent.mkdir()
    rnd.write_bytes(np.random.default_rng(5).bytes(20000))
    for d in (tmp_path / "t", tmp_path / "r"):
        for read in (load_results, load_metadata, lambda d: ResultStore.open(d, exp)):
            with pytest.raises(ResultsError, match="damaged or not a faultlab results store"):
                read(d)
    assert rnd.read_bytes() == np.random.default_rng(5).bytes(20000)  # refused without writing


def test_row_without_checksum_in_a_checked_store_is_damaged(tmp_path, exp):
    path = _finished_store(tmp_path, exp)
    conn = sqlite3.connect(path)
    conn.execute("UPDATE results SET checksum = NULL WHERE \"case\" = 3")
    conn.commit()
    conn.close()
    with pytest.raises(ResultsError, match="checksum is missing or damaged"):
        load_results(tmp_path)


def test_store_from_before_checksums_reads_with_a_warning_and_resumes_checked(tmp_path, exp):
    path = _finished_store(tmp_path, exp)
    conn = sqlite3.connect(path)  # as written before checksums: no column, no meta entry
    conn.execute("ALTER TABLE results DROP COLUMN checksum")
    conn.execute("DELETE FROM meta WHERE key IN ('row_checksum', 'meta_checksum')")
    conn.commit()
    conn.close()
    with accept_unverified(), pytest.warns(UnverifiedStoreWarning, match="3 of 3 rows"):
        df = load_results(tmp_path)
    assert df["emd_mm"].tolist() == [200.0, 1565.9, 200.0]
    with accept_unverified(), ResultStore.open(tmp_path, exp) as store:  # resuming adds the column: new rows
        store.write(_row(1, "random", 4, "baseline", 0, rms=7.0))                    # are checked
    with accept_unverified(), pytest.warns(UnverifiedStoreWarning, match="3 of 4 rows"):
        assert len(load_results(tmp_path)) == 4
    conn = sqlite3.connect(path)
    conn.execute("UPDATE results SET rms_mm = 8.0 WHERE \"case\" = 4")
    conn.commit()
    conn.close()
    with pytest.raises(ResultsError, match="column rms_mm does not match"), warnings.catch_warnings(), \
            accept_unverified():
        warnings.simplefilter("ignore", UnverifiedStoreWarning)
        load_results(tmp_path)


@pytest.mark.parametrize("checksum_column", ["dropped", "nulled"])
def test_a_store_without_integrity_entries_is_refused_naming_it_and_the_option_and_nothing_is_written(
        tmp_path, exp, checksum_column):
    """Every integrity entry deleted (or never written) -- the store is refused, not read as "unverified"."""
    path = _finished_store(tmp_path, exp)
    _sql(path, "ALTER TABLE results DROP COLUMN checksum" if checksum_column == "dropped"
         else "UPDATE results SET checksum = NULL", "DELETE FROM meta WHERE key IN ('row_checksum', 'meta_checksum')")
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    opened = []
    for read in (load_results, lambda d: check_store(d, exp), lambda d: opened.append(ResultStore.open(d, exp))):
        with pytest.raises(ResultsError) as refused, warnings.catch_warnings():
            warnings.simplefilter("error", UnverifiedStoreWarning)  # no silent (or warned) downgrade either
            read(tmp_path)
        assert str(path) in str(refused.value) and "--accept-unverified" in str(refused.value)
        assert "3 of its 3 rows" in str(refused.value)
    assert not opened and {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
    with accept_unverified(), pytest.warns(UnverifiedStoreWarning):
        assert load_results(tmp_path)["emd_mm"].tolist() == [200.0, 1565.9, 200.0]
    with pytest.raises(ResultsError, match="--accept-unverified"):  # the acceptance ends with its block
        load_results(tmp_path)


def test_reading_leaves_no_files_behind(tmp_path, exp):
    _finished_store(tmp_path, exp)
    before = sorted(p.name for p in tmp_path.iterdir())
    content = results_path(tmp_path).read_bytes()
    load_results(tmp_path)
    load_metadata(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == before
    assert results_path(tmp_path).read_bytes() == content


def test_reading_while_a_writer_holds_the_store_sees_its_committed_rows(tmp_path, exp):
    with ResultStore.open(tmp_path, exp) as store, store_lock(tmp_path):
        store.write(_row(1, "random", 1, "baseline", 0))
        assert results_path(tmp_path).with_name("results.sqlite-wal").exists()  # not checkpointed yet
        assert len(load_results(tmp_path)) == 1


def test_stale_running_session_is_closed_as_killed_on_reopen(tmp_path, exp):
    with ResultStore.open(tmp_path, exp) as store:
        sid = store.begin_session(jobs=2, backend="loky", n_todo=5)
        store.write(_row(1, "random", 1, "baseline", 0), session=sid)
        store.write(_row(1, "random", 2, "baseline", 0), session=sid)
        # the process dies here (SIGKILL): the session stays 'running'
    conn = sqlite3.connect(results_path(tmp_path))
    written = conn.execute("SELECT MAX(written_unix) - MIN(s.started_unix) FROM results, sessions s").fetchone()[0]
    conn.close()
    with ResultStore.open(tmp_path, exp):
        pass
    conn = sqlite3.connect(results_path(tmp_path))
    state, n_new, wall, finished = conn.execute(
        "SELECT state, n_new, wall_time_s, finished FROM sessions WHERE id = ?", (sid,)).fetchone()
    conn.close()
    assert (state, n_new) == ("killed", 2) and finished and wall == pytest.approx(written)


def test_out_naming_a_file_is_refused(tmp_path, exp):
    f = tmp_path / "results.txt"
    f.write_text("mine")
    with pytest.raises(ResultsError, match="is a file, not a directory"):
        with store_lock(f):
            pass
    with pytest.raises(ResultsError, match="is a file, not a directory"):
        ResultStore.open(f, exp)
    assert f.read_text() == "mine"


def test_disk_full_while_writing_keeps_committed_rows_and_resumes(tmp_path, exp):
    with ResultStore.open(tmp_path, exp) as store:
        store.write(_row(1, "random", 1, "baseline", 0))
        # SQLite's own disk-full error, deterministically: the file may not grow past its current pages
        pages = store.conn.execute("PRAGMA page_count").fetchone()[0]
        store.conn.execute(f"PRAGMA max_page_count = {pages}")
        with pytest.raises(ResultsError, match="disk is full.*rows committed before are kept"):
            for c in range(2, 200):
                store.write(_row(1, "random", c, "baseline", 0, rms=float(c)))
        n_kept = len(store.done_keys())
    df = load_results(tmp_path)
    assert len(df) == n_kept >= 1 and df["rms_mm"].tolist() == [100.0] + [float(c) for c in range(2, n_kept + 1)]
    with ResultStore.open(tmp_path, exp) as store:  # space again: resume writes the rest
        store.write(_row(1, "random", n_kept + 1, "baseline", 0))
    assert len(load_results(tmp_path)) == n_kept + 1


_finite = st.floats(allow_nan=False, width=64)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(rms=st.one_of(_finite, st.just(math.nan)), emd=st.floats(width=64), runtime=_finite,
       error=st.text(max_size=40), n=st.integers(-2**62, 2**62), case=st.integers(1, 10**6))
def test_any_row_reads_back_verified_and_equal(tmp_path_factory, exp, rms, emd, runtime, error, n, case):
    out = tmp_path_factory.mktemp("h")
    row = _row(1, "random", case, "baseline", 0, rms=0.0)
    row.update(rms_mm=rms, emd_mm=emd, runtime_s=runtime, error=error, n_mapped=n)
    with ResultStore.open(out, exp) as store:
        store.write(row)
    (got,) = load_results(out).to_dict("records")  # verified: no false alarm
    for c in RESULT_COLUMNS:
        want = "" if c == "error" and not error else row.get(c, math.nan)  # a column the row lacks: NULL
        if isinstance(want, float) and math.isnan(want):
            assert math.isnan(got[c]), c
        else:
            assert got[c] == want, c


@settings(max_examples=60, deadline=None)
@given(column=st.sampled_from(RESULT_COLUMNS), value=st.one_of(st.none(), st.integers(), _finite, st.text(max_size=8)))
def test_a_changed_value_is_attributed_to_its_column(column, value):
    from faultlab.runner.store import _damaged_columns, _stored_values

    values = _stored_values(_row(1, "random", 2, "baseline", 0))
    checksum = row_checksum(values)
    i = RESULT_COLUMNS.index(column)
    changed = list(values)
    changed[i] = value
    same = type(value) is type(values[i]) and repr(value) == repr(values[i])  # -0.0 is not 0.0 to the digest
    bad = _damaged_columns(changed, checksum)
    # the 16-byte row digest always notices; the 2-byte column digest names the column (or, at a
    # 1 in 65536 collision, only the row is known to be damaged)
    assert bad == [] if same else bad in ([column], ["checksum"])


def test_store_killed_before_its_schema_was_committed_is_created_afresh(tmp_path, exp):
    path = results_path(tmp_path)
    path.write_bytes(b"")  # created, then killed before the schema transaction committed
    with ResultStore.open(tmp_path, exp) as store:
        store.write(_row(1, "random", 1, "baseline", 0))
    assert len(load_results(tmp_path)) == 1 and load_metadata(tmp_path)["experiment_hash"] == exp.hash


def test_a_column_added_to_the_table_later_keeps_older_checksums_valid(monkeypatch):
    from faultlab.runner import store as store_module

    values = store_module._stored_values(_row(1, "random", 2, "baseline", 0))
    old = row_checksum(values)
    i = RESULT_COLUMNS.index("rep") + 1  # a new column in the middle of the table, NULL in older rows
    monkeypatch.setattr(store_module, "RESULT_COLUMNS", RESULT_COLUMNS[:i] + ("repetitions_used",) + RESULT_COLUMNS[i:])
    assert store_module._damaged_columns(values[:i] + [None] + values[i:], old) == []
    assert store_module._damaged_columns(values[:i] + [10] + values[i:], old) == ["repetitions_used"]
    changed = values[:i] + [None] + values[i:]
    changed[RESULT_COLUMNS.index("emd_mm") + 1] = 1.0
    assert store_module._damaged_columns(changed, old) == ["emd_mm"]
    new = row_checksum(values[:i] + [10] + values[i:])  # rows written with the column are checked on it too
    assert store_module._damaged_columns(values[:i] + [11] + values[i:], new) == ["repetitions_used"]


def test_settle_sessions_counts_a_killed_sessions_rows_and_time_from_the_store():
    import math

    from faultlab.runner.store import settle_sessions

    study = [{"started": 100.0, "state": "complete", "n_new": 5, "wall_time_s": 20.0},
             {"started": 200.0, "state": "running", "n_new": 0, "wall_time_s": None},      # killed
             {"started": 300.0, "state": "interrupted", "n_new": 0, "wall_time_s": math.nan},  # an old file's NaN
             {"started": 400.0, "state": "complete", "n_new": 3, "wall_time_s": 9.0}]
    store = [{"started_unix": 101.0, "n_new": 5, "wall_time_s": 18.0},
             {"started_unix": 203.0, "n_new": 231, "wall_time_s": 40.0},  # the runner's session of the killed one
             {"started_unix": 305.0, "n_new": 7, "wall_time_s": 2.5},
             {"started_unix": 320.0, "n_new": 1, "wall_time_s": 1.0},     # a second runner session in its window
             {"started_unix": 401.0, "n_new": 3, "wall_time_s": 8.0}]
    got = settle_sessions(study, store)
    assert got[0] == study[0] and got[3] == study[3]  # finished sessions are left alone
    assert (got[1]["state"], got[1]["n_new"], got[1]["wall_time_s"]) == ("killed", 231, 43.0)
    assert (got[2]["state"], got[2]["n_new"], got[2]["wall_time_s"]) == ("interrupted", 8, 21.0)
    assert study[1]["state"] == "running"  # the input is not changed
    assert settle_sessions([{"started": 10.0, "state": "running"}], []) == [
        {"started": 10.0, "state": "killed", "n_new": 0, "wall_time_s": 0.0}]


def test_a_committed_store_from_before_the_ate_reads_it_as_nan_verified(tmp_path):
    import shutil
    import sqlite3
    from pathlib import Path

    from faultlab.runner.store import recorded_metrics

    src = Path(__file__).resolve().parents[2] / "reports" / "calibrate-quick" / "store" / "results.sqlite"
    shutil.copy2(src, tmp_path / "results.sqlite")
    with sqlite3.connect(tmp_path / "results.sqlite") as conn:
        assert "ate_mm" not in {r[1] for r in conn.execute("PRAGMA table_info(results)")}
    df = load_results(tmp_path)  # verified against the checksums written without the column
    assert list(df.columns) == list(RESULT_COLUMNS) and len(df) > 0 and df.ate_mm.isna().all()
    assert "ate" not in recorded_metrics(load_metadata(tmp_path))


def test_job_metrics_keep_the_stores_choice_of_the_ate():
    from faultlab.runner.store import job_metrics

    every = ("rms", "emd", "ate")
    assert job_metrics(every, {"metrics": list(every)}) == every
    assert job_metrics(every, {"metrics": ["rms", "emd"]}) == ("rms", "emd")
    assert job_metrics(every, {}) == ("rms", "emd")  # a store from before the metrics key: no ATE
    assert job_metrics(("rms",), {"metrics": list(every)}) == ("rms",)
    assert job_metrics(("emd", "rms"), {"metrics": ["rms", "ate"]}) == ("rms", "emd")


def test_write_many_stores_the_rows_write_stores_one_at_a_time_in_one_transaction(tmp_path, exp):
    rows = [_row(1, "random", 1, "baseline", rep, rms=10.0 + rep) for rep in range(4)]
    rows[2] = _row(1, "random", 1, "baseline", 2, status="crash")
    with ResultStore.open(tmp_path / "one", exp) as store:
        s = store.begin_session(jobs=1, backend="loky", n_todo=4)
        for r in rows:
            store.write(r, session=s)
    with ResultStore.open(tmp_path / "many", exp) as store:
        s = store.begin_session(jobs=1, backend="loky", n_todo=4)
        store.write_many(rows, session=s)
        assert store.conn.execute("SELECT n_new FROM sessions WHERE id = ?", (s,)).fetchone()[0] == 4
        # one more group holding a stored job is refused whole: nothing of it is written
        with pytest.raises(ResultsError, match="already stored"):
            store.write_many([_row(1, "random", 2, "baseline", 0), rows[1]], session=s)
        assert store.conn.execute("SELECT n_new FROM sessions WHERE id = ?", (s,)).fetchone()[0] == 4
    one, many = load_results(tmp_path / "one"), load_results(tmp_path / "many")  # checksums verified
    pd.testing.assert_frame_equal(one, many)
    assert len(many) == 4 and many.status.tolist() == ["ok", "ok", "crash", "ok"]


def _sql(path, *statements):
    conn = sqlite3.connect(path)
    for st in statements:
        conn.execute(st)
    conn.commit()
    conn.close()


@pytest.mark.parametrize("key, value", [("root_seed", "12"), ("experiment_hash", '"0123"'),
                                        ("detection", '{"rule": "none"}')])
def test_changed_metadata_is_refused_by_every_reader_and_the_writer(tmp_path, exp, key, value):
    path = _finished_store(tmp_path, exp)
    _sql(path, f"UPDATE meta SET value = '{value}' WHERE key = '{key}'")
    for read in (load_results, load_metadata, lambda d: ResultStore.open(d, exp)):
        with pytest.raises(ResultsError, match="its metadata .* does not match its checksum"):
            read(tmp_path)


def test_a_checked_store_cannot_be_downgraded_to_unverified_by_removing_its_checksums(tmp_path, exp):
    path = _finished_store(tmp_path, exp)
    _sql(path, "UPDATE results SET checksum = NULL, rms_mm = 1.0", "DELETE FROM meta WHERE key = 'row_checksum'")
    with pytest.raises(ResultsError, match="metadata .* does not match its checksum"):
        load_results(tmp_path)


def test_resuming_verifies_the_rows_it_counts_as_done(tmp_path, exp):
    path = _finished_store(tmp_path, exp)
    _sql(path, "UPDATE results SET rms_mm = rms_mm + 1 WHERE \"case\" = 2")
    with ResultStore.open(tmp_path, exp) as store:
        with pytest.raises(ResultsError, match=r"case 2.*column rms_mm does not match its checksum"):
            store.done_keys()


def test_metadata_set_while_resuming_keeps_the_checksum_valid(tmp_path, exp):
    _finished_store(tmp_path, exp)
    with ResultStore.open(tmp_path, exp) as store:
        store.set_meta("skipped_variants", [{"fault": "x", "reason": "y"}])
    assert load_metadata(tmp_path)["skipped_variants"] == [{"fault": "x", "reason": "y"}]
    assert len(load_results(tmp_path)) == 3
