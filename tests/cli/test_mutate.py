"""``python -m faultlab mutate list|show`` on the reference FastSLAM and on a SLAM given by import path."""

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

from faultlab.cli import main

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module", autouse=True)
def cache(tmp_path_factory):
    """One screening of the reference for the whole module (later calls read the cache)."""
    old = os.environ.get("FAULTLAB_CACHE_DIR")
    os.environ["FAULTLAB_CACHE_DIR"] = str(tmp_path_factory.mktemp("cache"))
    yield
    if old is None:
        del os.environ["FAULTLAB_CACHE_DIR"]
    else:
        os.environ["FAULTLAB_CACHE_DIR"] = old


def _counts(out: str) -> dict[str, int]:
    return {m.group(1): int(m.group(2)) for m in re.finditer(r"^  (live|stillborn|equivalent|duplicate|nondeterministic)\s+(\d+)",
                                                            out, re.M)}


def test_list_shows_the_live_mutants_of_the_reference_and_a_count_per_class(capsys):
    assert main(["mutate", "list"]) == 0
    out = capsys.readouterr().out
    counts = _counts(out)
    assert set(counts) == {"live", "stillborn", "equivalent", "duplicate", "nondeterministic"} and counts["live"] >= 150
    rows = [line for line in out.splitlines() if re.match(r"^\S+:[a-z0-9_]+:\d+\s", line)]
    assert len(rows) == counts["live"]
    total = int(re.search(r"^fastslam: (\d+) mutants", out, re.M).group(1))
    assert total == sum(counts.values())
    assert "id" in out.splitlines()[0] and "operator" in out.splitlines()[0]


def test_list_all_of_one_unit_and_operator_with_classes(capsys):
    assert main(["mutate", "list", "--unit", "resample", "--operator", "comparison", "--all"]) == 0
    out = capsys.readouterr().out
    rows = {line.split()[0]: line for line in out.splitlines() if line.startswith("resample:")}
    assert set(rows) == {"resample:comparison:1", "resample:comparison:2"}
    assert "equivalent" in rows["resample:comparison:1"] and "n_eff > n" in rows["resample:comparison:1"]
    assert " live " in rows["resample:comparison:2"] and "n_eff < n" in rows["resample:comparison:2"]
    assert _counts(out) == {"live": 1, "stillborn": 0, "equivalent": 1, "duplicate": 0, "nondeterministic": 0}


def test_show_prints_the_diff_and_the_class(capsys):
    assert main(["mutate", "show", "resample:comparison:2"]) == 0
    out = capsys.readouterr().out
    assert "class       live: differs from the original on unit examples" in out
    assert "--- a/faultlab/slam/units.py\n+++ b/faultlab/slam/units.py\n@@ -" in out
    assert "-    if empty or n_eff >= n / config.resample_ratio:\n" in out
    assert "+    if empty or n_eff < n / config.resample_ratio:\n" in out
    assert "fault name  mutant/resample.comparison.2" in out


def test_unknown_mutant_is_a_clear_error(capsys):
    assert main(["mutate", "show", "resample:comparision:2"]) == 1
    err = capsys.readouterr().err
    assert "unknown mutant 'resample:comparision:2'" in err and "did you mean 'resample:comparison:2'" in err


def test_mutate_without_a_verb_prints_help(capsys):
    assert main(["mutate"]) == 2
    assert "list" in capsys.readouterr().out


def test_module_entry_point_with_a_slam_given_by_import_path(tmp_path):
    env = {**os.environ, "FAULTLAB_CACHE_DIR": str(tmp_path)}
    done = subprocess.run([sys.executable, "-m", "faultlab", "mutate", "list", "--slam",
                           "tests.mutation.toy:make_toy_slam", "--unit", "lin", "--all"],
                          capture_output=True, text=True, cwd=ROOT, env=env, timeout=300)
    assert done.returncode == 0, done.stderr
    assert "lin:constant:3" in done.stdout and "tests.mutation.toy:make_toy_slam:" in done.stdout


def test_mutate_run_refuses_too_few_repetitions_for_the_per_case_level(tmp_path, capsys):
    f = tmp_path / "m.toml"
    f.write_text('seed = 1\nrepetitions = 7\n[suites]\nfixed = 5\n[slam]\nparticles = 5\n'
                 '[mutation]\nids = ["motion_model:arithmetic:9"]\n')
    assert main(["mutate", "run", str(f), "--out", str(tmp_path / "out"), "--repetitions", "7"]) == 1
    err = capsys.readouterr().err
    assert "repetitions = 7 is too few" in err and "K = 8" in err  # 0.05 / 5 two-sided
    assert not (tmp_path / "out").exists()


def test_mutate_report_of_a_directory_without_a_mutation_campaign_is_one_clear_error(tmp_path, capsys):
    assert main(["mutate", "report", str(tmp_path), "--reports", str(tmp_path / "rep")]) == 1
    assert "not a mutation campaign" in capsys.readouterr().err


def test_mutate_run_rejects_an_unknown_selector(tmp_path, capsys):
    assert main(["mutate", "run", "mutation", "--out", str(tmp_path / "o"), "--mutants", "colour=red"]) == 1
    assert "unknown selector 'colour'" in capsys.readouterr().err
