"""Power planning against seeded simulations of the same tests, brute force and monotonicity properties."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import norm
from statsmodels.stats.contingency_tables import mcnemar

from faultlab.errors import ConfigError
from faultlab.seeds import study_seed_sequence
from faultlab.inference.planning import (detectable_detection, detectable_score, detection_power, mcnemar_power,
                                     min_repetitions, mutants_for_score, plan_study, pool_for_detection,
                                     study_executions)


def _rng(*key) -> np.random.Generator:
    return np.random.default_rng(study_seed_sequence(20261126, "planning-test", *key))


def _brute_min_p(k: int, sides: int) -> float:
    """Smallest p of the exact sign-flip test on k positive differences, by enumerating all 2^k flips."""
    d = np.arange(1, k + 1, dtype=float)
    flips = np.array(list(itertools.product((-1.0, 1.0), repeat=k))) if k else np.ones((1, 0))
    stats = (flips * d).sum(axis=1)
    obs = d.sum()
    return float(np.mean(np.abs(stats) >= abs(obs)) if sides == 2 else np.mean(stats >= obs))


@pytest.mark.parametrize("n_cases", [1, 3, 5, 6, 20, 45, 51, 52])
@pytest.mark.parametrize("sides", [1, 2])
def test_min_repetitions_is_the_smallest_k_whose_enumerated_min_p_reaches_alpha_over_n(n_cases, sides):
    k = min_repetitions(n_cases, alpha=0.05, sides=sides)
    assert _brute_min_p(k, sides) <= 0.05 / n_cases
    assert k == 0 or _brute_min_p(k - 1, sides) > 0.05 / n_cases


def test_min_repetitions_refuses_a_bad_family():
    with pytest.raises(ConfigError):
        min_repetitions(0)
    with pytest.raises(ConfigError):
        min_repetitions(5, sides=3)


def _simulated_mcnemar_power(m, only_a, only_b, alpha, draws, rng) -> float:
    """Share of seeded trinomial samples in which statsmodels' exact McNemar test rejects."""
    counts = rng.multinomial(m, [only_a, only_b, 1 - only_a - only_b], size=draws)[:, :2]
    cache: dict = {}
    reject = 0
    for b, c in map(tuple, counts.tolist()):
        if (b, c) not in cache:
            cache[(b, c)] = mcnemar([[0, b], [c, 0]], exact=True).pvalue <= alpha
        reject += cache[(b, c)]
    return reject / draws


@pytest.mark.parametrize("m, only_a, only_b, alpha", [(150, 0.15, 0.05, 0.05 / 6), (246, 0.15, 0.05, 0.05 / 6),
                                                        (60, 0.20, 0.02, 0.05 / 3), (30, 0.3, 0.1, 0.05)])
def test_exact_mcnemar_power_matches_a_seeded_simulation_of_statsmodels_test(m, only_a, only_b, alpha):
    sim = _simulated_mcnemar_power(m, only_a, only_b, alpha, 10_000, _rng("mcnemar", m))
    assert abs(mcnemar_power(m, only_a, only_b, alpha=alpha) - sim) <= 0.02


def _simulated_detection_power(n, diff, centre, alpha, draws, rng) -> float:
    """Share of seeded pairs of pools in which the two-sided arcsine two-proportion z test rejects."""
    xa = rng.binomial(n, centre + diff / 2, size=draws) / n
    xb = rng.binomial(n, centre - diff / 2, size=draws) / n
    z = (2 * np.arcsin(np.sqrt(xa)) - 2 * np.arcsin(np.sqrt(xb))) / math.sqrt(2 / n)
    return float(np.mean(np.abs(z) >= norm.ppf(1 - alpha / 2)))


@pytest.mark.parametrize("n, diff, centre, alpha", [(150, 0.2, 0.5, 0.05 / 6), (100, 0.2, 0.5, 0.05 / 6),
                                                    (60, 0.3, 0.4, 0.05), (150, 0.15, 0.3, 0.05 / 3)])
