"""Adaptive repetitions replayed on a fixed-K store against a real adaptive run of the same experiment."""

import shutil
import sqlite3

import numpy as np
import pandas as pd
import pytest

from faultlab.analysis import analyse
from faultlab.stats.metadata import count_expected_jobs
from faultlab.analysis.replay import AdaptiveReplay, replay_adaptive, replay_rows
from faultlab.errors import ConfigError, ResultsError
from faultlab.runner import load_experiment, load_metadata, load_results, run_experiment
from faultlab.runner.experiment import parse_experiment
from faultlab.inference.sequential import StagedDesign
from faultlab.runner.staging import STOPS_KEY
from faultlab.vocabulary import BASELINE, REPLICA
from tests.runner.suts import SMALL_SPACE

K = 8
DESIGN = {"stages": [4, K], "level": 0.1, "alternative": "two-sided", "futility": 0.5}
KEY = ["run", "suite", "case", "variant", "rep"]
VERDICT_KEY = ["suite", "run", "case", "fault"]


def _experiment(adaptive: bool):
    """A toy campaign: 15 steps, 5 particles, 3 cases, a fault detected on every case (motion sign
    error), one hardly ever (naive resampling) and the A/A replica; K = 8 in stages of 4 + 4."""
    data = load_experiment("smoke").to_dict()
    data.update(n_steps=15, repetitions=K, suites={"random": 2, "fixed": 1},
                variants=["baseline", REPLICA, "motion_sign_error", "naive_resampling"],
                detection={"rule": "statistical", "alpha": 0.1, "direction": "either"})
    data["slam"] = dict(data["slam"], particles=5)
    data["space"] = SMALL_SPACE
    if adaptive:
        data["adaptive"] = DESIGN
    return parse_experiment(data, source="replay-test")


@pytest.fixture(scope="module")
def fixed_store(tmp_path_factory):
    out = tmp_path_factory.mktemp("fixed")
    run_experiment(_experiment(False), out, jobs=1, progress=False)
    return out


@pytest.fixture(scope="module")
def adaptive_store(tmp_path_factory):
    out = tmp_path_factory.mktemp("adaptive")
    summary = run_experiment(_experiment(True), out, jobs=1, progress=False)
    return out, summary


@pytest.fixture(scope="module")
def replay(fixed_store):
    return replay_adaptive(fixed_store, DESIGN)


@pytest.mark.slow
def test_the_replay_reaches_the_real_adaptive_runs_stops_executions_and_verdicts(fixed_store, adaptive_store,
                                                                                 replay):
    out, summary = adaptive_store
    real_rows = load_results(out)
    real_meta = load_metadata(out)
    # the toy campaign exercises both a stop and a pair that runs every stage
    reasons = set(replay.pairs.loc[replay.pairs["variant"] != BASELINE, "stop"])
    assert "completed" in reasons and reasons - {"completed"}
    # stops, as the runner records them
    assert replay.stops == real_meta[STOPS_KEY]
    # executions: the rows the adaptive run stored, its own count and the metadata's count
    assert replay.executions_adaptive == summary.n_jobs == len(real_rows) == count_expected_jobs(real_meta)
    assert replay.executions_fixed == len(load_results(fixed_store)) == count_expected_jobs(real_meta, adaptive=False)
    assert replay.saved_pct == pytest.approx(100 * (1 - len(real_rows) / replay.executions_fixed))
    assert 0 < replay.saved_pct < 100
    # the repetitions each (case, variant) used, the baseline's included
    used = real_rows.groupby(["run", "suite", "case", "variant"]).size().rename("n").reset_index()
    merged = replay.pairs.merge(used, on=["run", "suite", "case", "variant"], how="left", validate="1:1")
    np.testing.assert_array_equal(merged["reps_adaptive"].to_numpy(), merged["n"].to_numpy())
    # the replayed rows are the adaptive run's rows, value for value
    design = StagedDesign.from_mapping(DESIGN, where="test")
    rows, stops = replay_rows(load_results(fixed_store), design=design, metric="rms")
    assert stops == real_meta[STOPS_KEY]
    drop = ["runtime_s"]
    pd.testing.assert_frame_equal(rows.drop(columns=drop).reset_index(drop=True),
                                  real_rows.drop(columns=drop).reset_index(drop=True))
    # verdicts: the adaptive column is the real adaptive run's analysis, the fixed column the fixed store's
    for store, side in ((out, "adaptive"), (fixed_store, "fixed")):
        real = analyse(store, paper=False).case_verdicts.set_index(VERDICT_KEY).sort_index()
        got = replay.verdicts.set_index(VERDICT_KEY).sort_index()
        assert list(got.index) == list(real.index)
        np.testing.assert_array_equal(got[f"verdict_{side}"].to_numpy(), real["verdict"].to_numpy())
        np.testing.assert_array_equal(got[f"reps_{side}"].to_numpy(), real["n_reps"].to_numpy())
        for col in ("p", "p_holm"):
            np.testing.assert_array_equal(got[f"{col}_{side}"].to_numpy(), real[col].to_numpy())
    v = replay.verdicts
    assert (v["changed"] == (v["verdict_fixed"] != v["verdict_adaptive"])).all()
    assert ((v["why"] != "") == v["changed"]).all()
    assert (v["verdict_fixed"] == "detected").any()  # the toy campaign has verdicts to keep


