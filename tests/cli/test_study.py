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
repetitions = 7
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
    assert "224 jobs" in capsys.readouterr().out          # 8 cases x (baseline, 2 faults, 1 mutant) x K = 7
    assert main(args) == 0                                                            # resumes: nothing to run
    assert "0 run now, 224 already done" in capsys.readouterr().out
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
    # a saved report is evaluated again from its kill matrix alone (no store): the same tables
    rep3 = tmp_path / "rep3"
    assert main(["study", "report", str(rep), "--reports", str(rep3)]) == 0
    for name in ("kill_matrix.csv", "detection.csv", "scores.csv", "comparisons.csv"):
        assert (rep / name).read_bytes() == (rep3 / name).read_bytes(), name
    assert (det["ci_high"] > det["ci_low"]).all()  # exact intervals: never zero width


def test_study_run_refuses_too_few_repetitions_for_the_largest_size(tmp_path, capsys):
    exp = tmp_path / "tiny.toml"
    exp.write_text(TINY.replace("sizes = [1, 2]", "sizes = [1, 2, 3]").replace("repetitions = 7", "repetitions = 6"))
    assert main(["study", "run", str(exp), "--out", str(tmp_path / "o")]) == 1
    err = capsys.readouterr().err
    assert "repetitions = 6 is too few" in err and "K = 7" in err  # 0.05 / 3 two-sided
    assert not (tmp_path / "o").exists()
