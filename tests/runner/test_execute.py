import dataclasses
import json
import math
import platform
import signal
import sqlite3
import threading
import warnings

import numpy as np
import pandas as pd
import pytest

from faultlab.errors import ConfigError, ResultsError
from faultlab.vocabulary import JobStatus
from faultlab.runner import (
    case_path,
    load_experiment,
    load_metadata,
    load_results,
    prepare_cases,
    run_experiment,
)
from faultlab.faults import FaultNotApplicableWarning
from faultlab.runner import execute as execute_module
from faultlab.runner.execute import SKIPPED_VARIANTS_KEY, _alarm, execute_batch, execute_job, tune_allocator
from faultlab.runner.jobs import JobBatch, JobKey, JobSpec, expand_jobs
from faultlab.seeds import case_seed, slam_seed, suite_seed_sequence
from faultlab.scenario import generate_scenario, load_scenario
from faultlab.space import build_suite
from tests.runner.suts import write_experiment

SUTS = "tests.runner.suts"


def _without_runtime(df: pd.DataFrame) -> pd.DataFrame:
    return df.drop(columns=["runtime_s"])


def _one_case(**kw):
    base = dict(runs=1, suites={"random": 1}, repetitions=1)
    base.update(kw)
    return base


def test_crash_nan_and_hang_are_recorded_while_others_finish(tmp_path):
    exp = write_experiment(tmp_path / "e.toml", **_one_case(
        variants=["baseline", f"{SUTS}:CRASH", f"{SUTS}:NAN", f"{SUTS}:HANG", f"{SUTS}:STUBBORN", f"{SUTS}:BIAS"],
        timeout_s=2.0))
    summary = run_experiment(exp, tmp_path / "out", jobs=2, progress=False)
    df = load_results(tmp_path / "out").set_index("variant")
    status = df.status.to_dict()
    assert status == {"baseline": "ok", f"{SUTS}:CRASH": "crash", f"{SUTS}:NAN": "crash",
                      f"{SUTS}:HANG": "timeout", f"{SUTS}:STUBBORN": "timeout", f"{SUTS}:BIAS": "ok"}
    assert df.loc[f"{SUTS}:CRASH", "error"].startswith("ZeroDivisionError: injected crash")
    assert df.loc[f"{SUTS}:NAN", "error"].startswith("SlamOutputError:")
    assert "not finite" in df.loc[f"{SUTS}:NAN", "error"]
    assert df.loc[f"{SUTS}:HANG", "error"] == "timeout: wall-clock limit of 2 s exceeded"
    # a hung job is stopped near its limit, not after the SUT's one-minute loop
    assert df.loc[f"{SUTS}:HANG", "runtime_s"] < 30
    for v in (f"{SUTS}:CRASH", f"{SUTS}:NAN", f"{SUTS}:HANG"):
        assert math.isnan(df.loc[v, "rms_mm"]) and math.isnan(df.loc[v, "emd_mm"])
    for v in ("baseline", f"{SUTS}:BIAS"):
        assert np.isfinite(df.loc[v, "rms_mm"]) and df.loc[v, "error"] == ""
        assert df.loc[v, "n_mapped"] + df.loc[v, "n_unmapped"] == df.loc[v, "n_landmarks"]
    assert summary.counts == {"ok": 2, "crash": 2, "timeout": 2}
    assert summary.n_jobs == 6 and summary.n_new == 6 and summary.complete
    assert "6 jobs: 2 ok, 2 crash, 2 timeout" in str(summary)


def test_cooperative_deadline_stops_a_slow_sut_in_a_thread(tmp_path):
    exp = write_experiment(tmp_path / "e.toml", **_one_case(variants=["baseline", f"{SUTS}:SLOW"],
                                                            timeout_s=0.5, n_steps=40))
    run_experiment(exp, tmp_path / "out", jobs=2, backend="threading", progress=False)
    df = load_results(tmp_path / "out").set_index("variant")
    assert df.loc[f"{SUTS}:SLOW", "status"] == "timeout"  # 40 steps x 50 ms > 0.5 s, no SIGALRM in threads
    assert df.loc["baseline", "status"] == "ok"


