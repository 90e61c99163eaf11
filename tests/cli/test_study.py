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
whole = ["random"]
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

    # a study whose stored cases do not make a kill matrix yet is refused as unfinished, and nothing written
    import shutil
    import sqlite3

    part = tmp_path / "part"
    shutil.copytree(out, part)
    with sqlite3.connect(part / "results.sqlite") as conn:
        conn.execute("DELETE FROM results WHERE variant = 'weight_overwritten' AND rep >= 3")
    capsys.readouterr()
    assert main(["study", "report", str(part), "--reports", str(tmp_path / "rep-part")]) == 1
    err = capsys.readouterr().err
    assert "the study is unfinished" in err and "of 224 SLAM executions stored" in err and err.count("\n") == 1
    assert not (tmp_path / "rep-part").exists()

    # the whole random suite (its 3 cases) judged by Holm over its cases (statsmodels), crashes detect
    from statsmodels.stats.multitest import multipletests
    from statsmodels.stats.proportion import proportion_confint

    whole = pd.read_csv(rep / "whole.csv")
    assert set(whole["strategy"]) == {"random"} and "## Whole generated suites" in md
    for variant in km["variant"].unique():
        cases = km[(km["strategy"] == "random") & (km["variant"] == variant)]
        holm = multipletests(cases["p"].fillna(1.0), alpha=0.05, method="holm")[0]
        detected = bool(cases["crash"].any() or holm.any())
        row = whole[whole["variant"] == variant].iloc[0]
        assert (row["suites"], row["detected"], row["size"]) == (1, int(detected), 3)
        lo, hi = proportion_confint(int(detected), 1, alpha=0.05, method="beta")
        assert (row["ci_low"], row["ci_high"]) == pytest.approx((lo, hi))
    assert "mutation score" in set(whole["variant"])

    # the report is a pure function of the store: the same tables again
    rep2 = tmp_path / "rep2"
    assert main(["study", "report", str(out), "--reports", str(rep2), "--html"]) == 0
    for name in ("kill_matrix.csv", "detection.csv", "scores.csv", "comparisons.csv"):
        assert (rep / name).read_bytes() == (rep2 / name).read_bytes(), name
    # --html: the same files as a site, every table embedded on a page of its own
    tables = sorted(p.stem for p in (rep2 / "html" / "tables").glob("*.html"))
    assert (rep2 / "html" / "index.html").is_file() and not (rep / "html").exists()
    assert tables == sorted(p.stem for p in rep2.glob("*.csv") if p.stat().st_size <= 1_000_000
                            and not (rep2 / f"{p.stem}.png").exists())
    # a saved report is evaluated again from its kill matrix alone (no store): the same tables
    rep3 = tmp_path / "rep3"
    assert main(["study", "report", str(rep), "--reports", str(rep3)]) == 0
    for name in ("kill_matrix.csv", "detection.csv", "scores.csv", "comparisons.csv"):
        assert (rep / name).read_bytes() == (rep3 / name).read_bytes(), name
    assert (det["ci_high"] > det["ci_low"]).all()  # exact intervals: never zero width


def test_study_run_refuses_a_whole_suite_its_repetitions_cannot_judge(tmp_path, capsys):
    exp = tmp_path / "tiny.toml"
    # 5 cases: 0.05 / 5 needs K = 8 two-sided (2 * 2^-8 <= 0.01 < 2 * 2^-7)
    exp.write_text(TINY.replace('whole = ["random"]', 'whole = ["systematic"]'))
    assert main(["study", "run", str(exp), "--out", str(tmp_path / "o")]) == 1
    err = capsys.readouterr().err
    assert "repetitions = 7 is too few" in err and "K = 8" in err
    exp.write_text(TINY.replace('whole = ["random"]', 'whole = ["pairwise"]'))
    assert main(["study", "run", str(exp), "--out", str(tmp_path / "o")]) == 1
    assert "study.whole" in capsys.readouterr().err and not (tmp_path / "o").exists()


def test_study_run_refuses_too_few_repetitions_for_the_largest_size(tmp_path, capsys):
    exp = tmp_path / "tiny.toml"
    exp.write_text(TINY.replace("sizes = [1, 2]", "sizes = [1, 2, 3]").replace("repetitions = 7", "repetitions = 6"))
    assert main(["study", "run", str(exp), "--out", str(tmp_path / "o")]) == 1
    err = capsys.readouterr().err
    assert "repetitions = 6 is too few" in err and "K = 7" in err  # 0.05 / 3 two-sided
    assert not (tmp_path / "o").exists()


