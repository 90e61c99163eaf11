"""Mutation campaign: the experiment file, statistical kills with early stopping, resume."""

import json

import pandas as pd
import pytest

from faultlab.analysis.mutation import analyse_mutation
from faultlab.campaigns.mutation import load_mutation_experiment, run_mutation
from faultlab.errors import ConfigError
from faultlab.runner.store import load_results
from faultlab.inference.exact import min_pairs

SIGN_FLIP = "motion_model:arithmetic:9"  # turns the wrong way: the map is ruined
EQUIVALENT = "motion_model:index:3"      # screened equivalent: never runs

TINY = """
seed = 3
runs = 1
n_steps = 30
repetitions = 7
timeout_s = 60.0
metrics = ["rms"]
[suites]
random = 2
fixed = 1
[slam]
name = "fastslam"
particles = 5
[mutation]
ids = ["{kill}", "{eq}"]
"""


def test_too_few_repetitions_for_the_per_case_level_is_refused(tmp_path):
    f = tmp_path / "m.toml"
    f.write_text(TINY.format(kill=SIGN_FLIP, eq=EQUIVALENT))
    # random = 2 cases: a case is judged at 0.025, which the two-sided test reaches from K = 7
    with pytest.raises(ConfigError, match="K = 7"):
        load_mutation_experiment(f, repetitions=6)


@pytest.mark.slow
def test_a_killed_mutant_stops_early_an_equivalent_one_never_runs_and_a_rerun_resumes(tmp_path):
    f = tmp_path / "m.toml"
    f.write_text(TINY.format(kill=SIGN_FLIP, eq=EQUIVALENT))
    mexp = load_mutation_experiment(f)
    assert mexp.selection.run == (SIGN_FLIP,) and mexp.selection.screened == {EQUIVALENT: "equivalent"}
    first = run_mutation(mexp, tmp_path / "out", jobs=2, progress=False)
    df = load_results(tmp_path / "out")
    assert not df["variant"].str.contains(EQUIVALENT).any()
    mutant = df[df["variant"] == f"mutant:{SIGN_FLIP}"]
    # killed on case 1 of the random suite: case 2 never runs (nor its baseline: nothing is left to judge)
    assert set(zip(mutant["suite"], mutant["case"])) == {("random", 1), ("fixed", 1)}
    assert len(df) == 2 * 2 * 7 and first.n_skipped_early == 2 * 7
    a = analyse_mutation(tmp_path / "out")
    o = a.outcomes.set_index(["mutant", "suite"])
    assert o.loc[(SIGN_FLIP, "random"), "outcome"] in ("killed", "crash")
    assert o.loc[(SIGN_FLIP, "random"), "killing_case"] == 1
    assert o.loc[(EQUIVALENT, "fixed"), "outcome"] == "equivalent"
    again = run_mutation(mexp, tmp_path / "out", jobs=2, progress=False)
    assert again.n_new == 0 and len(load_results(tmp_path / "out")) == len(df)
    a.save(tmp_path / "saved")
    back = type(a).load(tmp_path / "saved")
    pd.testing.assert_frame_equal(back.scores, a.scores, check_dtype=False)


def test_the_shipped_mutation_experiment_has_the_fewest_repetitions_its_two_sided_kills_need():
    mexp = load_mutation_experiment("mutation")
    assert mexp.direction == "either"
    n = max(s.n_cases for s in mexp.experiment.suites)
    assert mexp.experiment.repetitions == min_pairs(mexp.alpha / n, alternative="two-sided")


ADAPTIVE = TINY.replace("repetitions = 7", "repetitions = 10") + "[adaptive]\nstages = [5, 10]\n"