def test_alarm_only_in_main_thread():
    seen = []
    t = threading.Thread(target=lambda: seen.append(_alarm(1.0).__enter__()))
    t.start()
    t.join()
    assert seen == [False]
    before = signal.getsignal(signal.SIGALRM)
    with _alarm(5.0) as armed:
        assert armed and signal.getitimer(signal.ITIMER_REAL)[0] > 0
    assert signal.getsignal(signal.SIGALRM) is before and signal.getitimer(signal.ITIMER_REAL)[0] == 0


def test_execute_job_in_process_times_out_a_busy_loop(tmp_path):
    """SIGALRM stops a SUT stuck in a pure-Python loop inside one step (main thread)."""
    exp = load_experiment(write_experiment(tmp_path / "e.toml", **_one_case(timeout_s=0.5)))
    (info,) = prepare_cases(exp, tmp_path)
    key = JobKey(1, "random", 1, f"{SUTS}:HANG", 0)
    spec = JobSpec(key, str(info.path), exp.slam, seed=1, timeout_s=0.5)
    res = execute_job(spec)
    assert res.status == JobStatus.TIMEOUT and 0.4 < res.runtime_s < 30
    ok = execute_job(JobSpec(JobKey(1, "random", 1, "baseline", 0), str(info.path), exp.slam, seed=1,
                             timeout_s=30.0))
    assert ok.status == JobStatus.OK and ok.error == "" and np.isfinite(ok.rms_mm)


def test_worker_death_is_recorded_as_crash(tmp_path):
    exp = write_experiment(tmp_path / "e.toml", **_one_case(variants=["baseline", f"{SUTS}:EXIT"]))
    summary = run_experiment(exp, tmp_path / "out", jobs=2, progress=False)
    df = load_results(tmp_path / "out").set_index("variant")
    assert df.loc[f"{SUTS}:EXIT", "status"] == "crash"
    assert df.loc[f"{SUTS}:EXIT", "error"].startswith("WorkerDied:")
    assert df.loc["baseline", "status"] == "ok"
    assert summary.n_jobs == 2 and summary.complete


def test_common_random_numbers_across_variants(tmp_path):
    exp = write_experiment(tmp_path / "e.toml", variants=["baseline", f"{SUTS}:IDENTITY", f"{SUTS}:BIAS"],
                           repetitions=3, runs=1, suites={"random": 2})
    run_experiment(exp, tmp_path / "out", jobs=1, progress=False)
    df = load_results(tmp_path / "out")
    ids = ["run", "suite", "case", "rep"]
    base = df[df.variant == "baseline"].set_index(ids)
    same = df[df.variant == f"{SUTS}:IDENTITY"].set_index(ids)
    bias = df[df.variant == f"{SUTS}:BIAS"].set_index(ids)
    # a fault that changes nothing gives bit-identical errors: the SLAM seed depends on (case, rep) only
    np.testing.assert_array_equal(same.rms_mm.to_numpy(), base.rms_mm.to_numpy())
    assert not np.array_equal(bias.rms_mm.to_numpy(), base.rms_mm.to_numpy())
    # ... and the repetitions do use different seeds
    assert base.groupby(level=["suite", "case"]).rms_mm.nunique().min() == 3


def _small_fastslam(tmp_path):
    return write_experiment(
        tmp_path / "fs.toml", runs=1, n_steps=50, repetitions=2, timeout_s=300.0,
        variants=["baseline", "missing_angle_wrap"], suites={"random": 2, "fixed": 1},
        slam={"name": "fastslam", "particles": 10})


