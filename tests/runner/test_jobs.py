import pytest

from faultlab.errors import ConfigError
from faultlab.runner.experiment import parse_experiment
from faultlab.runner.jobs import JobBatch, JobKey, batch_jobs, expand_jobs
from faultlab.seeds import slam_seed
from tests.runner.suts import tiny_experiment


def test_expand_jobs_common_random_numbers_across_variants():
    exp = parse_experiment(tiny_experiment(variants=["baseline", "tests.runner.suts:BIAS",
                                                     "tests.runner.suts:IDENTITY"], repetitions=3))
    cases = [(1, "random", 1, "a.npz", 1.0), (1, "random", 2, "b.npz", 2.0), (2, "fixed", 1, "c.npz", 3.0)]
    jobs = expand_jobs(exp, cases)
    assert len(jobs) == len(cases) * 3 * 3
    assert len({j.key for j in jobs}) == len(jobs)
    by_case_rep: dict = {}
    for j in jobs:
        by_case_rep.setdefault((j.key.run, j.key.suite, j.key.case, j.key.rep), set()).add(j.seed)
        assert j.seed == slam_seed(exp.seed, j.key.run, j.key.suite, j.key.case, j.key.rep)
        assert j.timeout_s == exp.timeout_s and j.slam == exp.slam
    # one seed per (case, rep), shared by all variants; different reps get different seeds
    assert all(len(s) == 1 for s in by_case_rep.values())
    assert len({next(iter(s)) for s in by_case_rep.values()}) == len(by_case_rep)


def test_job_key_order_and_text():
    a, b = JobKey(1, "random", 1, "baseline", 0), JobKey(1, "random", 1, "baseline", 1)
    assert a < b and a.astuple() == (1, "random", 1, "baseline", 0)
    assert str(a) == "run 1 random case 1 baseline rep 0"


def test_the_replica_variant_gets_its_own_seeds():
    exp = parse_experiment(tiny_experiment(variants=["baseline", "baseline_replica"], repetitions=2))
    jobs = expand_jobs(exp, [(1, "random", 1, "a.npz", 1.0)])
    seeds = {(j.key.variant, j.key.rep): j.seed for j in jobs}
    assert seeds[("baseline_replica", 0)] == slam_seed(exp.seed, 1, "random", 1, 0, replica=True)
    assert len(set(seeds.values())) == 4


def _jobs(repetitions=3):
    exp = parse_experiment(tiny_experiment(variants=["baseline", "tests.runner.suts:BIAS"], repetitions=repetitions))
    return expand_jobs(exp, [(1, "random", 1, "a.npz", 1.0), (1, "random", 2, "b.npz", 2.5)])


def test_batch_jobs_groups_the_repetitions_of_a_case_and_variant():
    jobs = _jobs(repetitions=3)
    batches = batch_jobs(jobs)
    assert [len(b) for b in batches] == [3, 3, 3, 3]
    assert [b.jobs for b in batches] == [tuple(jobs[i:i + 3]) for i in range(0, 12, 3)]  # order kept
    for b in batches:
        assert len({(k.run, k.suite, k.case, k.variant) for k in b.keys}) == 1
        assert [k.rep for k in b.keys] == [0, 1, 2]
        assert b.cost == pytest.approx(3 * b.jobs[0].cost) and b.timeout_s == pytest.approx(3 * b.jobs[0].timeout_s)
    assert str(batches[1]) == "run 1 random case 1 tests.runner.suts:BIAS reps 0,1,2"
    # size limits, and one job per batch
    assert [len(b) for b in batch_jobs(jobs, size=2)] == [2, 1] * 4
    assert [b.jobs for b in batch_jobs(jobs, size=1)] == [(j,) for j in jobs]
    # only the jobs given (e.g. those missing from a store) are batched
    missing = [j for j in jobs if j.key.rep != 1]
    assert [[k.rep for k in b.keys] for b in batch_jobs(missing)] == [[0, 2]] * 4


def test_batch_jobs_refuses_bad_sizes_and_mixed_batches():
    jobs = _jobs()
    for size in (0, -1, 1.5, True):
        with pytest.raises(ConfigError, match="batch size"):
            batch_jobs(jobs, size=size)
    with pytest.raises(ConfigError, match="one case and variant"):
        JobBatch((jobs[0], jobs[3]))
    with pytest.raises(ConfigError, match="at least one job"):
        JobBatch(())