@pytest.mark.parametrize("extra, message", [
    ("level = 0.05\n", "adaptive.level = 0.05 differs from the kill test's per-case level .*0.025 \\(alpha / 2\\)"),
    ("alternative = \"greater\"\n", "contradicts \\[mutation\\].direction = 'either'"),
    ("futility = 0.01\n", "futility must lie in \\[level, 1\\] = \\[0.025, 1\\]"),
])
def test_an_adaptive_table_that_contradicts_the_kill_test_is_refused_naming_file_and_key(tmp_path, extra, message):
    f = tmp_path / "m.toml"
    f.write_text(ADAPTIVE.format(kill=SIGN_FLIP, eq=EQUIVALENT) + extra)
    with pytest.raises(ConfigError, match=message) as err:
        load_mutation_experiment(f)
    assert str(f) in str(err.value)


def test_an_adaptive_table_takes_the_kill_tests_level_and_sidedness_per_suite(tmp_path):
    f = tmp_path / "m.toml"
    f.write_text(ADAPTIVE.format(kill=SIGN_FLIP, eq=EQUIVALENT) + "futility = 0.5\n")
    mexp = load_mutation_experiment(f)
    assert mexp.case_design(2).level == 0.05 / 2 and mexp.case_design(1).level == 0.05
    assert mexp.case_design(2).alternative == "two-sided" and mexp.case_design(2).stages == (5, 10)
    f.write_text(ADAPTIVE.format(kill=SIGN_FLIP, eq=EQUIVALENT).replace("[adaptive]", "[adaptive]\nlevel = 0.025")
                 .replace("fixed = 1", "fixed = 2"))
    assert load_mutation_experiment(f).case_design(2).level == 0.025  # an explicit level equal to alpha / n
    with pytest.raises(ConfigError, match="last stage"):
        f.write_text(ADAPTIVE.format(kill=SIGN_FLIP, eq=EQUIVALENT).replace("[5, 10]", "[5, 9]"))
        load_mutation_experiment(f)


# bit-identical maps to the baseline's (observed equivalent in the reduced study): all-zero differences
IDENTICAL = "apply_resample:unary_minus:3"