@pytest.mark.slow
def test_results_identical_across_jobs_and_resume(tmp_path):
    exp = _small_fastslam(tmp_path)
    s2 = run_experiment(exp, tmp_path / "two", jobs=2, progress=False)
    s1 = run_experiment(exp, tmp_path / "one", jobs=1, progress=False)
    assert s1.n_jobs == s2.n_jobs == 3 * 2 * 2
    a, b = load_results(tmp_path / "two"), load_results(tmp_path / "one")
    assert (a.status == "ok").all()
    pd.testing.assert_frame_equal(_without_runtime(a), _without_runtime(b), check_exact=True)
    for run, suite, case in a[["run", "suite", "case"]].drop_duplicates().itertuples(index=False):
        x = load_scenario(case_path(tmp_path / "two", run, suite, case))
        y = load_scenario(case_path(tmp_path / "one", run, suite, case))
        np.testing.assert_array_equal(x.landmarks, y.landmarks)
        np.testing.assert_array_equal(x.controls, y.controls)

    # lose some rows (as if killed), resume: only those run again, and the table is unchanged
    conn = sqlite3.connect(tmp_path / "two" / "results.sqlite")
    with conn:
        conn.execute("DELETE FROM results WHERE rep = 1 OR \"case\" = 2")
    conn.close()
    kept = load_results(tmp_path / "two")
    again = run_experiment(exp, tmp_path / "two", jobs=2, progress=False)
    assert again.n_new == len(a) - len(kept) and again.n_skipped == len(kept)
    c = load_results(tmp_path / "two")
    pd.testing.assert_frame_equal(_without_runtime(c), _without_runtime(a), check_exact=True)
    # rows that were kept are untouched (runtime included)
    merged = kept.merge(c, on=["run", "suite", "case", "variant", "rep"], suffixes=("", "_after"))
    np.testing.assert_array_equal(merged.runtime_s.to_numpy(), merged.runtime_s_after.to_numpy())
    # a third run has nothing to do
    assert run_experiment(exp, tmp_path / "two", jobs=2, progress=False).n_new == 0
    assert [s["n_new"] for s in load_metadata(tmp_path / "two")["sessions"]] == [12, again.n_new, 0]


def test_prepare_cases_reproducible_idempotent_and_verified(tmp_path):
    exp = load_experiment(write_experiment(tmp_path / "e.toml", runs=2))
    infos = prepare_cases(exp, tmp_path / "out")
    assert [(i.run, i.suite, i.case) for i in infos] == [
        (r, s, c) for r in (1, 2) for s, n in (("random", 2), ("fixed", 1)) for c in range(1, n + 1)]
    # independent reconstruction of one case from the documented seeds
    specs = build_suite("random", exp.parameter_space(), rng=np.random.default_rng(
        suite_seed_sequence(exp.seed, 2, "random")), n_cases=2)
    seed = case_seed(exp.seed, 2, "random", 2)
    ref = generate_scenario(specs[1], rng=np.random.default_rng(seed), n_steps=exp.n_steps,
                            sensor_range=exp.sensor_range, seed=seed)
    saved = load_scenario(case_path(tmp_path / "out", 2, "random", 2))
    np.testing.assert_array_equal(saved.landmarks, ref.landmarks)
    np.testing.assert_array_equal(saved.obs_range, ref.obs_range)
    assert saved.seed == seed
    # different runs draw different cases
    other = load_scenario(case_path(tmp_path / "out", 1, "random", 2))
    assert other.landmarks.shape != saved.landmarks.shape or not np.array_equal(other.landmarks, saved.landmarks)

    # idempotent: a half-written case is regenerated identically, others are left alone
    path = case_path(tmp_path / "out", 1, "fixed", 1)
    before = load_scenario(path)
    mtime = case_path(tmp_path / "out", 1, "random", 1).stat().st_mtime_ns
    path.with_suffix(".json").unlink()
    assert prepare_cases(exp, tmp_path / "out") == infos
    np.testing.assert_array_equal(load_scenario(path).true_poses, before.true_poses)
    assert case_path(tmp_path / "out", 1, "random", 1).stat().st_mtime_ns == mtime

    # a saved case of another experiment is refused
    js = path.with_suffix(".json")
    meta = json.loads(js.read_text())
    meta["seed"] = 1
    js.write_text(json.dumps(meta))
    with pytest.raises(ResultsError, match="does not match"):
        prepare_cases(exp, tmp_path / "out")


def test_malformed_experiment_refused_before_any_work(tmp_path):
    bad = write_experiment(tmp_path / "bad.toml", runs=0)
    with pytest.raises(ConfigError, match="runs must be >= 1"):
        run_experiment(bad, tmp_path / "out")
    assert not (tmp_path / "out").exists()
    # a fault whose replacement cannot be built is caught before the store is created
    broken = write_experiment(tmp_path / "broken.toml", variants=["baseline", f"{SUTS}:UNBUILDABLE"])
    with pytest.raises(ConfigError, match=r"variants\[1\] = '.*UNBUILDABLE' cannot be applied"):
        run_experiment(broken, tmp_path / "out2")
    assert not (tmp_path / "out2").exists()
    good = write_experiment(tmp_path / "good.toml")
    with pytest.raises(ConfigError, match="jobs"):
        run_experiment(good, tmp_path / "out3", jobs=0)
    with pytest.raises(ConfigError, match="backend"):
        run_experiment(good, tmp_path / "out3", backend="spark")
    with pytest.raises(ConfigError, match="batch_size"):
        run_experiment(good, tmp_path / "out3", batch_size=0)
    assert not (tmp_path / "out3").exists()