def test_study_plan_writes_the_plan_of_a_tiny_study(tmp_path, capsys):
    from faultlab.inference.planning import plan_study

    from faultlab.analysis.planning import execution_cost

    (tmp_path / "tiny.toml").write_text(TINY)
    from pathlib import Path

    store = str(Path(__file__).resolve().parents[2] / "reports/mutation/store")
    rc = main(["study", "plan", str(tmp_path / "tiny.toml"), "--cost-store", store, "--budget-hours", "0.5",
               "--reports", str(tmp_path / "plan")])
    assert rc == 0
    text = (tmp_path / "plan" / "plan.md").read_text()
    assert text in capsys.readouterr().out
    # the file's 2 strategies (1 pair), 2 faults, largest size 2 and the store's mean runtime
    plan = plan_study("strategies", strategies=2, faults=2, max_suite=2,
                      seconds_per_execution=execution_cost(store).seconds, budget_hours=0.5)
    assert f"| pool cases per strategy | {plan.needed.cases} |" in text
    assert f"| mutants | {plan.needed.mutants} |" in text
    assert f"| SLAM executions | {plan.needed.executions:,} |" in text
    assert "alpha / 1 = 0.05" in text and str(tmp_path) not in text


def test_study_plan_with_an_assumed_cost_says_so(tmp_path, capsys):
    from faultlab.inference.planning import plan_study

    (tmp_path / "tiny.toml").write_text(TINY)
    assert main(["study", "plan", str(tmp_path / "tiny.toml"), "--seconds-per-execution", "2.5",
                 "--cost-store", str(tmp_path / "nowhere")]) == 0
    out = capsys.readouterr().out
    plan = plan_study("strategies", strategies=2, faults=2, max_suite=2, seconds_per_execution=2.5)
    assert "2.50 s per execution: a stated assumption" in out
    assert f"| CPU hours | {plan.needed.cpu_hours:,.1f} |" in out
    # the file's own scale: pools of 5 and 3 cases x (baseline, 2 faults, 1 mutant) x K = 7, at 2.5 s each
    assert "## The file's scale" in out and "Pools: systematic 5, random 3" in out
    assert "| SLAM executions | 224 |" in out and f"| CPU hours | {224 * 2.5 / 3600:,.1f} |" in out
    assert main(["study", "plan", str(tmp_path / "tiny.toml"), "--seconds-per-execution", "0"]) == 1
    assert "--seconds-per-execution" in capsys.readouterr().err


def test_study_plan_of_the_quick_scale_costs_the_quick_table(tmp_path, capsys):
    (tmp_path / "tiny.toml").write_text(TINY + "[study.quick]\nrepetitions = 8\nsuites = { random = 5 }\n")
    assert main(["study", "plan", str(tmp_path / "tiny.toml"), "--quick", "--seconds-per-execution", "1"]) == 0
    out = capsys.readouterr().out
    assert "# Power plan: tiny --quick" in out and "Pools: systematic 5, random 5" in out
    assert f"| SLAM executions | {10 * 4 * 8} |" in out
    assert main(["study", "plan", "mutation", "--quick", "--seconds-per-execution", "1"]) == 1
    assert "--quick" in capsys.readouterr().err


def test_study_run_refuses_a_bad_weights_file_and_writes_nothing(tmp_path, capsys):
    exp = tmp_path / "tiny.toml"
    exp.write_text(TINY.replace("random = 3", "random = 3\neffect-guided = 3")
                   .replace("seed = 1\n", f"seed = 1\nweights = '{tmp_path / 'w.csv'}'\n"))
    (tmp_path / "w.csv").write_text("parameter,class,weight\nmap_size,small,1\nmap_size,huge,2\n")
    assert main(["study", "run", str(exp), "--out", str(tmp_path / "o")]) == 1
    err = capsys.readouterr().err
    assert err.startswith("faultlab: error: ") and err.count("\n") == 1
    assert "study.weights" in err and "w.csv" in err and "huge: unknown class" in err
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_effect_guided_pools_and_whole_suites_appear_in_the_report(tmp_path, capsys):
    from faultlab.space import read_class_weights

    weights = tmp_path / "w.csv"
    weights.write_text("parameter,class,weight\nmap_size,small,0.6\nmap_size,medium,0.3\nmap_size,large,0.1\n")
    exp = tmp_path / "tiny.toml"
    exp.write_text(TINY.replace("random = 3", "random = 3\neffect-guided = 3")
                   .replace('whole = ["random"]', f'whole = ["random", "effect-guided"]\nweights = "{weights}"'))
    out, rep = tmp_path / "out", tmp_path / "rep"
    assert main(["study", "run", str(exp), "--out", str(out), "--jobs", "1", "--backend", "threading",
                 "--no-progress"]) == 0
    assert "308 jobs" in capsys.readouterr().out             # 11 cases x (baseline, 2 faults, 1 mutant) x K = 7
    assert main(["study", "report", str(out), "--reports", str(rep)]) == 0
    km = pd.read_csv(rep / "kill_matrix.csv")
    assert (km["strategy"] == "effect-guided").sum() == 3 * 3                      # 3 pool cases x 3 variants
    for name in ("detection.csv", "power.csv"):
        assert "effect-guided" in set(pd.read_csv(rep / name)["strategy"]), name
    whole = pd.read_csv(rep / "whole.csv")
    assert set(whole["strategy"]) == {"random", "effect-guided"}
    assert set(whole.loc[whole["strategy"] == "effect-guided", "size"]) == {3}
    md = (rep / "study.md").read_text()
    assert "## Whole generated suites" in md and "`effect-guided`" in md
    assert f"class weights of `{weights}`" in md and "heaviest first): map_size: small 0.60, medium 0.30, large 0.10" in md
    meta = pd.read_json(rep / "study_meta.json", typ="series")
    planted = read_class_weights(weights)["map_size"]
    assert meta["weights"]["classes"]["map_size"] == pytest.approx(planted)       # normalised: they sum to 1