def test_detection_power_matches_a_seeded_simulation_of_the_arcsine_test(n, diff, centre, alpha):
    sim = _simulated_detection_power(n, diff, centre, alpha, 20_000, _rng("detection", n))
    assert abs(detection_power(n, n, diff, centre=centre, alpha=alpha) - sim) <= 0.02


def test_planned_sizes_are_the_smallest_that_reach_the_power():
    a = 0.05 / 6
    n = pool_for_detection(0.2, alpha=a, power=0.8)
    assert detection_power(n, n, 0.2, alpha=a) >= 0.8 > detection_power(n - 1, n - 1, 0.2, alpha=a)
    m = mutants_for_score(0.1, reverse=0.05, alpha=a, power=0.8)
    assert mcnemar_power(m, 0.15, 0.05, alpha=a) >= 0.8 > mcnemar_power(m - 1, 0.15, 0.05, alpha=a)
    assert all(mcnemar_power(x, 0.15, 0.05, alpha=a) >= 0.8 for x in range(m, m + 30))


def test_detectable_differences_invert_the_power():
    a = 0.05 / 6
    d = detectable_detection(150, alpha=a, power=0.8)
    assert detection_power(150, 150, d + 1e-4, alpha=a) >= 0.8 > detection_power(150, 150, d - 1e-3, alpha=a)
    s = detectable_score(200, reverse=0.05, alpha=a, power=0.8)
    assert mcnemar_power(200, 0.05 + s, 0.05, alpha=a) >= 0.8 > mcnemar_power(200, 0.05 + s - 1e-3, 0.05, alpha=a)
    assert math.isinf(detectable_score(3, reverse=0.05, alpha=a))


@settings(max_examples=60, deadline=None)
@given(n=st.integers(2, 400), extra=st.integers(1, 100), diff=st.floats(0.02, 0.5), centre=st.floats(0.3, 0.7),
       alpha=st.sampled_from([0.05, 0.05 / 3, 0.05 / 6, 0.05 / 10]))
def test_more_cases_never_lower_detection_power(n, extra, diff, centre, alpha):
    diff = min(diff, 2 * min(centre, 1 - centre))
    assert detection_power(n + extra, n, diff, centre=centre, alpha=alpha) >= \
        detection_power(n, n, diff, centre=centre, alpha=alpha) - 1e-12
    assert detectable_detection(n + extra, centre=centre, alpha=alpha) <= \
        detectable_detection(n, centre=centre, alpha=alpha) + 1e-6


@settings(max_examples=60, deadline=None)
@given(m=st.integers(1, 300), extra=st.integers(1, 60), diff=st.floats(0.02, 0.4), reverse=st.floats(0.0, 0.2),
       alpha=st.sampled_from([0.05, 0.05 / 3, 0.05 / 6]))
def test_more_mutants_never_lower_mcnemar_power(m, extra, diff, reverse, alpha):
    assert mcnemar_power(m + extra, reverse + diff, reverse, alpha=alpha) >= \
        mcnemar_power(m, reverse + diff, reverse, alpha=alpha) - 1e-12


def test_executions_count_every_job():
    # strategies: every (strategy, pool case, variant, repetition)
    jobs = list(itertools.product(range(4), range(7), range(1 + 3 + 5), range(9)))
    assert study_executions("strategies", strategies=4, cases=7, faults=3, mutants=5, repetitions=9) == len(jobs)
    # mutation: every (suite kind, run, case, baseline or mutant, repetition)
    jobs = list(itertools.product(range(3), range(2), range(5), range(1 + 11), range(8)))
    assert study_executions("mutation", strategies=3, runs=2, cases=5, faults=0, mutants=11,
                            repetitions=8) == len(jobs)