def test_variants_whose_fault_does_not_apply_are_skipped_and_recorded(tmp_path):
    # EKF-SLAM has no resampling unit: naive_resampling is skipped, missing_angle_wrap runs
    exp = write_experiment(tmp_path / "ekf.toml", **_one_case(
        slam={"name": "ekf"}, variants=["baseline", "naive_resampling", "missing_angle_wrap"]))
    with pytest.warns(FaultNotApplicableWarning,
                      match=r"variants\[1\] skipped: fault 'naive_resampling' replaces unit 'resample', "
                            r"which SLAM 'ekf' does not have"):
        summary = run_experiment(exp, tmp_path / "out", jobs=1, progress=False)
    df = load_results(tmp_path / "out")
    assert sorted(df.variant) == ["baseline", "missing_angle_wrap"]
    assert summary.n_jobs == 2 and summary.complete
    skipped = load_metadata(tmp_path / "out")[SKIPPED_VARIANTS_KEY]
    assert skipped == [{"fault": "naive_resampling", "step": "resample", "slam": "ekf", "n_units": 13,
                        "reason": "fault 'naive_resampling' replaces unit 'resample', which SLAM 'ekf' does "
                                  "not have (it has 13 other units)"}]
    # dead reckoning has no units at all: every fault is skipped, the baseline still runs
    dr = write_experiment(tmp_path / "dr.toml", **_one_case(
        slam={"name": "dead_reckoning"}, variants=["baseline", "naive_resampling", "motion_sign_error"]))
    with pytest.warns(FaultNotApplicableWarning, match="has no replaceable units"):
        run_experiment(dr, tmp_path / "dr", jobs=1, progress=False)
    assert list(load_results(tmp_path / "dr").variant) == ["baseline"]
    assert [r["fault"] for r in load_metadata(tmp_path / "dr")[SKIPPED_VARIANTS_KEY]] == [
        "naive_resampling", "motion_sign_error"]
    # a campaign whose faults all apply records an empty list
    ok = write_experiment(tmp_path / "ok.toml", **_one_case(variants=["baseline", f"{SUTS}:BIAS"]))
    with warnings.catch_warnings():
        warnings.simplefilter("error", FaultNotApplicableWarning)
        run_experiment(ok, tmp_path / "ok", jobs=1, progress=False)
    assert load_metadata(tmp_path / "ok")[SKIPPED_VARIANTS_KEY] == []


def test_changed_experiment_refused_unless_force_new(tmp_path):
    path = write_experiment(tmp_path / "e.toml", **_one_case())
    run_experiment(path, tmp_path / "out", jobs=1, progress=False)
    first = load_results(tmp_path / "out")
    write_experiment(path, **_one_case(repetitions=2))
    with pytest.raises(ResultsError, match="different experiment.*changed: repetitions.*--force-new"):
        run_experiment(path, tmp_path / "out", jobs=1, progress=False)
    pd.testing.assert_frame_equal(load_results(tmp_path / "out"), first)
    summary = run_experiment(path, tmp_path / "out", jobs=1, progress=False, force_new=True)
    assert summary.n_new == summary.n_jobs == 4
    (old,) = (tmp_path / "out").glob("previous-*")
    pd.testing.assert_frame_equal(load_results(old), first)


@pytest.mark.slow
def test_dask_local_cluster_gives_the_loky_table(tmp_path):
    distributed = pytest.importorskip("distributed")
    exp = write_experiment(tmp_path / "e.toml", runs=1, variants=["baseline", f"{SUTS}:BIAS"])
    run_experiment(exp, tmp_path / "loky", jobs=2, progress=False)
    with distributed.LocalCluster(n_workers=2, processes=True, threads_per_worker=1, host="127.0.0.1",
                                  dashboard_address=None) as cluster, distributed.Client(cluster):
        summary = run_experiment(exp, tmp_path / "dask", backend="dask", progress=False)
    assert summary.complete and summary.counts["ok"] == summary.n_jobs == 12
    pd.testing.assert_frame_equal(_without_runtime(load_results(tmp_path / "dask")),
                                  _without_runtime(load_results(tmp_path / "loky")), check_exact=True)
    assert load_metadata(tmp_path / "dask")["sessions"][0]["backend"] == "dask"