def test_study_plan_refuses_a_missing_cost_store(tmp_path, capsys):
    rc = main(["study", "plan", "mutation", "--cost-store", str(tmp_path / "nowhere")])
    assert rc != 0
    assert "nowhere" in capsys.readouterr().err
    assert not (tmp_path / "nowhere").exists()


@pytest.mark.slow
@pytest.mark.parametrize("study, folder, cost", [
    ("study", "study", ["--cost-store", "reports/paper-k10/store"]),
    ("mutation", "mutation", ["--cost-store", "reports/paper-k10/store"]),
    # the 215-mutant run's CPU time per execution (its README): 3618 CPU s for 8275 executions
    ("mutation-paper", "mutation-paper", ["--seconds-per-execution", "0.44"]),
    # the reduced SLAM's measured cost (its README): 2442 CPU s for 306,000 executions
    ("study-medium", "study-medium", ["--seconds-per-execution", "0.008"]),
    # the fault half's measured cost (its README): 1384 s wall x 2 workers for 172,260 executions
    ("study-large", "study-large", ["--seconds-per-execution", "0.016"]),
    ("study-large-faults", "study-large-faults", ["--seconds-per-execution", "0.016"]),
    # the mutant half's (its README): 1695 s wall x 2 workers for 471,540 executions
    ("study-large-mutants", "study-large-mutants", ["--seconds-per-execution", "0.0072"]),
    # a deterministic third-party SLAM judged exactly (K = 1), its cost from its own committed store
    ("mutation-rtb", "mutation-rtb", ["--cost-store", "reports/mutation-rtb/store"])])
def test_the_committed_plan_is_what_the_verb_renders(study, folder, cost, tmp_path, capsys):
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    if cost[0] == "--cost-store":
        cost = [cost[0], str(repo / cost[1])]
    assert main(["study", "plan", study, *cost, "--reports", str(tmp_path)]) == 0
    rendered = (tmp_path / "plan.md").read_text().replace(str(repo) + "/", "")
    assert rendered == (repo / "reports" / folder / "plan.md").read_text()


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
    assert code == 0 or (code == 1 and err.startswith("faultlab: error: ") and err.count("\n") == 1
                         and "the study is unfinished" in err and "study run" in err), err
    assert code == 0 or not (tmp_path / "rep-killed").exists()  # a refused report writes nothing
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


def test_the_committed_confirmatory_plan_is_what_the_verb_renders_from_the_pilot(tmp_path, capsys):
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    assert main(["study", "plan", "study-confirm", "--pilot", str(repo / "reports" / "study-large-faults"),
                 "--seconds-per-execution", "0.016", "--reports", str(tmp_path)]) == 0
    rendered = (tmp_path / "plan.md").read_text().replace(str(repo) + "/", "")
    assert rendered == (repo / "reports" / "study-confirm" / "plan.md").read_text()
    assert "Runs needed for 80 % power at the pilot's effect: **13**" in rendered


def test_a_pilot_plan_needs_a_declared_run_level_difference(tmp_path, capsys):
    from pathlib import Path

    repo = Path(__file__).resolve().parents[2]
    assert main(["study", "plan", "study-large-faults", "--pilot", str(repo / "reports" / "study-large-faults")]) == 1
    assert "declares no run-level detection_means difference test" in capsys.readouterr().err
