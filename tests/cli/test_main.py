"""One clear error, never a traceback: what ``faultlab.cli.main`` does with damaged files, full disks and pipes."""

import os
import shutil
import struct
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from faultlab.cli import main
from faultlab.runner import load_metadata, load_results, run_experiment
from tests.runner.suts import write_experiment

ROOT = Path(__file__).resolve().parents[2]
KEYS = ["run", "suite", "case", "variant", "rep"]


def _files(d: Path) -> dict:
    """Every file under ``d`` with its bytes (the lock file's content is empty either way)."""
    return {p.relative_to(d): p.read_bytes() for p in sorted(d.rglob("*")) if p.is_file()}


def _one_error(err: str, *needles: str) -> None:
    assert err.startswith("faultlab: error: ") and err.count("\n") == 1 and "Traceback" not in err, err
    for n in needles:
        assert n in err, (n, err)


@pytest.fixture(scope="module")
def finished(tmp_path_factory):
    """A finished tiny campaign (12 jobs) and its experiment file."""
    d = tmp_path_factory.mktemp("finished")
    exp = write_experiment(d / "e.toml", runs=1)
    run_experiment(exp, d / "out", jobs=1, progress=False)
    return exp, d / "out"


@pytest.mark.parametrize("verb", [["faults"], ["slams"], ["mutate", "list"]])
def test_listing_into_a_closed_pipe_ends_quietly(verb):
    r, w = os.pipe()
    os.close(r)  # the reader is gone before the first line, as `| head -0`
    try:
        done = subprocess.run([sys.executable, "-m", "faultlab", *verb], stdout=w, stderr=subprocess.PIPE,
                              text=True, cwd=ROOT, env=dict(os.environ, PYTHONPATH=str(ROOT)), timeout=120)
    finally:
        os.close(w)
    assert done.returncode == 141 and done.stderr == "", done.stderr  # as a process killed by SIGPIPE


def test_run_out_naming_a_file_is_refused(tmp_path, capsys):
    exp = write_experiment(tmp_path / "e.toml", runs=1)
    out = tmp_path / "notes.txt"
    out.write_text("mine")
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 1
    _one_error(capsys.readouterr().err, str(out), "is a file, not a directory")
    assert out.read_text() == "mine" and sorted(p.name for p in tmp_path.iterdir()) == ["e.toml", "notes.txt"]


@pytest.mark.parametrize("damage", ["random", "truncated", "foreign"])
def test_run_and_report_refuse_a_damaged_store_without_writing(finished, tmp_path, capsys, damage):
    exp, src = finished
    out = tmp_path / "out"
    shutil.copytree(src, out)
    db = out / "results.sqlite"
    if damage == "random":
        db.write_bytes(np.random.default_rng(3).bytes(db.stat().st_size))
    elif damage == "truncated":
        db.write_bytes(db.read_bytes()[:5000])
    else:
        db.write_bytes(b"SQLite format 3\0" + bytes(84) + b"not really")
    before = _files(out)
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 1
    _one_error(capsys.readouterr().err, str(db))
    assert main(["report", str(out), "--reports", str(tmp_path / "rep")]) == 1
    _one_error(capsys.readouterr().err, str(db))
    assert _files(out) == before
    assert not (tmp_path / "rep").exists() or not any((tmp_path / "rep").iterdir())