def test_expand_matches_store_identities(tmp_path):
    exp = load_experiment(write_experiment(tmp_path / "e.toml"))
    run_experiment(exp, tmp_path / "out", jobs=1, progress=False)
    infos = prepare_cases(exp, tmp_path / "out")
    jobs = expand_jobs(exp, ((i.run, i.suite, i.case, i.path, i.cost) for i in infos))
    df = load_results(tmp_path / "out")
    assert sorted(j.key.astuple() for j in jobs) == sorted(
        df[["run", "suite", "case", "variant", "rep"]].itertuples(index=False, name=None))
    assert all(j.seed == slam_seed(exp.seed, j.key.run, j.key.suite, j.key.case, j.key.rep) for j in jobs)


# ------------------------------------------------------------------ batched repetitions

def _fastslam_batches(tmp_path, **overrides):
    data = dict(runs=1, n_steps=40, repetitions=3, timeout_s=300.0, suites={"random": 1, "fixed": 1},
                variants=["baseline", "missing_angle_wrap", f"{SUTS}:FS_UNLUCKY", f"{SUTS}:FS_FAR"],
                slam={"name": "fastslam", "particles": 12})
    data.update(overrides)
    return write_experiment(tmp_path / "batches.toml", **data)


def _batch(exp, infos, variant, reps) -> JobBatch:
    specs = [s for s in expand_jobs(exp, ((i.run, i.suite, i.case, i.path, i.cost) for i in infos))
             if s.key.variant == variant and s.key.rep in reps and s.key.case == 1 and s.key.suite == "random"]
    return JobBatch(tuple(specs))


def test_execute_batch_gives_each_repetition_its_single_job_result(tmp_path):
    exp = load_experiment(_fastslam_batches(tmp_path, repetitions=4))
    infos = prepare_cases(exp, tmp_path)
    for variant in exp.variants:
        batch = _batch(exp, infos, variant, range(4))
        got = execute_batch(batch)
        alone = [execute_job(s) for s in batch.jobs]
        assert [r.key for r in got] == list(batch.keys)
        for a, b in zip(alone, got):
            assert dataclasses.replace(a, runtime_s=0.0) == dataclasses.replace(b, runtime_s=0.0), variant
        if variant == f"{SUTS}:FS_FAR":  # not attributable to one repetition: every one ran alone
            assert len({r.runtime_s for r in got}) == len(got)
        else:  # one batched SLAM: every row records the batch's time / its size
            assert len({r.runtime_s for r in got}) == 1
    statuses = {v: [r.status for r in execute_batch(_batch(exp, infos, v, range(4)))] for v in exp.variants}
    assert set(statuses[f"{SUTS}:FS_UNLUCKY"]) == {JobStatus.OK, JobStatus.CRASH}  # one repetition's failure
    assert set(statuses[f"{SUTS}:FS_FAR"]) == {JobStatus.CRASH}
    assert set(statuses["baseline"]) == {JobStatus.OK}


def test_a_batch_past_its_limit_records_every_repetition_as_timeout(tmp_path):
    exp = load_experiment(_fastslam_batches(tmp_path, timeout_s=0.4, variants=["baseline", f"{SUTS}:FS_HANG"]))
    infos = prepare_cases(exp, tmp_path)
    batch = _batch(exp, infos, f"{SUTS}:FS_HANG", range(3))
    assert batch.timeout_s == pytest.approx(1.2)
    results = execute_batch(batch)
    assert [r.status for r in results] == [JobStatus.TIMEOUT] * 3
    assert results[0].error == "timeout: wall-clock limit of 1.2 s exceeded by a batch of 3 repetitions (0.4 s each)"
    assert 1.0 < 3 * results[0].runtime_s < 30  # stopped near the batch's limit, not after a minute