def test_plan_meets_its_targets_and_the_fitting_scale_fits():
    plan = plan_study("strategies", strategies=4, faults=17, seconds_per_execution=4.0)
    a = 0.05 / 6
    assert plan.comparison_alpha == pytest.approx(a)
    n, m = plan.needed.cases, plan.needed.mutants
    assert detection_power(n, n, 0.2, alpha=a) >= 0.8 and mcnemar_power(m, 0.15, 0.05, alpha=a) >= 0.8
    assert plan.needed.repetitions == min_repetitions(20)
    assert not plan.fits and plan.fitting.cpu_hours <= 6.0
    assert plan.cluster_cores == math.ceil(plan.needed.cpu_hours / 3.0)
    # a cheap enough execution fits the needed scale itself
    cheap = plan_study("mutation", strategies=3, seconds_per_execution=0.1)
    assert cheap.fits and cheap.fitting == cheap.needed
    assert cheap.needed.repetitions == min_repetitions(5) and cheap.needed.cases == 5


def test_the_tabulated_scales_are_read_off_the_power_functions_at_the_plans_level():
    plan = plan_study("strategies", strategies=4, faults=17, seconds_per_execution=4.0)
    a = plan.comparison_alpha
    pools, scores, needed = plan.detection_by_pool(), plan.score_by_mutants(), plan.mutants_by_reverse()
    for n, pp in pools:   # the detectable difference has the plan's power, a smaller one has less
        assert detection_power(n, n, pp / 100, centre=plan.centre, alpha=a) == pytest.approx(plan.power, abs=1e-3)
    assert [pp for _, pp in pools] == sorted((pp for _, pp in pools), reverse=True)
    assert [pp for _, pp in scores] == sorted((pp for _, pp in scores), reverse=True)
    for r, m in needed:   # the smallest number of mutants with the power for the target
        only_b = r
        assert mcnemar_power(m, plan.target_score_pp / 100 + only_b, only_b, alpha=a) >= plan.power
    assert [m for _, m in needed] == sorted(m for _, m in needed)


def test_the_largest_fitting_scale_is_no_worse_than_any_other_fitting_scale():
    plan = plan_study("mutation", strategies=3, seconds_per_execution=1.0, budget_hours=1.0, cores=2)
    f = plan.fitting
    assert f.cpu_hours <= 2.0
    more = study_executions("mutation", strategies=3, cases=5, faults=0, mutants=f.mutants + 1,
                            repetitions=f.repetitions)
    assert more * 1.0 / 3600 > 2.0                               # one more mutant does not fit
    assert f.score_pp == pytest.approx(100 * detectable_score(f.mutants, reverse=0.05, alpha=0.05 / 3))


@settings(max_examples=15, deadline=None)
@given(target=st.floats(0.1, 0.4), smaller=st.floats(0.6, 0.95), alpha=st.sampled_from([0.05, 0.05 / 6]))
def test_smaller_targets_never_need_fewer_cases_or_mutants(target, smaller, alpha):
    assert pool_for_detection(target * smaller, alpha=alpha) >= pool_for_detection(target, alpha=alpha)
    assert mutants_for_score(target * smaller, alpha=alpha) >= mutants_for_score(target, alpha=alpha)


def test_plan_refuses_what_it_cannot_plan():
    with pytest.raises(ConfigError):
        plan_study("strategies", strategies=1, seconds_per_execution=1.0)
    with pytest.raises(ConfigError):
        plan_study("other", strategies=3, seconds_per_execution=1.0)
    with pytest.raises(ConfigError):
        plan_study("mutation", strategies=3, seconds_per_execution=0.0)