def test_a_store_stripped_of_its_integrity_entries_is_refused_unless_the_option_accepts_it(finished, tmp_path,
                                                                                           capsys):
    import sqlite3

    exp, src = finished
    out = tmp_path / "out"
    shutil.copytree(src, out)
    db = out / "results.sqlite"
    conn = sqlite3.connect(db)  # every integrity entry deleted: as a store from before checksums
    conn.execute("UPDATE results SET checksum = NULL")
    conn.execute("DELETE FROM meta WHERE key IN ('row_checksum', 'meta_checksum')")
    conn.commit()
    conn.close()
    before = _files(out)
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 1
    _one_error(capsys.readouterr().err, str(db), "no row checksums", "--accept-unverified")
    assert main(["report", str(out), "--reports", str(tmp_path / "rep")]) == 1
    _one_error(capsys.readouterr().err, str(db), "no row checksums", "--accept-unverified")
    assert _files(out) == before
    assert not (tmp_path / "rep").exists() or not any((tmp_path / "rep").iterdir())
    with pytest.warns(UserWarning, match="12 of 12 rows .* without verification"):  # accepted, and said so
        assert main(["--accept-unverified", "run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 0
    from faultlab.errors import ResultsError
    from faultlab.runner.store import accept_unverified

    with pytest.raises(ResultsError, match="--accept-unverified"):  # accepting once does not seal it
        load_results(out)
    with accept_unverified():  # (the note was given once in this process, by the run above)
        assert len(load_results(out)) == 12


def test_report_refuses_a_store_with_an_overwritten_value(finished, tmp_path, capsys):
    _, src = finished
    out = tmp_path / "out"
    shutil.copytree(src, out)
    db = out / "results.sqlite"
    df = load_results(out)
    emd = df.loc[df["status"] == "ok", "emd_mm"].iloc[3]
    data = db.read_bytes()
    assert data.count(struct.pack(">d", emd)) == 1
    db.write_bytes(data.replace(struct.pack(">d", emd), struct.pack(">d", emd * 1444.0)))
    assert main(["report", str(out), "--reports", str(tmp_path / "rep")]) == 1
    _one_error(capsys.readouterr().err, str(db), "emd_mm does not match its checksum")
    assert not (tmp_path / "rep").exists() or not any((tmp_path / "rep").iterdir())


def test_truncated_case_is_regenerated_from_its_seed(finished, tmp_path, capsys):
    exp, src = finished
    out = tmp_path / "out"
    shutil.copytree(src, out)
    case = next(out.glob("cases/run1/random/case1.npz"))
    original = case.read_bytes()
    case.write_bytes(original[:1000])
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 0
    assert "(0 run now, 12 already done)" in capsys.readouterr().out
    assert case.read_bytes() == original


@pytest.mark.parametrize("room_kib, stage", [(32, "cases"), (160, "rows")])
def test_disk_full_keeps_finished_rows_and_resumes(finished, tmpfs, capsys, room_kib, stage):
    """A real full file system (a 4 MiB tmpfs nearly filled): while saving the cases, or mid-run."""
    exp, reference = finished
    pages = sum(-(-p.stat().st_size // 4096) * 4096 for p in (reference / "cases").rglob("*") if p.is_file())
    fs = tmpfs("4m")
    with open(fs / "filler", "wb", buffering=0) as f:  # room for the cases (tmpfs counts whole pages) and some
        f.write(bytes(4 * 2**20 - pages - room_kib * 2**10))
    out = fs / "out"
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 1
    err = capsys.readouterr().err
    _one_error(err, "disk is full", "test case" if stage == "cases" else "rows committed before are kept")
    partial = load_results(out)  # every committed row intact: checksums verify
    assert (len(partial) == 0) if stage == "cases" else (0 < len(partial) < 12)
    assert not list(out.rglob("*.tmp*"))  # no half-written case
    (fs / "filler").unlink()  # space again: the same command resumes
    assert main(["run", str(exp), "--out", str(out), "--jobs", "1", "--no-progress"]) == 0
    assert f"({12 - len(partial)} run now, {len(partial)} already done)" in capsys.readouterr().out
    sessions = load_metadata(out)["sessions"]
    assert sessions[-1]["state"] == "complete" and all(s["state"] != "running" for s in sessions)
    got, want = load_results(out), load_results(reference)
    pd.testing.assert_frame_equal(got.drop(columns="runtime_s"), want.drop(columns="runtime_s"))
    for p in (reference / "cases").rglob("*.npz"):  # the cases are the reference's, byte for byte
        assert (out / p.relative_to(reference)).read_bytes() == p.read_bytes()


MUTATION = """
seed = 3
runs = 1
n_steps = 30
repetitions = 7   # two-sided: 2^-(K-1) <= 0.05 / 2 cases
timeout_s = 60.0
[suites]
random = 2
fixed = 1
[slam]
name = "fastslam"
particles = 5
[mutation]
ids = ["motion_model:arithmetic:9"]
"""


@pytest.mark.slow
def test_a_refused_run_of_any_verb_leaves_every_file_byte_identical(finished, tmp_path, capsys):
    from tests.cli.test_study import SMALL

    exp, src = finished
    changed_run = tmp_path / "run-changed.toml"
    write_experiment(changed_run, runs=1, seed=12)
    runs = {"run": (src, None, [changed_run], ["run"]),
            "mutate": (None, MUTATION, [MUTATION.replace("seed = 3", "seed = 4"),
                                        MUTATION.replace("[mutation]", "[mutation]\nalpha = 0.1")], ["mutate", "run"]),
            "study": (None, SMALL, [SMALL.replace('"baseline", "motion_sign_error"', '"baseline"')], ["study", "run"])}
    for verb, (done, text, changes, command) in runs.items():
        out = tmp_path / verb
        if done is not None:
            shutil.copytree(done, out)
        else:
            (tmp_path / f"{verb}.toml").write_text(text)
            assert main([*command, str(tmp_path / f"{verb}.toml"), "--out", str(out), "--jobs", "1",
                         "--backend", "threading", "--no-progress"]) == 0
        before = _files(out)
        for i, changed in enumerate(changes):
            if isinstance(changed, str):
                (tmp_path / f"{verb}-changed{i}.toml").write_text(changed)
                changed = tmp_path / f"{verb}-changed{i}.toml"
            assert main([*command, str(changed), "--out", str(out), "--jobs", "1", "--no-progress"]) == 1
            _one_error(capsys.readouterr().err, "changed:")
            assert _files(out) == before, (verb, i)


def test_help_and_version_import_none_of_the_libraries_behind_the_commands():
    # a fresh interpreter: what `faultlab --help` loads (its CPU time is measured in benchmarks/bench_startup.py)
    code = ("import sys, contextlib, io\n"
            "from faultlab.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()) as out:\n"
            "    assert main(['--version']) == 0\n"
            "    try:\n"
            "        main(['--help'])\n"
            "    except SystemExit:\n"
            "        pass\n"
            "assert 'COMMAND' in out.getvalue() and 'faultlab ' in out.getvalue()\n"
            "print(sorted(m for m in ('numpy', 'pandas', 'scipy', 'numba', 'matplotlib', 'statsmodels') "
            "if m in sys.modules))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True, cwd=ROOT)
    assert done.stdout.strip() == "[]"


def test_a_command_help_still_names_the_defaults_and_choices_it_reads_lazily(capsys):
    from faultlab.metamorphic import DEFAULT_FACTOR
    from faultlab.space.registry import suite_kinds

    for argv, needles in ((["generate", "--help"], suite_kinds()),
                          (["metamorphic", "--help"], [f"(default {DEFAULT_FACTOR:g})"])):
        with pytest.raises(SystemExit):
            main(argv)
        out = " ".join(capsys.readouterr().out.split()).replace("- ", "-")  # argparse wraps after a hyphen
        assert all(n in out for n in needles), (argv, out)
    with pytest.raises(SystemExit):
        main(["generate", "--suite", "no-such-kind", "--out", "x"])
    assert "invalid choice: 'no-such-kind'" in capsys.readouterr().err


def test_disk_full_while_writing_a_report_is_one_line_naming_where_and_leaves_no_partial_file(finished, tmpfs,
                                                                                              capsys):
    _, out = finished
    fs = tmpfs("1m")
    with open(fs / "filler", "wb", buffering=0) as f:  # room for the tables, not for the figures and the PDF
        f.write(bytes(2**20 - 96 * 2**10))
    reports = fs / "reports"
    assert main(["report", str(out), "--reports", str(reports)]) == 1
    err = capsys.readouterr().err
    _one_error(err, "the disk is full", str(reports))
    assert not list(reports.rglob("*.partial"))