def test_batched_and_single_repetition_campaigns_store_the_same_rows(tmp_path):
    exp = _fastslam_batches(tmp_path)
    single = run_experiment(exp, tmp_path / "single", jobs=2, progress=False, batch_size=1)
    batched = run_experiment(exp, tmp_path / "batched", jobs=2, progress=False)
    assert single.n_jobs == batched.n_jobs == batched.n_new == 2 * 4 * 3
    a, b = load_results(tmp_path / "single"), load_results(tmp_path / "batched")
    pd.testing.assert_frame_equal(_without_runtime(a), _without_runtime(b), check_exact=True)
    assert set(a.status) == {"ok", "crash"} and (a[a.variant == "baseline"].status == "ok").all()
    # batched rows of a (case, variant) share one runtime (the batch's); single-job rows do not
    ok = b[b.variant == "baseline"].groupby(["suite", "case"]).runtime_s.nunique()
    assert (ok == 1).all()
    assert (a[a.variant == "baseline"].groupby(["suite", "case"]).runtime_s.nunique() == 3).all()


@pytest.mark.slow
def test_a_resumed_batched_campaign_runs_only_the_missing_repetitions(tmp_path):
    exp = _fastslam_batches(tmp_path, variants=["baseline", "motion_sign_error"])
    run_experiment(exp, tmp_path / "out", jobs=2, progress=False)
    full = load_results(tmp_path / "out")
    conn = sqlite3.connect(tmp_path / "out" / "results.sqlite")
    with conn:
        conn.execute("DELETE FROM results WHERE rep = 1 OR (rep = 2 AND variant = 'baseline')")
    conn.close()
    kept = load_results(tmp_path / "out")
    again = run_experiment(exp, tmp_path / "out", jobs=2, progress=False)
    assert again.n_new == len(full) - len(kept) == 2 * (2 + 1)
    after = load_results(tmp_path / "out")
    pd.testing.assert_frame_equal(_without_runtime(after), _without_runtime(full), check_exact=True)
    merged = kept.merge(after, on=["run", "suite", "case", "variant", "rep"], suffixes=("", "_after"))
    np.testing.assert_array_equal(merged.runtime_s.to_numpy(), merged.runtime_s_after.to_numpy())
    # the missing repetitions of a (case, variant) ran as one batch: reps 1 and 2 of the baseline share a runtime
    redo = after[(after.variant == "baseline") & (after.rep > 0)].groupby(["suite", "case"]).runtime_s.nunique()
    assert (redo == 1).all()


def test_a_batch_that_kills_its_worker_is_a_crash_of_each_repetition(tmp_path):
    exp = _fastslam_batches(tmp_path, variants=["baseline", f"{SUTS}:FS_EXIT"], suites={"random": 1},
                            repetitions=2)
    summary = run_experiment(exp, tmp_path / "out", jobs=2, progress=False)
    df = load_results(tmp_path / "out")
    died = df[df.variant == f"{SUTS}:FS_EXIT"]
    assert list(died.status) == ["crash", "crash"] and died.error.str.startswith("WorkerDied:").all()
    assert (df[df.variant == "baseline"].status == "ok").all() and summary.complete


def test_prepare_cases_passes_fov_bug_and_notices_a_mismatch(tmp_path):
    exp = load_experiment(write_experiment(tmp_path / "e.toml", fov_bug=True))
    infos = prepare_cases(exp, tmp_path / "out")
    saved = load_scenario(infos[0].path)
    assert saved.meta["config"]["fov_bug"] is True
    # the same case generated directly with the defect, from its documented seed
    direct = generate_scenario(saved.case, rng=np.random.default_rng(saved.seed), n_steps=exp.n_steps,
                               sensor_range=exp.sensor_range, min_distance=exp.min_distance, fov_bug=True)
    np.testing.assert_array_equal(saved.obs_bearing, direct.obs_bearing)
    with pytest.raises(ResultsError, match="fov_bug = True there, False here"):
        prepare_cases(exp.replace(fov_bug=False), tmp_path / "out")


@pytest.mark.skipif(platform.system() != "Linux" or platform.libc_ver()[0] != "glibc", reason="glibc only")
def test_the_executors_tune_glibcs_allocator_once(tmp_path):
    exp = load_experiment(write_experiment(tmp_path / "e.toml", **_one_case()))
    (info,) = prepare_cases(exp, tmp_path)
    execute_job(JobSpec(JobKey(1, "random", 1, "baseline", 0), str(info.path), exp.slam, seed=1, timeout_s=30.0))
    assert execute_module._allocator_tuned is True  # set by the executor, in this (worker) process
    assert tune_allocator() is True


