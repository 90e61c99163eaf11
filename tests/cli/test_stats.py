import numpy as np

import faultlab.runner
from faultlab.cli import main
from tests.stats.synthetic import frame, job


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


def test_effects_command_loads_results_through_the_runner(monkeypatch, capsys):
    rng = np.random.default_rng(0)
    rows = []
    for c in range(1, 61):
        size = float(rng.uniform(16, 400))
        hit = rng.random() < size / 450
        rows += [job(1, "random", c, "baseline", 0, 100.0, map_size=size),
                 job(1, "random", c, "naive_resampling", 0, 900.0 if hit else 100.0, map_size=size)]
    seen = []
    monkeypatch.setattr(faultlab.runner, "load_results", lambda path: seen.append(path) or frame(rows))
    assert main(["effects", "some/results", "--parameters", "map_size, landmark_density"]) == 0
    out = capsys.readouterr().out
    assert seen == ["some/results"]
    assert "naive_resampling" in out and "map_size" in out and "OR/SD" in out
