"""Executing one job or a batch: timeouts, crashes, batched repetitions, the allocator."""

import dataclasses
import platform
import signal
import threading

import numpy as np
import pytest

from faultlab.errors import ScenarioError
from faultlab.vocabulary import JobStatus
from faultlab.runner import load_experiment, load_results, prepare_cases, run_experiment
from faultlab.runner import execution as execution_module
from faultlab.runner.execution import _alarm, execute_batch, execute_job, load_case, tune_allocator
from faultlab.runner.jobs import JobBatch, JobKey, JobSpec, expand_jobs
from faultlab.scenario.model import load_scenario, save_scenario
from tests.runner.suts import SUTS, fastslam_batches, one_case, write_experiment


def test_cooperative_deadline_stops_a_slow_sut_in_a_thread(tmp_path):
    exp = load_experiment(write_experiment(tmp_path / "e.toml", **one_case(variants=["baseline", f"{SUTS}:SLOW"],
                                                                           timeout_s=0.5, n_steps=40)))
    infos = prepare_cases(exp, tmp_path / "out")
    specs = expand_jobs(exp, ((i.run, i.suite, i.case, i.path, i.cost) for i in infos))
    results = {}
    threads = [threading.Thread(target=lambda s=s: results.update({s.key.variant: execute_job(s)})) for s in specs]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert results[f"{SUTS}:SLOW"].status == JobStatus.TIMEOUT  # 40 steps x 50 ms > 0.5 s, no SIGALRM in threads
    assert results["baseline"].status == JobStatus.OK


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
    exp = load_experiment(write_experiment(tmp_path / "e.toml", **one_case(timeout_s=0.5)))
    (info,) = prepare_cases(exp, tmp_path)
    key = JobKey(1, "random", 1, f"{SUTS}:HANG", 0)
    spec = JobSpec(key, str(info.path), exp.slam, seed=1, timeout_s=0.5)
    res = execute_job(spec)
    assert res.status == JobStatus.TIMEOUT and 0.4 < res.runtime_s < 30
    ok = execute_job(JobSpec(JobKey(1, "random", 1, "baseline", 0), str(info.path), exp.slam, seed=1,
                             timeout_s=30.0))
    assert ok.status == JobStatus.OK and ok.error == "" and np.isfinite(ok.rms_mm)


def _batch(exp, infos, variant, reps) -> JobBatch:
    specs = [s for s in expand_jobs(exp, ((i.run, i.suite, i.case, i.path, i.cost) for i in infos))
             if s.key.variant == variant and s.key.rep in reps and s.key.case == 1 and s.key.suite == "random"]
    return JobBatch(tuple(specs))


def test_execute_batch_gives_each_repetition_its_single_job_result(tmp_path):
    exp = load_experiment(fastslam_batches(tmp_path, repetitions=4))
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
    exp = load_experiment(fastslam_batches(tmp_path, timeout_s=0.4, variants=["baseline", f"{SUTS}:FS_HANG"]))
    infos = prepare_cases(exp, tmp_path)
    batch = _batch(exp, infos, f"{SUTS}:FS_HANG", range(3))
    assert batch.timeout_s == pytest.approx(1.2)
    results = execute_batch(batch)
    assert [r.status for r in results] == [JobStatus.TIMEOUT] * 3
    assert results[0].error == "timeout: wall-clock limit of 1.2 s exceeded by a batch of 3 repetitions (0.4 s each)"
    assert 1.0 < 3 * results[0].runtime_s < 30  # stopped near the batch's limit, not after a minute


@pytest.mark.skipif(platform.system() != "Linux" or platform.libc_ver()[0] != "glibc", reason="glibc only")
def test_the_executors_tune_glibcs_allocator_once(tmp_path):
    exp = load_experiment(write_experiment(tmp_path / "e.toml", **one_case()))
    (info,) = prepare_cases(exp, tmp_path)
    execute_job(JobSpec(JobKey(1, "random", 1, "baseline", 0), str(info.path), exp.slam, seed=1, timeout_s=30.0))
    assert execution_module._allocator_tuned is True  # set by the executor, in this (worker) process
    assert tune_allocator() is True


def _same_scenario(a, b) -> bool:
    arrays = [f.name for f in dataclasses.fields(a) if isinstance(getattr(a, f.name), np.ndarray)]
    return (a.case == b.case and a.seed == b.seed and a.meta == b.meta
            and all(np.array_equal(getattr(a, k), getattr(b, k)) and getattr(a, k).dtype == getattr(b, k).dtype
                    for k in arrays))


def test_load_case_gives_the_saved_case_a_fresh_copy_each_time_and_rereads_a_rewritten_file(tmp_path):
    exp = load_experiment(write_experiment(tmp_path / "e.toml", **one_case(runs=2)))
    first, second = prepare_cases(exp, tmp_path / "out")
    a = load_case(first.path)
    assert _same_scenario(a, load_scenario(first.path))
    a.obs_range[:] = -1.0  # a SLAM writing into what it is fed
    a.meta["config"] = "changed"
    b = load_case(str(first.path))
    assert _same_scenario(b, load_scenario(first.path)) and b.obs_range is not a.obs_range
    # the file replaced by another case (a new store in the same directory): read again
    save_scenario(load_scenario(second.path), first.path)
    assert _same_scenario(load_case(first.path), load_scenario(second.path))
    with pytest.raises(ScenarioError, match="missing file"):
        load_case(tmp_path / "nowhere" / "case1.npz")


def test_the_guarded_sut_is_fed_what_the_unguarded_one_is_and_keeps_a_step_of_its_own(tmp_path):
    from faultlab.runner.execution import _Guarded
    from faultlab.slam.protocol import run_slam
    from tests.runner.suts import TinySlam

    class Stepping(TinySlam):
        """A SUT whose step() does more than validate: the guard must call it, not update()."""

        def step(self, control, observations=None):
            self.stepped = getattr(self, "stepped", 0) + 1
            super().step(control, observations)

    exp = load_experiment(write_experiment(tmp_path / "e.toml", **one_case(n_steps=30)))
    (info,) = prepare_cases(exp, tmp_path)
    scenario = load_case(info.path)
    plain = run_slam(TinySlam(), scenario, rng=np.random.default_rng(5))
    guarded = run_slam(_Guarded(TinySlam(), deadline=float("inf")), scenario, rng=np.random.default_rng(5))
    stepping = Stepping()
    own = run_slam(_Guarded(stepping, deadline=float("inf")), scenario, rng=np.random.default_rng(5))
    for est in (guarded, own):
        assert np.array_equal(est.pose, plain.pose) and np.array_equal(est.landmarks, plain.landmarks)
    assert stepping.stepped == scenario.n_steps
