from faultlab.runner.experiment import parse_experiment
from faultlab.runner.jobs import JobKey, expand_jobs
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
