import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from faultlab.cli import main
from faultlab.runner import load_metadata, load_results, run_experiment
from tests.runner.suts import write_experiment

ROOT = Path(__file__).resolve().parents[2]
SUTS = "tests.runner.suts"


def _count_rows(db: Path) -> int:
    if not db.exists():
        return 0
    conn = sqlite3.connect(db, timeout=5.0)
    try:
        return conn.execute("SELECT COUNT(*) FROM results").fetchone()[0]
    except sqlite3.OperationalError:  # table not created yet
        return 0
    finally:
        conn.close()


def test_run_prints_location_and_summary(tmp_path, capsys):
    exp = write_experiment(tmp_path / "e.toml", runs=1)
    out = tmp_path / "out"
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 0
    text = capsys.readouterr().out
    assert f"results: {out / 'results.sqlite'}" in text
    assert "12 jobs: 12 ok, 0 crash, 0 timeout (12 run now, 0 already done); wall time" in text
    assert len(load_results(out)) == 12
    # rerun: nothing left to do
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 0
    assert "(0 run now, 12 already done)" in capsys.readouterr().out


def test_run_refuses_malformed_and_changed_files(tmp_path, capsys):
    bad = write_experiment(tmp_path / "bad.toml", variants=["baseline", "no_such_fault"])
    assert main(["run", str(bad), "--out", str(tmp_path / "bad_out"), "--no-progress"]) == 2  # an unknown name
    err = capsys.readouterr().err
    assert "faultlab: error:" in err and "variants[1] = 'no_such_fault'" in err
    assert not (tmp_path / "bad_out").exists()

    exp = write_experiment(tmp_path / "e.toml", runs=1, suites={"fixed": 1})
    out = tmp_path / "out"
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 0
    write_experiment(exp, runs=1, suites={"fixed": 1}, seed=12)
    capsys.readouterr()
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 1
    err = capsys.readouterr().err
    assert "different experiment" in err and "changed: seed" in err and "--force-new" in err
    assert load_metadata(out)["root_seed"] == 11
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress", "--force-new"]) == 0
    assert load_metadata(out)["root_seed"] == 12
    assert len(list(out.glob("previous-*"))) == 1


@pytest.mark.slow
def test_kill_and_resume(tmp_path):
    """SIGKILL a running campaign, resume it: every job exactly once, finished rows unchanged."""
    exp = write_experiment(tmp_path / "e.toml", runs=1, repetitions=3, n_steps=40,
                           slam={"name": f"{SUTS}:make_tiny", "options": {"noise": 0.02, "delay": 0.005}})
    out = tmp_path / "out"
    db = out / "results.sqlite"
    total = 3 * 2 * 3
    proc = subprocess.Popen([sys.executable, "-m", "faultlab", "run", str(exp), "--out", str(out), "--jobs", "2",
                             "--no-progress"], cwd=ROOT, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 120
        while _count_rows(db) < 2 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)  # the run and its worker processes
        proc.wait(timeout=60)
    assert proc.returncode == -signal.SIGKILL, proc.stderr.read().decode()
    before = load_results(out)
    assert 2 <= len(before) < total  # killed mid-run
    assert load_metadata(out)["sessions"][0]["state"] == "killed"

    summary = run_experiment(exp, out, jobs=2, progress=False)
    after = load_results(out)
    assert summary.n_skipped == len(before) and summary.n_new == total - len(before)
    assert len(after) == total
    assert not after.duplicated(["run", "suite", "case", "variant", "rep"]).any()
    assert (after.status == "ok").all()
    # rows finished before the kill are byte-for-byte the same (runtime included)
    merged = before.merge(after, on=["run", "suite", "case", "variant", "rep"], suffixes=("", "_after"),
                          validate="one_to_one")
    assert len(merged) == len(before)
    for col in before.columns.drop(["run", "suite", "case", "variant", "rep"]):
        pd.testing.assert_series_equal(merged[col], merged[f"{col}_after"], check_names=False)


def test_bad_options(tmp_path, capsys):
    exp = write_experiment(tmp_path / "e.toml")
    assert main(["run", str(exp), "--out", str(tmp_path / "out"), "--no-progress", "--jobs", "0"]) == 1
    assert "jobs must be an integer >= 1" in capsys.readouterr().err
    with pytest.raises(SystemExit):  # argparse rejects an unknown backend
        main(["run", str(exp), "--out", str(tmp_path / "out"), "--backend", "spark"])
    assert not (tmp_path / "out").exists()


