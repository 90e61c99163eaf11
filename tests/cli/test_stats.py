import json
import shutil
import sqlite3
import subprocess
import sys
from pathlib import Path

import numpy as np

import faultlab.analysis.result
from faultlab.analysis import analyse
from faultlab.cli import main
from faultlab.runner import load_results
from faultlab.stats import DetectionRule, format_effects, outcomes, parameter_effects
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