def test_a_files_scale_counts_every_pool_and_states_the_smallest_pools_power():
    from statsmodels.stats.power import NormalIndPower

    from faultlab.inference.planning import file_scale, plan_study

    plan = plan_study("strategies", strategies=5, faults=17, max_suite=22, seconds_per_execution=0.5)
    scale = file_scale(plan, pools=[16, 16, 20, 22, 16], mutants=10, repetitions=10, largest_suite=22)
    assert scale.executions == (16 + 16 + 20 + 22 + 16) * (1 + 17 + 10) * 10
    assert scale.cpu_hours == pytest.approx(scale.executions * 0.5 / 3600)
    # the stated difference: two pools of 16 at Holm's first step over 10 pairs detect it with 80 % power
    # (statsmodels' arcsine two-proportion power, two-sided, around 0.5)
    d = scale.detection_pp / 100
    h = 2 * math.asin(math.sqrt(0.5 + d / 2)) - 2 * math.asin(math.sqrt(0.5 - d / 2))
    power = NormalIndPower().power(effect_size=h, nobs1=16, alpha=0.05 / 10, ratio=1.0, alternative="two-sided")
    assert power == pytest.approx(0.8, abs=0.01)
    bigger = file_scale(plan, pools=[30, 40], mutants=10, repetitions=10, largest_suite=22)
    assert bigger.detection_pp < scale.detection_pp and bigger.cases == 30
    with pytest.raises(ConfigError, match="two or more pools"):
        file_scale(plan, pools=[16], mutants=10, repetitions=10, largest_suite=22)


def test_the_split_design_runs_faults_on_the_needed_pools_and_mutants_on_the_smallest():
    from faultlab.inference.planning import plan_study

    plan = plan_study("strategies", strategies=5, faults=17, max_suite=22, seconds_per_execution=0.02)
    need = plan.needed
    faults, mutants = plan.split
    k = need.repetitions
    # brute-force counts: every pool case of a half runs that half's variants and the baseline K times
    assert faults.executions == 5 * need.cases * (1 + 17) * k
    assert mutants.executions == 5 * 22 * (1 + need.mutants) * k
    assert faults.executions + mutants.executions < need.executions
    assert faults.detection_pp == need.detection_pp and mutants.score_pp == need.score_pp
    assert math.isinf(faults.score_pp) and mutants.detection_pp > need.detection_pp
    assert plan.split_fits == ((faults.cpu_hours + mutants.cpu_hours) <= plan.budget_hours * plan.cores)
    assert not plan.fits and plan.split_fits  # 13 CPU hours crossed, under 6 split at 0.02 s
    assert plan_study("strategies", strategies=5, faults=0, max_suite=22, seconds_per_execution=0.02).split is None
    assert plan_study("mutation", strategies=3, seconds_per_execution=0.02).split is None


def test_a_deterministic_slams_mutation_plan_judges_exactly_and_needs_the_mcnemar_mutants():
    from faultlab.inference.planning import mutation_file_scale

    plan = plan_study("mutation", strategies=2, suite_cases=10, exact=True, seconds_per_execution=0.5)
    need = plan.needed
    assert plan.exact and need.repetitions == 1 and plan.comparison_alpha == 0.05
    # the smallest number of mutants from which the simulated exact McNemar test keeps 80 % power
    assert need.mutants == mutants_for_score(0.10, reverse=0.05, alpha=0.05)
    assert _simulated_mcnemar_power(need.mutants, 0.15, 0.05, 0.05, 10_000, _rng("exact-plan")) >= 0.8 - 0.02
    assert need.executions == 2 * 10 * (1 + need.mutants)  # each case once per variant: no repetitions
    scale = mutation_file_scale(plan, mutants=need.mutants)
    assert scale.score_pp <= 10 and scale.repetitions == 1 and scale.executions == need.executions
    assert mutation_file_scale(plan, mutants=45).score_pp > 10
    sign_flip = plan_study("mutation", strategies=2, suite_cases=10, seconds_per_execution=0.5)
    assert sign_flip.needed.repetitions == min_repetitions(10) > 1
    with pytest.raises(ConfigError, match="mutation study only"):
        plan_study("strategies", strategies=2, exact=True, seconds_per_execution=0.5)
