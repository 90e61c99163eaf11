"""Mutation campaigns on a user's own SLAM source: selection, exact kills, jobs, SIGKILL-resume, incremental reruns."""

import os
import signal
import sqlite3
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest

from faultlab.analysis.mutation import analyse_mutation
from faultlab.campaigns.mutation import load_mutation_experiment, run_mutation
from faultlab.errors import ConfigError
from faultlab.runner.store import load_results
from tests.mutation.usercode import FACTORY, MODULE, SOURCE, forget_package, user_package  # noqa: F401  (fixture)

EXPERIMENT = f"""
seed = 4
runs = 1
n_steps = 10
repetitions = 1
timeout_s = 60.0
metrics = ["rms"]
[suites]
random = 3
[slam]
name = "{FACTORY}"
[mutation]
target = "{MODULE}:wrap,Mapper.update"
operators = ["arithmetic", "off_by_one"]
probes = 2
"""
COLUMNS = ["run", "suite", "case", "variant", "rep", "status", "rms_mm", "emd_mm", "n_mapped", "error"]


@pytest.fixture
def experiment(user_package, tmp_path, monkeypatch):  # noqa: F811
    monkeypatch.setenv("FAULTLAB_CACHE_DIR", str(tmp_path / "cache"))
    f = tmp_path / "m.toml"
    f.write_text(EXPERIMENT)
    return f


def _rows(out) -> pd.DataFrame:
    return load_results(out)[COLUMNS].sort_values(COLUMNS[:5]).reset_index(drop=True)


@pytest.mark.slow
def test_a_target_campaign_selects_live_mutants_and_judges_a_deterministic_slam_exactly(experiment):
    mexp = load_mutation_experiment(experiment)
    sel = mexp.selection
    assert mexp.kill == "exact" and mexp.fixed_case_alpha == pytest.approx(0.05 / 3)
    assert sel.run and all(i.startswith(f"{MODULE}:") for i in sel.run)
    assert {sel.unit[i] for i in sel.run} <= {"wrap", "Mapper.update"}
    assert sel.info["classes"]["live"] == sel.info["n_live"] >= len(sel.run)
    # update's diagnostic counter (self.steps) is read by no estimate: its mutants are equivalent
    counter = [i for i, c in sel.screened.items() if ":Mapper.update:" in i and c == "equivalent"]
    assert counter and all(i not in sel.run for i in counter)
    sampled = load_mutation_experiment(experiment, mutants="operator=arithmetic,operator=off_by_one,sample=3")
    # the first 3 live mutants of the seeded order: live in the full screening too, or a duplicate of one there
    assert len(sampled.selection.run) == 3
    assert all(i in sel.run or i in sel.represented_by for i in sampled.selection.run)
    assert sampled.selection.info["n_live"] == 3 and sampled.selection.info["n_mutants"] == sel.info["n_mutants"]
    with pytest.raises(ConfigError, match="functions and lines"):
        load_mutation_experiment(experiment, mutants="unit=motion_model")


def test_a_sign_flip_campaign_on_a_target_needs_enough_repetitions(experiment):
    with pytest.raises(ConfigError, match="judged exactly"):
        load_mutation_experiment(experiment, repetitions=3)


def _cli(args, *, cwd, site, **kw):
    env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(site), *sys.path]))
    return subprocess.Popen([sys.executable, "-m", "faultlab", "mutate", "run", *map(str, args), "--no-progress"],
                            cwd=cwd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, **kw)


@pytest.mark.slow
def test_two_workers_give_the_rows_of_one_and_a_sigkilled_run_resumes_to_them(experiment, tmp_path):
    site = tmp_path / "site"
    one = _cli([experiment, "--out", tmp_path / "one", "--jobs", "1"], cwd=tmp_path, site=site)
    assert one.wait(timeout=900) == 0, one.stderr.read()
    two = _cli([experiment, "--out", tmp_path / "two", "--jobs", "2"], cwd=tmp_path, site=site)
    assert two.wait(timeout=900) == 0, two.stderr.read()
    pd.testing.assert_frame_equal(_rows(tmp_path / "one"), _rows(tmp_path / "two"))
    n = len(_rows(tmp_path / "one"))
    killed = _cli([experiment, "--out", tmp_path / "killed", "--jobs", "2"], cwd=tmp_path, site=site,
                  start_new_session=True)
    deadline = time.monotonic() + 600
    while killed.poll() is None and time.monotonic() < deadline:
        try:
            if 1 <= len(load_results(tmp_path / "killed")) < n:
                break
        except Exception:  # the store is not there yet
            pass
        time.sleep(0.02)
    if killed.poll() is None:
        os.killpg(killed.pid, signal.SIGKILL)
    killed.wait()
    if len(load_results(tmp_path / "killed")) == n:
        # on an idle machine the campaign can finish between two looks: lose its later rows as a kill would
        with sqlite3.connect(tmp_path / "killed" / "results.sqlite") as con:
            con.execute("DELETE FROM results WHERE rowid > (SELECT MIN(rowid) FROM results) + 2")
    assert len(load_results(tmp_path / "killed")) < n
    again = _cli([experiment, "--out", tmp_path / "killed", "--jobs", "2"], cwd=tmp_path, site=site)
    assert again.wait(timeout=900) == 0, again.stderr.read()
    pd.testing.assert_frame_equal(_rows(tmp_path / "one"), _rows(tmp_path / "killed"))
    a, b = analyse_mutation(tmp_path / "one"), analyse_mutation(tmp_path / "killed")
    pd.testing.assert_frame_equal(a.outcomes, b.outcomes)


@pytest.mark.slow
def test_an_incremental_rerun_runs_only_the_changed_functions_mutants_and_reuses_the_rest(experiment, tmp_path,
                                                                                           user_package):  # noqa: F811
    first = load_mutation_experiment(experiment)
    run_mutation(first, tmp_path / "a", jobs=1, progress=False)
    # the user edits wrap (same behaviour, other text): only wrap's mutants are new
    user_package.write_text(SOURCE.replace("return (a + np.pi) % (2 * np.pi) - np.pi",
                                           "return (a + np.pi) % (np.pi * 2) - np.pi"))
    forget_package()
    second = load_mutation_experiment(experiment, reuse=tmp_path / "a")
    ran_before = set(first.selection.run)
    assert set(second.selection.reused) == {i for i in ran_before if ":Mapper.update:" in i}
    assert second.selection.run and all(":wrap:" in i and i not in ran_before for i in second.selection.run)
    run_mutation(second, tmp_path / "b", jobs=1, progress=False)
    variants = set(load_results(tmp_path / "b")["variant"])
    assert variants - {"baseline"} == {f"mutant:{i}" for i in second.selection.run}
    a, b = analyse_mutation(tmp_path / "a"), analyse_mutation(tmp_path / "b")
    assert b.meta["n_reused"] == len(second.selection.reused)
    reused = b.outcomes[b.outcomes["mutant"].isin(second.selection.reused)]
    assert reused["note"].str.contains("reused from").all()
    old = a.outcomes.set_index(["mutant", "suite"]).loc[reused.set_index(["mutant", "suite"]).index, "outcome"]
    assert list(old) == list(reused["outcome"])
    with pytest.raises(ConfigError, match="another experiment"):
        Path(experiment).write_text(EXPERIMENT.replace("seed = 4", "seed = 5"))
        load_mutation_experiment(experiment, reuse=tmp_path / "a")
