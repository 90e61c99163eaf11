"""``faultlab study run|report`` on a tiny pool: files, resume, and the report recomputed from the matrix."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.stats import hypergeom

from faultlab.cli import main

TINY = """
seed = 5
runs = 1
n_steps = 10
repetitions = 6
timeout_s = 60.0
variants = ["baseline", "motion_sign_error", "weight_overwritten"]
[suites]
systematic = 5
random = 3
[slam]
name = "fastslam"
particles = 3
[space.inactivity]
classes = { none = [0], inactive = [5] }
[space.map_size]
classes = { small = [4, 5], medium = [5, 6], large = [6, 7] }
[space.landmark_density]
classes = { low = [1, 1.5], medium = [1.5, 2], high = [2, 3] }
[mutation]
ids = ["motion_model:arithmetic:1"]
[study]
sizes = [1, 2]
draws = 300
bootstrap = 100
seed = 1
"""


@pytest.mark.slow
def test_study_run_and_report_on_a_tiny_pool(tmp_path, capsys):
    exp = tmp_path / "tiny.toml"
    exp.write_text(TINY)
    out, rep = tmp_path / "out", tmp_path / "rep"
    args = ["study", "run", str(exp), "--out", str(out), "--jobs", "1", "--backend", "threading", "--no-progress"]
    assert main(args) == 0
    assert "192 jobs" in capsys.readouterr().out          # 8 cases x (baseline, 2 faults, 1 mutant) x K = 6
    assert main(args) == 0                                                            # resumes: nothing to run
    assert "0 run now, 192 already done" in capsys.readouterr().out
    assert main(["study", "report", str(out), "--reports", str(rep)]) == 0
    for name in ("kill_matrix.csv", "detection.csv", "scores.csv", "comparisons.csv", "power.csv", "study.md",
                 "detection_vs_size.png", "study_meta.json"):
        assert (rep / name).stat().st_size > 0, name

    km = pd.read_csv(rep / "kill_matrix.csv")
    det = pd.read_csv(rep / "detection.csv")
    assert len(km) == 8 * 3 and set(km["variant"]) == {"motion_sign_error", "weight_overwritten",
                                                       "mutant:motion_model:arithmetic:1"}
    # every exact rate recomputed from the matrix: strong cases = crash or p <= 0.05 / n, then hypergeometric
    for _, r in det.iterrows():
        pool = km[(km["strategy"] == r["strategy"]) & (km["variant"] == r["variant"])]
        strong = int((pool["crash"] | (pool["p"].fillna(1.0) <= 0.05 / r["size"])).sum())
        assert r["strong_cases"] == strong and r["pool"] == len(pool)
        assert r["rate_exact"] == pytest.approx(1 - hypergeom.pmf(0, len(pool), strong, r["size"]))
        assert abs(r["rate"] - r["rate_exact"]) <= 5 * np.sqrt(0.25 / r["draws"])
        assert 0 <= r["ci_low"] <= r["ci_high"] <= 1
    md = (rep / "study.md").read_text()
    assert "## Power" in md and "bootstrap" in md

    # the report is a pure function of the store: the same tables again
    rep2 = tmp_path / "rep2"
    assert main(["study", "report", str(out), "--reports", str(rep2)]) == 0
    for name in ("kill_matrix.csv", "detection.csv", "scores.csv", "comparisons.csv"):
        assert (rep / name).read_bytes() == (rep2 / name).read_bytes(), name


def test_study_run_refuses_too_few_repetitions_for_the_largest_size(tmp_path, capsys):
    exp = tmp_path / "tiny.toml"
    exp.write_text(TINY.replace("sizes = [1, 2]", "sizes = [1, 2, 3]").replace("repetitions = 6", "repetitions = 5"))
    assert main(["study", "run", str(exp), "--out", str(tmp_path / "o")]) == 1
    err = capsys.readouterr().err
    assert "repetitions = 5 is too few" in err and "K = 6" in err
    assert not (tmp_path / "o").exists()


SMALL = """
seed = 5
runs = 1
n_steps = 60
repetitions = 6
timeout_s = 60.0
variants = ["baseline", "motion_sign_error"]
[suites]
random = 3
fixed = 1
[slam]
name = "fastslam"
particles = 20
[space.inactivity]
classes = { none = [0], inactive = [5] }
[space.map_size]
classes = { small = [4, 5], medium = [5, 6], large = [6, 7] }
[space.landmark_density]
classes = { low = [1, 1.5], medium = [1.5, 2], high = [2, 3] }
[mutation]
ids = ["motion_model:arithmetic:1"]
[study]
sizes = [1]
draws = 100
bootstrap = 50
seed = 1
"""
TABLES = ("kill_matrix.csv", "detection.csv", "scores.csv", "comparisons.csv", "power.csv")


def _rows(db) -> int:
    import sqlite3
    try:
        conn = sqlite3.connect(f"file:{db}?mode=ro", uri=True, timeout=5.0)
        try:
            return conn.execute("SELECT COUNT(*) FROM results").fetchone()[0]
        finally:
            conn.close()
    except sqlite3.Error:
        return 0


@pytest.mark.slow
def test_killed_then_resumed_study_reports_as_the_uninterrupted_one(tmp_path, capsys):
    import json
    import math
    import os
    import signal
    import subprocess
    import sys
    import time
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    exp = tmp_path / "small.toml"
    exp.write_text(SMALL)
    ref, out = tmp_path / "ref", tmp_path / "out"
    args = ["--jobs", "2", "--no-progress"]
    assert main(["study", "run", str(exp), "--out", str(ref), *args]) == 0
    proc = subprocess.Popen([sys.executable, "-m", "faultlab", "study", "run", str(exp), "--out", str(out), *args],
                            cwd=root, env=dict(os.environ, PYTHONPATH=str(root)), start_new_session=True,
                            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.monotonic() + 300
        while _rows(out / "results.sqlite") < 1 and proc.poll() is None and time.monotonic() < deadline:
            time.sleep(0.01)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
        proc.wait(timeout=60)
    assert proc.returncode == -signal.SIGKILL
    committed = _rows(out / "results.sqlite")
    assert 1 <= committed < 72  # killed mid-run
    (killed,) = json.loads((out / "study.json").read_text())["sessions"]
    assert killed["state"] == "running"  # as the killed process left it
    # a killed study is reported before resuming (its session settled from the store), or, when too few rows
    # are stored for a kill matrix, refused with one clear error
    capsys.readouterr()
    code = main(["study", "report", str(out), "--reports", str(tmp_path / "rep-killed")])
    err = capsys.readouterr().err
    assert code == 0 or (code == 1 and err.startswith("faultlab: error: ") and err.count("\n") == 1), err
    assert main(["study", "run", str(exp), "--out", str(out), *args]) == 0
    assert f"({72 - committed} run now, {committed} already done)" in capsys.readouterr().out
    text = (out / "study.json").read_text()
    assert "NaN" not in text
    first, second = json.loads(text)["sessions"]
    assert first["state"] == "killed" and first["n_new"] == committed and math.isfinite(first["wall_time_s"])
    assert second["state"] == "complete" and second["n_new"] == 72 - committed
    for name, d in (("ref", ref), ("out", out)):
        assert main(["study", "report", str(d), "--reports", str(tmp_path / f"rep-{name}")]) == 0
    for t in TABLES:
        assert (tmp_path / "rep-out" / t).read_bytes() == (tmp_path / "rep-ref" / t).read_bytes(), t
    md = (tmp_path / "rep-out" / "study.md").read_text()
    assert "2 session(s)" in md and "nan" not in md.lower()
