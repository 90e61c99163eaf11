import hashlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from faultlab.runner.experiment import parse_experiment
from faultlab.runner.jobs import JobKey, case_seed, expand_jobs, slam_seed, stable_code, suite_seed_sequence
from tests.runner.suts import tiny_experiment

ROOT = Path(__file__).resolve().parents[2]


def test_stable_code_is_sha256_prefix():
    for name in ("systematic", "random", "fixed", "x"):
        assert stable_code(name) == int(hashlib.sha256(name.encode()).hexdigest()[:8], 16)


def test_seeds_are_distinct_per_identity_and_fit_int64():
    seeds = {}
    for run in (1, 2):
        for suite in ("systematic", "random", "fixed"):
            for case in (1, 2, 3):
                seeds[("case", run, suite, case)] = case_seed(7, run, suite, case)
                for rep in (0, 1):
                    seeds[("slam", run, suite, case, rep)] = slam_seed(7, run, suite, case, rep)
    values = list(seeds.values())
    assert len(set(values)) == len(values)
    assert all(0 <= v < 2**63 for v in values)
    # another root seed changes every seed
    assert case_seed(8, 1, "random", 1) != case_seed(7, 1, "random", 1)


def test_seeds_follow_seedsequence_spawn_keys():
    # independent reference: the documented SeedSequence recipe, written out by hand
    ss = np.random.SeedSequence(entropy=7, spawn_key=(3, 2, stable_code("fixed"), 4, 1))
    assert slam_seed(7, 2, "fixed", 4, 1) == int(ss.generate_state(1, np.uint64)[0]) >> 1
    a = np.random.default_rng(suite_seed_sequence(7, 1, "random")).random(3)
    b = np.random.default_rng(np.random.SeedSequence(7, spawn_key=(1, 1, stable_code("random")))).random(3)
    np.testing.assert_array_equal(a, b)


def test_seeds_do_not_depend_on_the_interpreter_hash_seed():
    code = ("from faultlab.runner.jobs import slam_seed, case_seed;"
            "print(slam_seed(3, 1, 'random', 2, 0), case_seed(3, 2, 'fixed', 1))")
    outs = set()
    for hs in ("0", "12345"):
        env = dict(os.environ, PYTHONHASHSEED=hs)
        outs.add(subprocess.run([sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True,
                                text=True, check=True).stdout)
    assert outs == {f"{slam_seed(3, 1, 'random', 2, 0)} {case_seed(3, 2, 'fixed', 1)}\n"}


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