def test_run_adaptive_option_sets_the_stages(tmp_path, capsys):
    # K = 4 in stages 2 + 2 on the tiny SUT: the option sets the experiment's [adaptive] stages, the
    # store holds what the stages needed, and an unusable value is refused before anything is written
    exp = write_experiment(tmp_path / "e.toml", runs=1, repetitions=4)
    out = tmp_path / "out"
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress", "--adaptive", "2,4"]) == 0
    meta = load_metadata(out)
    assert meta["experiment"]["adaptive"]["stages"] == [2, 4]
    stops = meta.get("adaptive_stops", [])
    df = load_results(out)
    used = df[df["variant"] != "baseline"].groupby(["suite", "case", "variant"]).size()
    assert sorted(used.unique()) == sorted({2 for _ in stops} | ({4} if len(stops) < len(used) else set()))
    assert len(stops) == int((used == 2).sum())
    assert main(["run", str(exp), "--out", str(tmp_path / "bad"), "--no-progress", "--adaptive", "2,5"]) == 1
    assert "must equal repetitions" in capsys.readouterr().err
    assert not (tmp_path / "bad").exists()


def test_run_metrics_option_records_only_those(tmp_path, capsys):
    exp = write_experiment(tmp_path / "e.toml", runs=1, suites={"random": 1}, repetitions=1)
    out = tmp_path / "out"
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress", "--metrics", "rms"]) == 0
    df = load_results(out)
    assert load_metadata(out)["metrics"] == ["rms"]
    assert df["emd_mm"].isna().all() and df["rms_mm"].notna().all()
    capsys.readouterr()
    assert main(["run", str(exp), "--out", str(tmp_path / "bad"), "--no-progress", "--metrics", "rms,mae"]) == 1
    err = capsys.readouterr().err
    assert "metrics unknown metric 'mae'" in err and "Traceback" not in err
    assert not (tmp_path / "bad").exists()  # a refused command writes nothing


@pytest.mark.slow
def test_sigterm_stops_like_ctrl_c_marks_the_session_and_the_run_resumes_to_the_uninterrupted_table(tmp_path):
    exp = write_experiment(tmp_path / "e.toml", runs=1, repetitions=3, n_steps=40,
                           slam={"name": f"{SUTS}:make_tiny", "options": {"noise": 0.02, "delay": 0.005}})
    out = tmp_path / "out"
    total = 3 * 2 * 3
    proc = subprocess.Popen([sys.executable, "-m", "faultlab", "run", str(exp), "--out", str(out), "--jobs", "2",
                             "--no-progress"], cwd=ROOT, start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 120
        while _count_rows(out / "results.sqlite") < 2 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.02)
        proc.send_signal(signal.SIGTERM)  # the command alone, as timeout(1) or kill(1) send it
        proc.wait(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    err = proc.stderr.read().decode()
    assert proc.returncode == 143, err
    assert err.strip().splitlines() == ["faultlab: terminated (SIGTERM); finished results are saved: rerun the same "
                                        "command to resume"]
    before = load_results(out)
    assert 2 <= len(before) < total
    assert load_metadata(out)["sessions"][0]["state"] == "interrupted"
    run_experiment(exp, out, jobs=2, progress=False)
    run_experiment(exp, tmp_path / "clean", jobs=2, progress=False)
    keys = ["run", "suite", "case", "variant", "rep"]
    resumed, clean = (load_results(p).sort_values(keys).reset_index(drop=True).drop(columns=["runtime_s"])
                      for p in (out, tmp_path / "clean"))
    pd.testing.assert_frame_equal(resumed, clean, check_exact=True)


@pytest.mark.parametrize("command", [["run", "{f}", "--out", "{o}"], ["generate", "--space", "{f}", "--out", "{o}"],
                                     ["study", "run", "{f}", "--out", "{o}"], ["effects", "run", "{f}", "--out", "{o}"]])
def test_a_toml_file_that_is_not_utf8_is_one_error_line_naming_it(tmp_path, capsys, command):
    bad = tmp_path / "bad.toml"
    bad.write_bytes(b"seed = 1\n# \xff\xfe not UTF-8\n")
    out = tmp_path / "out"
    argv = [a.format(f=bad, o=out) for a in command]
    assert main(argv) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"faultlab: error: {bad}") and "not UTF-8" in err[0], err
    assert not out.exists()