@pytest.mark.slow
def test_staged_repetitions_stop_undecidable_pairs_keep_the_fixed_k_kills_and_resume_to_the_same_rows(tmp_path):
    import sqlite3

    from faultlab.runner.staging import STOPS_KEY
    from faultlab.runner.store import META_CHECKSUM_KEY, load_metadata, meta_checksum, results_path

    fixed_f, staged_f = tmp_path / "fixed.toml", tmp_path / "staged.toml"
    fixed_f.write_text(ADAPTIVE.split("[adaptive]")[0].format(kill=SIGN_FLIP, eq=IDENTICAL))
    # futility = 1: curtailment only, every test decision is the fixed-K one
    staged_f.write_text(ADAPTIVE.format(kill=SIGN_FLIP, eq=IDENTICAL) + "futility = 1\n")
    fixed = run_mutation(fixed_f, tmp_path / "fixed", jobs=1, backend="threading", progress=False)
    staged = run_mutation(staged_f, tmp_path / "staged", jobs=1, backend="threading", progress=False)
    a_fixed, a_staged = analyse_mutation(tmp_path / "fixed"), analyse_mutation(tmp_path / "staged")
    key = ["mutant", "suite"]
    kills = lambda a: a.outcomes.set_index(key)["outcome"].isin(["killed", "crash", "timeout"])
    pd.testing.assert_series_equal(kills(a_staged), kills(a_fixed))
    # the identical mutant's differences are all 0: after 5 pairs no outcome of the other 5 can reach
    # alpha / n (two-sided 2 * 2^-5 > 0.05), so every case it ran stopped there, curtailed
    stops = load_metadata(tmp_path / "staged")[STOPS_KEY]
    df_f, df_s = load_results(tmp_path / "fixed"), load_results(tmp_path / "staged")
    ran = df_s[df_s["variant"] == f"mutant:{IDENTICAL}"].groupby(["suite", "case"]).size()
    assert len(ran) and (ran == 5).all()
    assert {(e["suite"], e["case"]) for e in stops if e["variant"] == f"mutant:{IDENTICAL}"} == set(ran.index)
    assert all(e["reason"] in ("curtailed", "futile") and e["repetitions"] == 5 for e in stops)
    assert staged.n_jobs_run == len(df_s) < len(df_f) == fixed.n_jobs_run
    assert staged.n_saved_adaptive == staged.n_stops * 5 + 5 * sum(  # a case whose pairs all stopped: its baseline too
        1 for (s, c), g in df_s.groupby(["suite", "case"]) if g["rep"].max() == 4)
    assert "saved by adaptive repetitions" in str(staged)
    assert a_staged.meta["adaptive"]["executions_saved"] == len(df_s.groupby(["suite", "case", "variant"])) * 10 - len(df_s)
    # common random numbers, seeds per job: every staged row is the fixed-K campaign's row
    cols = ["suite", "case", "variant", "rep", "status", "rms_mm"]
    both = df_s[cols].merge(df_f[cols], on=cols[:4], suffixes=("", "_f"))
    assert len(both) == len(df_s) and (both["rms_mm"] == both["rms_mm_f"]).all()
    # resume after a kill during the first round's second stage: its rows and every recorded stop are
    # lost; the rerun re-derives the same stops from the stage-1 rows and runs the same jobs again
    # (the stops and the metadata checksum are written in one transaction, so the store left behind has a
    # checksum of the metadata without them)
    with sqlite3.connect(results_path(tmp_path / "staged")) as con:
        con.execute("DELETE FROM results WHERE \"case\" = 1 AND rep >= 5")
        con.execute("DELETE FROM meta WHERE key = ?", (STOPS_KEY,))
        left = {k: json.loads(v) for k, v in con.execute("SELECT key, value FROM meta")}
        con.execute("UPDATE meta SET value = ? WHERE key = ?", (json.dumps(meta_checksum(left)), META_CHECKSUM_KEY))
    lost = int(((df_s["case"] == 1) & (df_s["rep"] >= 5)).sum())
    assert lost > 0
    again = run_mutation(staged_f, tmp_path / "staged", jobs=1, backend="threading", progress=False)
    assert again.n_new == lost
    pd.testing.assert_frame_equal(load_results(tmp_path / "staged")[cols].sort_values(cols[:4]).reset_index(drop=True),
                                  df_s[cols].sort_values(cols[:4]).reset_index(drop=True))
    assert load_metadata(tmp_path / "staged")[STOPS_KEY] == stops


@pytest.mark.slow
def test_mutants_that_leave_a_matrix_entry_unwritten_give_the_same_store_in_two_runs(tmp_path):
    """Both write one entry of a scratch matrix twice and another never: zero-filled, never old memory."""
    f = tmp_path / "m.toml"
    f.write_text(TINY.replace('ids = ["{kill}", "{eq}"]',
                              'ids = ["predict_measurement:index:18", "innovation_covariance._sandwich_sym:index:12"]'))
    mexp = load_mutation_experiment(f)
    assert set(mexp.selection.run) == {"predict_measurement:index:18",
                                       "innovation_covariance._sandwich_sym:index:12"}
    stores = []
    for name in ("first", "second"):
        run_mutation(mexp, tmp_path / name, jobs=2, progress=False)
        stores.append(load_results(tmp_path / name).drop(columns=["runtime_s"]))
    assert len(stores[0]) > 0
    pd.testing.assert_frame_equal(stores[0], stores[1], check_exact=True)


def test_a_sample_of_zero_mutants_is_refused_naming_the_file(tmp_path):
    f = tmp_path / "m.toml"
    f.write_text(TINY.replace('ids = ["{kill}", "{eq}"]', "sample = 0"))
    with pytest.raises(ConfigError, match=rf"^{f}: \[mutation\] sample must be >= 1, got 0$"):
        load_mutation_experiment(f)
