"""Mutation campaign: the experiment file, statistical kills with early stopping, resume."""

import pandas as pd
import pytest

from faultlab.analysis.mutation import analyse_mutation
from faultlab.campaigns.mutation import load_mutation_experiment, run_mutation
from faultlab.errors import ConfigError
from faultlab.runner.store import load_results

SIGN_FLIP = "motion_model:arithmetic:9"  # turns the wrong way: the map is ruined
EQUIVALENT = "motion_model:index:3"      # screened equivalent: never runs

TINY = """
seed = 3
runs = 1
n_steps = 30
repetitions = 6
timeout_s = 60.0
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
    with pytest.raises(ConfigError, match="K = 6"):
        load_mutation_experiment(f, repetitions=5)


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
    assert len(df) == 2 * 2 * 6 and first.n_skipped_early == 2 * 6
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