def test_a_saved_case_with_a_nan_landmark_stops_run_and_export_with_one_line_naming_it(tmp_path, capsys):
    import dataclasses

    import numpy as np

    from faultlab.scenario import load_scenario, save_scenario

    exp = write_experiment(tmp_path / "e.toml", runs=1, suites={"random": 1}, repetitions=1)
    out = tmp_path / "out"
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 0
    case = sorted((out / "cases").rglob("*.npz"))[0]
    sc = load_scenario(case)
    landmarks = sc.landmarks.copy()
    landmarks[0, 1] = np.nan
    save_scenario(dataclasses.replace(sc, landmarks=landmarks), case)  # checksums valid, content not
    rows = load_results(out)
    capsys.readouterr()
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(case) in err[0] and "landmarks holds 1 non-finite value(s)" in err[0], err
    pd.testing.assert_frame_equal(load_results(out), rows)
    assert main(["export", "--format", "tum", "--out", str(tmp_path / "exported"), str(case)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and str(case) in err[0] and "non-finite" in err[0], err
    assert not (tmp_path / "exported").exists()


def test_an_old_store_holding_crash_rows_of_a_non_finite_case_reports_the_case_invalid_naming_it(tmp_path, capsys):
    """A store written before cases were checked on load: the case's jobs were stored as crashes."""
    import dataclasses
    import sqlite3

    import numpy as np

    from faultlab.errors import ResultsError
    from faultlab.runner.store import RESULT_COLUMNS, row_checksum
    from faultlab.scenario import load_scenario, save_scenario

    exp = write_experiment(tmp_path / "e.toml", runs=1, suites={"random": 2}, repetitions=1)
    out = tmp_path / "out"
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 0
    case = out / "cases" / "run1" / "random" / "case2.npz"
    sc = load_scenario(case)
    landmarks = sc.landmarks.copy()
    landmarks[1, 0] = np.inf
    save_scenario(dataclasses.replace(sc, landmarks=landmarks), case)  # checksums valid, content not
    with sqlite3.connect(out / "results.sqlite") as conn:  # what the SLAM made of it then, sealed by the writer
        conn.execute("UPDATE results SET status = 'crash', error = 'SlamOutputError: estimate is not finite', "
                     "rms_mm = NULL, emd_mm = NULL, ate_mm = NULL, n_mapped = 0, n_unmapped = 0 WHERE \"case\" = 2")
        cols = ", ".join(f'"{c}"' for c in RESULT_COLUMNS)
        for rowid, *values in conn.execute(f"SELECT rowid, {cols} FROM results").fetchall():
            conn.execute("UPDATE results SET checksum = ? WHERE rowid = ?", (row_checksum(values), rowid))
    capsys.readouterr()
    assert main(["report", str(out), "--reports", str(tmp_path / "rep")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith(f"faultlab: error: case invalid: {case}:"), err
    assert "landmarks holds 1 non-finite value(s)" in err[0] and "baseline failed" not in err[0], err
    assert not (tmp_path / "rep").exists() or not any((tmp_path / "rep").iterdir())
    with pytest.raises(ResultsError, match=f"case invalid: {case}: the 2 rows"):  # baseline and BIAS
        load_results(out)
    save_scenario(sc, case)  # the case valid again: the crash rows are the SLAM's, read as they are
    assert (load_results(out).query("case == 2").status == "crash").all()


def _one_error_line(capsys) -> str:
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("faultlab: error: "), err
    return err[0]


@pytest.mark.parametrize("slam, expected", [
    ({"name": "process", "command": ["/no/such/slam-program", "--fast"]},
     "[slam] command: the program '/no/such/slam-program' cannot be started: no executable file"),
    ({"name": "process", "command": ["no-such-slam-program-on-path"]},
     "the program 'no-such-slam-program-on-path' cannot be started: not found on PATH"),
    ({"name": "fastslam", "particles": 10 ** 12}, "[slam] particles = 1000000000000 needs at least"),
])
def test_a_slam_that_cannot_start_or_fit_in_memory_is_refused_before_the_campaign_writing_nothing(
        tmp_path, capsys, slam, expected):
    exp = write_experiment(tmp_path / "e.toml", runs=1, suites={"random": 1}, repetitions=1, slam=slam)
    out = tmp_path / "out"
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 1
    line = _one_error_line(capsys)
    assert str(exp) in line and expected in line, line
    assert not out.exists()


def test_a_zero_byte_store_next_to_saved_cases_is_refused_and_left_as_it_is(tmp_path, capsys):
    exp = write_experiment(tmp_path / "e.toml", runs=1, suites={"random": 1}, repetitions=1)
    out = tmp_path / "out"
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 0
    (out / "results.sqlite").write_bytes(b"")  # truncated: every row lost
    capsys.readouterr()
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 1
    line = _one_error_line(capsys)
    assert f"{out / 'results.sqlite'} is empty (0 bytes)" in line and "--force-new" in line
    assert (out / "results.sqlite").stat().st_size == 0
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress", "--force-new"]) == 0
    assert len(load_results(out)) == 2


def test_a_run_refused_for_another_experiments_store_does_not_create_the_lock_file(tmp_path, capsys):
    exp = write_experiment(tmp_path / "e.toml", runs=1, suites={"random": 1}, repetitions=1)
    out = tmp_path / "out"
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 0
    assert not (out / ".lock").exists()  # a clean exit removes it
    before = sorted(p.relative_to(out) for p in out.rglob("*"))
    write_experiment(exp, runs=1, suites={"random": 1}, repetitions=1, seed=99)
    capsys.readouterr()
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 1
    assert "different experiment" in _one_error_line(capsys)
    assert sorted(p.relative_to(out) for p in out.rglob("*")) == before