def test_summary_counts_add_up(replay):
    s = replay.summary.set_index("variant")
    per = s.drop(index="(all)")
    assert per["executions_adaptive"].sum() == s.loc["(all)", "executions_adaptive"] == replay.executions_adaptive
    assert per["executions_fixed"].sum() == s.loc["(all)", "executions_fixed"] == replay.executions_fixed
    assert per["n_changed"].sum() == s.loc["(all)", "n_changed"] == int(replay.verdicts["changed"].sum())
    # a pair stopped at the first look used the first stage's repetitions
    stopped = replay.pairs[~replay.pairs["stop"].isin(["completed", "follows_variants"])]
    assert (stopped["reps_adaptive"] == DESIGN["stages"][0]).all() and (stopped["stages_run"] == 1).all()


def test_saved_and_loaded_back_equal(replay, tmp_path):
    replay.save(tmp_path)
    back = AdaptiveReplay.load(tmp_path)
    for name in AdaptiveReplay.TABLES:
        pd.testing.assert_frame_equal(back.table(name), replay.table(name))
    assert back.meta["stops"] == replay.stops


def test_a_store_with_a_missing_repetition_is_one_clear_error(fixed_store, tmp_path):
    broken = tmp_path / "broken"
    shutil.copytree(fixed_store, broken)
    with sqlite3.connect(broken / "results.sqlite") as conn:
        conn.execute("DELETE FROM results WHERE variant = 'naive_resampling' AND rep = 6 AND suite = 'fixed'")
    with pytest.raises(ResultsError, match=r"1 of the \d+ jobs of its cases are missing \(run 1 fixed case 1 "
                                           r"naive_resampling rep 6 first; K = 8"):
        replay_adaptive(broken, DESIGN)


def test_refusals(fixed_store, adaptive_store):
    with pytest.raises(ConfigError, match="no \\[adaptive\\] table"):
        replay_adaptive(fixed_store)
    with pytest.raises(ConfigError, match="last stage \\(6\\) must equal the store's K = 8"):
        replay_adaptive(fixed_store, {"stages": [3, 6]})
    with pytest.raises(ConfigError, match="strictly increasing"):
        replay_adaptive(fixed_store, {"stages": [8, 8]})
    out, _ = adaptive_store
    with pytest.raises(ResultsError, match="an adaptive campaign .* stopped early"):
        replay_adaptive(out)  # its own [adaptive] design is the default; its rows are truncated


def test_the_toy_replay_explains_its_changes(replay):
    """Stages of 4 cannot be judged two-sided at alpha 0.1 (5 pairs needed): each such change says so."""
    changed = replay.changed
    assert len(changed) > 0 and (changed["reason_adaptive"] == "too_few_pairs").all()
    assert changed["why"].str.contains("needs 5 usable pairs to reach alpha = 0.1").all()
    assert any("cannot be judged by the store's rule" in n for n in replay.meta["notes"])


def _row(**kw):
    from collections import namedtuple

    base = dict(run=1, suite="fixed", case=1, fault="f", family="f", stop="futile", reps_fixed=8, reps_adaptive=4,
                verdict_fixed="detected", verdict_adaptive="not_detected", reason_fixed="", reason_adaptive="",
                p_fixed=0.004, p_adaptive=0.6, p_holm_fixed=0.01, p_holm_adaptive=0.6, changed=True, why="")
    base.update(kw)
    return namedtuple("Row", base)(**base)


def test_each_kind_of_change_gets_its_reason():
    from faultlab.analysis.replay import _why

    jobs = pd.DataFrame({"run": [1] * 4, "suite": ["fixed"] * 4, "case": [1] * 4,
                         "variant": [BASELINE, BASELINE, "f", "f"], "rep": [3, 6, 3, 5],
                         "status": ["ok", "crash", "ok", "timeout"]})
    kw = dict(k=8, alpha=0.05, needed=6, alternative="two-sided")
    assert "power loss of the futility bound" in _why(_row(), jobs, **kw)
    assert "the baseline failed in repetition 6" in _why(_row(verdict_fixed="cannot_judge"), jobs, **kw)
    assert "the faulty variant failed in repetition 5" in _why(_row(verdict_fixed="crash_detected"), jobs, **kw)
    holm = _why(_row(reps_adaptive=8, stop="completed", p_holm_adaptive=0.07), jobs, **kw)
    assert holm.startswith("ran all 8 repetitions") and "0.01 -> 0.07" in holm
    assert _why(_row(changed=False), jobs, **kw) == ""
