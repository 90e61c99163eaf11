"""run_experiment: cases, jobs, store, resumption, skipped variants, every built-in SLAM."""

import dataclasses
import json
import math
import sqlite3
import warnings

import numpy as np
import pandas as pd
import pytest

from faultlab.errors import ConfigError, ResultsError
from faultlab.runner import case_path, load_experiment, load_metadata, load_results, prepare_cases, run_experiment
from faultlab.faults import FaultNotApplicableWarning
from faultlab.runner.store import SKIPPED_VARIANTS_KEY
from faultlab.runner.jobs import expand_jobs
from faultlab.seeds import case_seed, slam_seed, suite_seed_sequence
from faultlab.scenario import generate_scenario, load_scenario, save_scenario
from faultlab.space import build_suite
from tests.runner.suts import SUTS, fastslam_batches, one_case, without_runtime, write_experiment


def test_crash_nan_and_hang_are_recorded_while_others_finish(tmp_path):
    exp = write_experiment(tmp_path / "e.toml", **one_case(
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
    pd.testing.assert_frame_equal(without_runtime(a), without_runtime(b), check_exact=True)
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
    pd.testing.assert_frame_equal(without_runtime(c), without_runtime(a), check_exact=True)
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

    # a saved case of another experiment (another seed, intact files) is refused
    save_scenario(dataclasses.replace(before, seed=1), path)
    with pytest.raises(ResultsError, match="does not match"):
        prepare_cases(exp, tmp_path / "out")

    # a damaged case (an edited .json, a truncated .npz) is regenerated from its seed
    js = path.with_suffix(".json")
    meta = json.loads(js.read_text())
    meta["seed"] = 12345
    js.write_text(json.dumps(meta))
    npz = case_path(tmp_path / "out", 1, "random", 1)
    intact = npz.read_bytes()
    npz.write_bytes(intact[:len(intact) // 3])
    assert prepare_cases(exp, tmp_path / "out") == infos
    assert npz.read_bytes() == intact
    np.testing.assert_array_equal(load_scenario(path).true_poses, before.true_poses)


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
    exp = write_experiment(tmp_path / "ekf.toml", **one_case(
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
    dr = write_experiment(tmp_path / "dr.toml", **one_case(
        slam={"name": "dead_reckoning"}, variants=["baseline", "naive_resampling", "motion_sign_error"]))
    with pytest.warns(FaultNotApplicableWarning, match="has no replaceable units"):
        run_experiment(dr, tmp_path / "dr", jobs=1, progress=False)
    assert list(load_results(tmp_path / "dr").variant) == ["baseline"]
    assert [r["fault"] for r in load_metadata(tmp_path / "dr")[SKIPPED_VARIANTS_KEY]] == [
        "naive_resampling", "motion_sign_error"]
    # a campaign whose faults all apply records an empty list
    ok = write_experiment(tmp_path / "ok.toml", **one_case(variants=["baseline", f"{SUTS}:BIAS"]))
    with warnings.catch_warnings():
        warnings.simplefilter("error", FaultNotApplicableWarning)
        run_experiment(ok, tmp_path / "ok", jobs=1, progress=False)
    assert load_metadata(tmp_path / "ok")[SKIPPED_VARIANTS_KEY] == []


def test_changed_experiment_refused_unless_force_new(tmp_path):
    path = write_experiment(tmp_path / "e.toml", **one_case())
    run_experiment(path, tmp_path / "out", jobs=1, progress=False)
    first = load_results(tmp_path / "out")
    write_experiment(path, **one_case(repetitions=2))
    with pytest.raises(ResultsError, match="different experiment.*changed: repetitions.*--force-new"):
        run_experiment(path, tmp_path / "out", jobs=1, progress=False)
    pd.testing.assert_frame_equal(load_results(tmp_path / "out"), first)
    summary = run_experiment(path, tmp_path / "out", jobs=1, progress=False, force_new=True)
    assert summary.n_new == summary.n_jobs == 4
    (old,) = (tmp_path / "out").glob("previous-*")
    pd.testing.assert_frame_equal(load_results(old), first)


def test_expand_matches_store_identities(tmp_path):
    exp = load_experiment(write_experiment(tmp_path / "e.toml"))
    run_experiment(exp, tmp_path / "out", jobs=1, progress=False)
    infos = prepare_cases(exp, tmp_path / "out")
    jobs = expand_jobs(exp, ((i.run, i.suite, i.case, i.path, i.cost) for i in infos))
    df = load_results(tmp_path / "out")
    assert sorted(j.key.astuple() for j in jobs) == sorted(
        df[["run", "suite", "case", "variant", "rep"]].itertuples(index=False, name=None))
    assert all(j.seed == slam_seed(exp.seed, j.key.run, j.key.suite, j.key.case, j.key.rep) for j in jobs)


def test_batched_and_single_repetition_campaigns_store_the_same_rows(tmp_path):
    exp = fastslam_batches(tmp_path)
    single = run_experiment(exp, tmp_path / "single", jobs=2, progress=False, batch_size=1)
    batched = run_experiment(exp, tmp_path / "batched", jobs=2, progress=False)
    assert single.n_jobs == batched.n_jobs == batched.n_new == 2 * 4 * 3
    a, b = load_results(tmp_path / "single"), load_results(tmp_path / "batched")
    pd.testing.assert_frame_equal(without_runtime(a), without_runtime(b), check_exact=True)
    assert set(a.status) == {"ok", "crash"} and (a[a.variant == "baseline"].status == "ok").all()
    # batched rows of a (case, variant) share one runtime (the batch's); single-job rows do not
    ok = b[b.variant == "baseline"].groupby(["suite", "case"]).runtime_s.nunique()
    assert (ok == 1).all()
    assert (a[a.variant == "baseline"].groupby(["suite", "case"]).runtime_s.nunique() == 3).all()


@pytest.mark.slow
def test_a_resumed_batched_campaign_runs_only_the_missing_repetitions(tmp_path):
    exp = fastslam_batches(tmp_path, variants=["baseline", "motion_sign_error"])
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
    pd.testing.assert_frame_equal(without_runtime(after), without_runtime(full), check_exact=True)
    merged = kept.merge(after, on=["run", "suite", "case", "variant", "rep"], suffixes=("", "_after"))
    np.testing.assert_array_equal(merged.runtime_s.to_numpy(), merged.runtime_s_after.to_numpy())
    # the missing repetitions of a (case, variant) ran as one batch: reps 1 and 2 of the baseline share a runtime
    redo = after[(after.variant == "baseline") & (after.rep > 0)].groupby(["suite", "case"]).runtime_s.nunique()
    assert (redo == 1).all()


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


def _smoke_with(slam: dict, tmp_path, name: str):
    """The shipped smoke experiment with another ``[slam]`` table, cut to one case of 30 steps."""
    from faultlab.runner.experiment import load_experiment, parse_experiment

    data = load_experiment("smoke").to_dict()
    data.update(slam=slam, suites={"fixed": 1}, n_steps=30)
    data.pop("metric")  # the SLAM's association chooses it
    data.pop("metrics", None)  # and the map errors recorded follow from it (smoke itself records the RMS only)
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


def test_metrics_rms_records_nan_emd_and_the_same_rms_bit_for_bit(tmp_path):
    from faultlab.analysis import analyse
    from faultlab.errors import ResultsError

    spec = dict(repetitions=2, variants=["baseline", "missing_angle_wrap"])
    both = load_experiment(fastslam_batches(tmp_path, metrics=["rms", "emd"], **spec))  # the two map errors
    only = both.replace(metrics=["rms"])
    run_experiment(both, tmp_path / "both", jobs=1, progress=False)
    run_experiment(only, tmp_path / "rms", jobs=1, progress=False)
    a, b = load_results(tmp_path / "both"), load_results(tmp_path / "rms")
    assert (a["status"] == "ok").all() and a["emd_mm"].gt(0).all()
    assert b["emd_mm"].isna().all()
    np.testing.assert_array_equal(a["rms_mm"].to_numpy(), b["rms_mm"].to_numpy())  # bit for bit
    pd.testing.assert_frame_equal(without_runtime(a).drop(columns="emd_mm"), without_runtime(b).drop(columns="emd_mm"))
    assert load_metadata(tmp_path / "rms")["metrics"] == ["rms"]
    assert load_metadata(tmp_path / "both")["metrics"] == ["rms", "emd"]
    by_emd = analyse(tmp_path / "both", paper=False, metric="emd")
    assert "judge by 'emd'" in " ".join(n.text for n in by_emd.notes_on("metric"))
    with pytest.raises(ResultsError, match=r"cannot be judged by 'emd': the experiment recorded only 'rms'"):
        analyse(tmp_path / "rms", paper=False, metric="emd")
    by_rms = analyse(tmp_path / "rms", paper=False)
    assert any("Metrics recorded: RMS only; EMD was not computed" in n.text for n in by_rms.notes_on("metric"))


def test_given_cases_replace_the_suites_draws_and_are_checked_on_resume(tmp_path):
    """A designed experiment passes its cases: each is generated from its own seed and run for every variant."""
    import dataclasses

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


def test_the_stored_ate_is_the_trajectory_error_of_the_slam_rerun_on_the_stored_case(tmp_path):
    from faultlab.metrics.trajectory import absolute_trajectory_error
    from faultlab.slam import run_slam
    from faultlab.slam.registry import build_slam

    exp = write_experiment(tmp_path / "e.toml", runs=1, n_steps=30, repetitions=2, suites={"random": 2},
                           variants=["baseline", "missing_angle_wrap"], slam={"name": "fastslam", "particles": 8})
    run_experiment(exp, tmp_path / "out", jobs=1, progress=False)
    df = load_results(tmp_path / "out")
    assert (df.status == "ok").all() and np.isfinite(df.ate_mm).all()
    experiment = load_experiment(exp)
    for row in df.itertuples():
        scenario = load_scenario(case_path(tmp_path / "out", row.run, row.suite, row.case))
        slam = build_slam("fastslam", dict(experiment.slam.options))
        if row.variant != "baseline":
            from faultlab.faults import get_fault
            slam = get_fault(row.variant).apply(slam)
        est = run_slam(slam, scenario, rng=np.random.default_rng(
            slam_seed(experiment.seed, row.run, row.suite, row.case, row.rep)))
        ate = absolute_trajectory_error(scenario.true_poses[1:, :2], est.trajectory[:, :2]).rmse
        assert row.ate_mm == 1000 * ate


def test_a_slam_without_a_trajectory_and_a_job_not_recording_it_store_nan(tmp_path):
    exp = write_experiment(tmp_path / "e.toml", **one_case())  # TinySlam reports no trajectory
    run_experiment(exp, tmp_path / "out", jobs=1, progress=False)
    df = load_results(tmp_path / "out")
    assert (df.status == "ok").all() and df.ate_mm.isna().all() and np.isfinite(df.rms_mm).all()
    exp2 = write_experiment(tmp_path / "e2.toml", **one_case(slam={"name": "ekf"}, variants=["baseline"],
                                                                metrics=["rms", "emd"]))
    run_experiment(exp2, tmp_path / "out2", jobs=1, progress=False)
    df2 = load_results(tmp_path / "out2")
    assert (df2.status == "ok").all() and df2.ate_mm.isna().all()
    assert load_metadata(tmp_path / "out2")["metrics"] == ["rms", "emd"]


def test_a_store_from_before_the_ate_resumes_under_the_same_experiment_without_it(tmp_path):
    """A store written before the ATE existed (no ate_mm column, metadata metrics rms and emd) resumes
    under an experiment that records the ATE by default: same hash, old rows still verified, the new
    rows keep the store's layout (ATE NULL)."""
    exp = write_experiment(tmp_path / "e.toml", **one_case(slam={"name": "ekf"}, suites={"random": 2},
                                                               variants=["baseline"]))
    out = tmp_path / "out"
    run_experiment(exp, out, jobs=1, progress=False)
    full = load_results(out)
    assert np.isfinite(full.ate_mm).all()
    # make it a store of the previous layout: the column gone, one row gone, the metadata of then
    conn = sqlite3.connect(out / "results.sqlite")
    conn.execute("UPDATE results SET ate_mm = NULL")  # what such a store holds (checksums then re-made below)
    conn.execute("ALTER TABLE results DROP COLUMN ate_mm")
    conn.execute("DELETE FROM results WHERE \"case\" = 2")
    conn.execute("UPDATE meta SET value = ? WHERE key = 'metrics'", (json.dumps(["rms", "emd"]),))
    conn.execute("DELETE FROM meta WHERE key = 'meta_checksum'")  # nor had such a store a metadata checksum
    conn.commit()
    conn.close()
    _rechecksum_without_ate(out / "results.sqlite")
    old = load_results(out)
    assert len(old) == len(full) // 2 and old.ate_mm.isna().all()
    pd.testing.assert_frame_equal(old.drop(columns=["ate_mm", "runtime_s"]),
                                  full[full.case != 2].drop(columns=["ate_mm", "runtime_s"]).reset_index(drop=True))
    summary = run_experiment(exp, out, jobs=1, progress=False)  # not refused: same hash
    assert summary.n_new == len(full) // 2
    resumed = load_results(out)
    assert len(resumed) == len(full) and resumed.ate_mm.isna().all()
    pd.testing.assert_frame_equal(without_runtime(resumed).drop(columns=["ate_mm"]),
                                  without_runtime(full).drop(columns=["ate_mm"]))


def _rechecksum_without_ate(path):
    """Recompute every row's checksum as a writer of the previous layout did (no ate_mm column)."""
    from faultlab.runner import store as store_module

    before = tuple(c for c in store_module.RESULT_COLUMNS if c != "ate_mm")
    conn = sqlite3.connect(path)
    cols = ", ".join(f'"{c}"' for c in before)
    rows = conn.execute(f"SELECT rowid, {cols} FROM results").fetchall()
    old_layout = tuple(c for c in store_module._DIGEST_ORDER if c != "ate_mm")
    for rowid, *values in rows:
        by_name = dict(zip(before, values))
        checksum = store_module._row_digest(by_name) + b"".join(
            store_module._column_digest(c, by_name[c]) for c in old_layout)
        conn.execute("UPDATE results SET checksum = ? WHERE rowid = ?", (checksum, rowid))
    conn.commit()
    conn.close()


def _files_of(out) -> dict:
    return {p: p.stat().st_mtime_ns for p in out.rglob("*")}


def test_meta_entries_are_recorded_before_the_rows_and_cannot_change_on_a_resume(tmp_path):
    path = write_experiment(tmp_path / "e.toml", **one_case())
    out = tmp_path / "out"
    declared = {"alpha": 0.05, "analyses": [{"table": "detection_means", "margin": 0.05}]}
    run_experiment(path, out, jobs=1, progress=False, meta={"declaration": declared})
    assert load_metadata(out)["declaration"] == declared
    # the same entry resumes (nothing left to run); another one is refused and writes nothing
    assert run_experiment(path, out, jobs=1, progress=False, meta={"declaration": declared}).n_new == 0
    first, files = load_results(out), _files_of(out)
    with pytest.raises(ResultsError, match="another 'declaration'.*cannot change once recorded"):
        run_experiment(path, out, jobs=1, progress=False, meta={"declaration": declared | {"alpha": 0.01}})
    assert _files_of(out) == files
    pd.testing.assert_frame_equal(load_results(out), first)
    # a store holding rows without the entry cannot get it afterwards
    other = tmp_path / "other"
    run_experiment(path, other, jobs=1, progress=False)
    with pytest.raises(ResultsError, match="holds 2 rows and no 'declaration'.*before the first row"):
        run_experiment(path, other, jobs=1, progress=False, meta={"declaration": declared})
    assert "declaration" not in load_metadata(other)
    # the entry is covered by the metadata checksum: editing it in the file is detected
    with sqlite3.connect(out / "results.sqlite") as conn:
        conn.execute("UPDATE meta SET value = ? WHERE key = 'declaration'", (json.dumps(declared | {"alpha": 0.5}),))
    with pytest.raises(ResultsError, match="does not match its checksum"):
        load_metadata(out)
