import json
import shutil
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd

import faultlab.analysis.result
from faultlab.analysis import analyse
from faultlab.cli import main
from faultlab.runner import load_results
from faultlab.stats import DetectionRule, format_effects, outcomes, parameter_effects
from faultlab.runner.store import META_CHECKSUM_KEY, meta_checksum
from tests.stats.synthetic import frame, job

STORE = Path(__file__).resolve().parents[2] / "reports" / "store"
LENIENT = {"abs_mm": 100.0, "rel": 0.1}


def test_paper_table_defaults_from_any_directory(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # defaults fall back to the repository's paper_repro/
    assert main(["paper-table"]) == 0
    out = capsys.readouterr().out
    assert "9038*" in out and "5616 " in out  # starred detected cell, unstarred baseline
    assert out.count("<-- DIFFERS") == 1
    assert "random / missing_angle_wrap: computed 73 %, printed 80 %" in out


def test_paper_table_options_and_errors(tmp_path, capsys):
    assert main(["paper-table", "--abs-mm", "100000"]) == 0
    out = capsys.readouterr().out
    assert "> 100000 mm" in out and "*" not in out.split("Detected Faults")[0].split("\n", 2)[2]
    assert main(["paper-table", "--raw", str(tmp_path / "missing.csv")]) == 1
    assert "paper data file not found" in capsys.readouterr().err


def _store_with_rule(tmp_path, rule: dict) -> Path:
    """A copy of the reference run's store whose campaign stored another detection rule."""
    store = tmp_path / "store"
    shutil.copytree(STORE, store)
    with sqlite3.connect(store / "results.sqlite") as conn:
        conn.execute("UPDATE meta SET value = ? WHERE key = 'detection'", (json.dumps(rule),))
        meta = {k: json.loads(v) for k, v in conn.execute("SELECT key, value FROM meta")}
        conn.execute("UPDATE meta SET value = ? WHERE key = ?", (json.dumps(meta_checksum(meta)), META_CHECKSUM_KEY))
    conn.close()
    return store


def test_paper_table_of_a_campaign_uses_its_stored_rule(tmp_path, capsys):
    store = _store_with_rule(tmp_path, LENIENT)
    assert main(["paper-table", str(store)]) == 0
    out = capsys.readouterr().out
    assert out == analyse(store).paper_table.to_text()
    assert "> 100 mm and >= 10 %" in out
    assert main(["paper-table", str(store), "--abs-mm", "5"]) == 1
    assert "either RESULTS" in capsys.readouterr().err
    assert main(["paper-table", str(store), "--raw", str(tmp_path / "missing.csv")]) == 1
    assert "paper data file not found" in capsys.readouterr().err


def test_effects_command_loads_results_through_the_runner(monkeypatch, capsys):
    rng = np.random.default_rng(0)
    rows = []
    for c in range(1, 61):
        size = float(rng.uniform(16, 400))
        hit = rng.random() < size / 450
        rows += [job(1, "random", c, "baseline", 0, 100.0, map_size=size),
                 job(1, "random", c, "naive_resampling", 0, 900.0 if hit else 100.0, map_size=size)]
    seen = []
    monkeypatch.setattr(faultlab.analysis.result, "load_results", lambda path: seen.append(path) or frame(rows))
    monkeypatch.setattr(faultlab.analysis.result, "load_metadata", lambda path: {})
    assert main(["effects", "some/results", "--parameters", "map_size, landmark_density"]) == 0
    out = capsys.readouterr().out
    assert seen == ["some/results"]
    assert "naive_resampling" in out and "map_size" in out and "OR/SD" in out


def test_effects_use_the_rule_stored_with_the_campaign(tmp_path, capsys):
    store = _store_with_rule(tmp_path, LENIENT)
    assert main(["effects", str(store), "--parameters", "map_size,step_size"]) == 0
    out = capsys.readouterr().out
    stored = parameter_effects(load_results(store), rule=DetectionRule(**LENIENT), parameters=["map_size", "step_size"])
    default = parameter_effects(load_results(store), parameters=["map_size", "step_size"])
    assert out == ("Detection (stored with the campaign): " + DetectionRule(**LENIENT).describe() + "\n"
                   + format_effects(stored))
    assert format_effects(stored) != format_effects(default)
    # the count under the stored rule, computed independently of the command
    pairs = outcomes(load_results(store), rule=DetectionRule(**LENIENT))
    naive = pairs[(pairs["fault"] == "naive_resampling") & pairs["outcome"].isin(["detected", "not_detected"])]
    k = int((naive["outcome"] == "detected").sum())
    assert f"naive_resampling: {k} of {len(naive)} judged jobs detected" in out
    # exactly what the report's Analysis of that store holds
    assert format_effects(analyse(store, paper=False, parameters=["map_size", "step_size"]).parameter_effects) \
        in out
    assert main(["effects", str(store), "--parameters", "size"]) == 1
    assert "unknown parameter 'size'" in capsys.readouterr().err


def test_the_command_line_starts_without_statsmodels():
    code = ("import sys; from faultlab.cli import build_parser; build_parser(); "
            "print('statsmodels' in sys.modules, 'faultlab.analysis.result' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout
    assert out.split() == ["False", "False"]


def _tiny_fixed_store(out: Path) -> Path:
    """A fixed-K toy campaign (K = 4; 15 steps, 5 particles, 2 cases) to replay adaptive designs on."""
    from faultlab.runner import run_experiment
    from tests.analysis.test_replay import _experiment

    exp = _experiment(False).replace(repetitions=4, suites={"random": 1, "fixed": 1},
                                     variants=["baseline", "motion_sign_error", "naive_resampling"])
    run_experiment(exp, out, jobs=1, progress=False)
    return out


def test_stats_adaptive_prints_or_writes_the_replay_of_the_library(tmp_path, capsys):
    from faultlab.analysis.replay import AdaptiveReplay, replay_adaptive

    store = _tiny_fixed_store(tmp_path / "store")
    argv = ["stats", "adaptive", str(store), "--stages", "2,4", "--level", "0.1", "--alternative", "two-sided"]
    expected = replay_adaptive(store, {"stages": [2, 4], "level": 0.1, "alternative": "two-sided"})
    assert main(argv) == 0
    page = capsys.readouterr().out
    assert f"**Executions: {expected.executions_adaptive} of {expected.executions_fixed} " in page
    assert main(argv + ["--reports", str(tmp_path / "rep")]) == 0
    written = capsys.readouterr().out.split()
    assert sorted(Path(p).name for p in written) == ["adaptive_replay.md", "pairs.csv", "replay_meta.json",
                                                      "summary.csv", "verdicts.csv"]
    assert (tmp_path / "rep" / "adaptive_replay.md").read_text() == page
    back = AdaptiveReplay.load(tmp_path / "rep")
    for name in AdaptiveReplay.TABLES:
        pd.testing.assert_frame_equal(back.table(name), expected.table(name))


def test_stats_adaptive_refusals_write_nothing(tmp_path, capsys):
    store = _tiny_fixed_store(tmp_path / "store")
    rep = tmp_path / "rep"
    for argv, message in ((["--reports", str(rep)], "no [adaptive] table"),
                          (["--stages", "2,3", "--reports", str(rep)], "must equal the store's K = 4"),
                          (["--stages", "2,x"], "--stages: expected cumulative repetitions"),
                          (["--level", "0.1"], "need --stages"),
                          (["--stages", "2,4", "--futility", "0.01"], "futility must lie in")):
        assert main(["stats", "adaptive", str(store), *argv]) == 1
        err = capsys.readouterr().err
        assert err.startswith("faultlab: error: ") and message in err and err.count("\n") == 1
        assert not rep.exists()
    assert main(["stats", "adaptive", str(tmp_path / "nowhere"), "--stages", "2,4"]) == 1
    assert capsys.readouterr().err.startswith("faultlab: error: ")