# -- every built-in SLAM runs the smoke experiment; unknown association is scored by EMD ----------


def _smoke_with(slam: dict, tmp_path, name: str):
    """The shipped smoke experiment with another ``[slam]`` table, cut to one case of 30 steps."""
    from faultlab.runner.experiment import load_experiment, parse_experiment

    data = load_experiment("smoke").to_dict()
    data.update(slam=slam, suites={"fixed": 1}, n_steps=30)
    data.pop("metric")  # the SLAM's association chooses it
    exp = parse_experiment(data, source=f"smoke [{name}]")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", FaultNotApplicableWarning)
        summary = run_experiment(exp, tmp_path / name, jobs=1, progress=False)
    return exp, summary, load_results(tmp_path / name)


@pytest.mark.parametrize("slam", [
    {"name": "fastslam", "particles": 10}, {"name": "fastslam2", "particles": 10}, {"name": "ekf"},
    pytest.param({"name": "gtsam"}, marks=pytest.mark.skipif(
        __import__("importlib").util.find_spec("gtsam") is None, reason="gtsam is not installed"))],
    ids=lambda s: s["name"])
def test_the_smoke_experiment_runs_with_every_builtin_slam(slam, tmp_path):
    exp, summary, df = _smoke_with(slam, tmp_path, slam["name"])
    assert summary.complete and (df.status == "ok").all()
    assert exp.metric == "rms" and df.rms_mm.notna().all()
    assert "baseline" in set(df.variant)


def test_a_slam_without_ids_is_scored_by_emd(tmp_path):
    slam = {"name": "fastslam", "particles": 10, "association": "unknown"}
    exp, summary, df = _smoke_with(slam, tmp_path, "unknown")
    assert exp.metric == "emd" and summary.complete and (df.status == "ok").all()
    assert df.rms_mm.isna().all() and (df.emd_mm > 0).all()
    # the stored EMD is the one of the same estimate scored directly, without alignment
    from faultlab.metrics import earth_movers_distance
    from faultlab.slam import run_slam
    row = df[df.variant == "baseline"].iloc[0]
    sc = load_scenario(sorted((tmp_path / "unknown" / "cases").rglob("*.npz"))[0])
    seed = slam_seed(exp.seed, int(row.run), row.suite, int(row.case), int(row.rep))
    est = run_slam(exp.slam.build(), sc, rng=np.random.default_rng(seed))
    assert row.emd_mm == pytest.approx(1000 * earth_movers_distance(sc.landmarks, est.landmarks))


def test_given_cases_replace_the_suites_draws_and_are_checked_on_resume(tmp_path):
    """A designed experiment passes its cases: each is generated from its own seed and run for every variant."""
    from faultlab.runner import load_experiment, load_results
    from faultlab.scenario.suite import SuiteCase
    from faultlab.space import FIXED_VALUES, CaseSpec, table1_space

    exp = load_experiment(write_experiment(tmp_path / "e.toml"))
    values = [dict(FIXED_VALUES, map_size=9.0), dict(FIXED_VALUES, map_size=30.0, step_size=120.0)]
    cases = [SuiteCase(run=1, suite="morris", case=i, spec=CaseSpec(v, table1_space().classify(v)),
                       seed=case_seed(exp.seed, 1, "morris", i)) for i, v in enumerate(values, start=1)]
    out = tmp_path / "out"
    summary = run_experiment(exp, out, jobs=1, backend="threading", progress=False, cases=cases)
    res = load_results(out)
    assert summary.n_jobs == 2 * len(exp.variants) * exp.repetitions == len(res)
    assert set(res["suite"]) == {"morris"}
    got = res.drop_duplicates("case").set_index("case")
    assert got.loc[1, "map_size"] == 9.0 and got.loc[2, "step_size"] == 120.0
    assert load_scenario(out / "cases" / "run1" / "morris" / "case2.npz").seed == cases[1].seed
    changed = [dataclasses.replace(cases[0], spec=CaseSpec(dict(values[0], map_size=10.0)))]
    with pytest.raises(ResultsError, match="does not match"):
        run_experiment(exp, out, jobs=1, backend="threading", progress=False, cases=changed)
