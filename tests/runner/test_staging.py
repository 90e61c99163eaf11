import sqlite3

import numpy as np
import pandas as pd
import pytest

from faultlab.errors import ConfigError
from faultlab.runner import load_experiment, load_metadata, load_results, run_experiment
from faultlab.runner.experiment import parse_experiment
from faultlab.runner.staging import STOPS_KEY
from faultlab.inference.sequential import StagedDesign, interim_look, interim_p
from faultlab.inference.exact import min_p_value
from faultlab.vocabulary import BASELINE
from tests.runner.suts import SMALL_SPACE

STAGES = [2, 4]
KEY = ["run", "suite", "case", "variant", "rep"]


def _experiment(adaptive=True, **kw):
    """The smoke campaign at toy scale: 4 repetitions in stages of 2 + 2, level 0.1, one-sided (2^-4 <= 0.1)."""
    data = load_experiment("smoke").to_dict()
    data.update(n_steps=30, repetitions=4, suites={"random": 3, "fixed": 1},
                variants=["baseline", "motion_sign_error", "naive_resampling"])
    data["slam"] = dict(data["slam"], particles=5)
    data["space"] = SMALL_SPACE  # small maps, 30 inactive steps at most
    if adaptive:
        data["adaptive"] = {"stages": STAGES, "level": 0.1, "alternative": "greater", "futility": 0.5} | kw
    return parse_experiment(data, source="staging-test")


def _rows(out):
    df = load_results(out).drop(columns=["runtime_s"])
    return df.sort_values(KEY).reset_index(drop=True)


@pytest.fixture(scope="module")
def fixed_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("fixed")
    run_experiment(_experiment(adaptive=False), out, jobs=1, progress=False)
    return _rows(out)


@pytest.fixture(scope="module")
def staged_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("staged")
    summary = run_experiment(_experiment(), out, jobs=1, progress=False)
    return out, summary


def test_staged_rows_are_the_fixed_runs_rows_of_the_pairs_that_ran(fixed_run, staged_run):
    out, summary = staged_run
    staged = _rows(out)
    assert summary.complete and summary.n_jobs == len(staged) < len(fixed_run)
    merged = staged.merge(fixed_run, on=KEY, suffixes=("", "_fixed"), how="left", validate="1:1")
    for col in ("status", "rms_mm", "emd_mm"):
        np.testing.assert_array_equal(merged[col].to_numpy(), merged[f"{col}_fixed"].to_numpy())


def test_stops_follow_the_rule_on_the_first_stage_and_are_recorded(fixed_run, staged_run):
    out, _ = staged_run
    staged = _rows(out)
    design = StagedDesign(tuple(STAGES), level=0.1, alternative="greater", futility=0.5)
    stops = {(e["run"], e["suite"], e["case"], e["variant"]): e for e in load_metadata(out)[STOPS_KEY]}
    first = fixed_run[fixed_run["rep"] < STAGES[0]].set_index(KEY)["rms_mm"]
    n_reps = staged.groupby(["run", "suite", "case", "variant"]).size()
    kinds = set()
    for (run, suite, case, variant), n in n_reps.items():
        if variant == BASELINE:
            continue
        d = (first.loc[(run, suite, case, variant)].to_numpy() - first.loc[(run, suite, case, BASELINE)].to_numpy())
        decision = str(interim_look(d, design=design))  # this fixture's rows are all ok
        kinds.add(decision)
        key = (run, suite, case, variant)
        if decision == "continue":
            assert n == STAGES[-1] and key not in stops
        else:
            assert n == STAGES[0] and stops[key]["repetitions"] == STAGES[0] and stops[key]["reason"] == decision
    assert "continue" in kinds and kinds - {"continue"}  # the toy campaign exercises both
    # a case's baseline runs every repetition some variant of it needs, and no more
    for (run, suite, case), g in staged.groupby(["run", "suite", "case"]):
        need = g[g["variant"] != BASELINE].groupby("variant").size().max()
        assert (g["variant"] == BASELINE).sum() == need


def test_resume_after_a_kill_reaches_the_same_rows_and_stops(staged_run, tmp_path):
    out, _ = staged_run
    again = tmp_path / "again"
    run_experiment(_experiment(), again, jobs=1, progress=False, batch_size=1)
    # a kill during stage 2: its rows are lost, the run is rerun
    with sqlite3.connect(again / "results.sqlite") as conn:
        conn.execute("DELETE FROM results WHERE rep >= ?", (STAGES[0],))
    summary = run_experiment(_experiment(), again, jobs=1, progress=False)
    assert summary.n_new > 0
    pd.testing.assert_frame_equal(_rows(again), _rows(out))
    assert load_metadata(again)[STOPS_KEY] == load_metadata(out)[STOPS_KEY]


def test_refusals(tmp_path):
    with pytest.raises(ConfigError, match="must equal repetitions"):
        _experiment().replace(repetitions=5)
    with pytest.raises(ConfigError, match="strictly increasing"):
        _experiment(stages=[4, 4])
    # a first stage too short for any interim p value to stay under the futility bound
    for stages, alternative, futility in (([1, 10], "two-sided", 0.5), ([1, 10], "greater", 0.4),
                                          ([2, 10], "two-sided", 0.4)):
        with pytest.raises(ConfigError, match="adaptive: stages: .* stops every pair at the first look"):
            StagedDesign.from_mapping({"stages": stages, "alternative": alternative, "futility": futility},
                                      where="adaptive")
    for stages, alternative, futility in (([1, 10], "greater", 0.5), ([2, 10], "two-sided", 0.5), ([1], "two-sided", 0.5)):
        StagedDesign.from_mapping({"stages": stages, "alternative": alternative, "futility": futility},
                                  where="adaptive")                                 # some data can continue
    # the bound is the test's own: every difference positive gives it
    for k, alternative in ((1, "greater"), (3, "greater"), (2, "two-sided"), (4, "two-sided")):
        StagedDesign(stages=(k, k + 1), alternative=alternative, futility=1.0)
        assert interim_p(np.arange(1.0, k + 1), alternative=alternative) == min_p_value(k, alternative=alternative)
    # no [adaptive]: the hash is the one it had before the key existed
    assert "adaptive" not in _experiment(adaptive=False).canonical_json()
