import math
import sqlite3

import numpy as np
import pytest

from faultlab.errors import ResultsError
from faultlab.runner.experiment import parse_experiment
from faultlab.runner.store import (
    RESULT_COLUMNS,
    ResultStore,
    case_path,
    load_metadata,
    load_results,
    results_path,
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
    changed = exp.replace(repetitions=3, slam={"options": {"noise": 0.5}})
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
    assert not _other_process_holds(tmp_path / ".lock")  # released
    fd = os.open(tmp_path / ".lock", os.O_RDWR)  # another writer holds it
    try:
        fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        with pytest.raises(ResultsError, match="in use"):
            with store_lock(tmp_path):
                pass
    finally:
        os.close(fd)
    with store_lock(tmp_path):
        pass


def test_case_path_layout(tmp_path):
    assert case_path(tmp_path, 2, "random", 3) == tmp_path / "cases" / "run2" / "random" / "case3.npz"
    assert case_path(tmp_path / "results.sqlite", 1, "fixed", 1) == tmp_path / "cases" / "run1" / "fixed" / "case1.npz"
