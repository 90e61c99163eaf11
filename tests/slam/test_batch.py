"""Batched repetitions of the reference FastSLAM: every repetition bit-identical to a single run.

``FastSlam.reset_batch`` runs K repetitions (each with its own particles, weights, resampling and
random streams) as one filter of K N particles.  The independent reference here is the
single-filter run of each repetition with the same seed (``FastSlam.reset`` + the same steps),
compared bit for bit: the final particle set (poses, weights, every landmark mean and covariance),
the estimate, the number of resamplings, or the exception that ended the run.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from faultlab.errors import SlamInputError, SlamOutputError
from faultlab.faults import Fault, builtin_faults
from faultlab.faults.check import check_scenario, estimates_identical
from faultlab.slam import (
    REFERENCE_STEPS,
    DeadReckoning,
    FastSlam,
    FastSlamConfig,
    Observations,
    run_slam,
    run_slam_batch,
)
from faultlab.slam import units as _units
from faultlab.slam.fastslam import BatchUnsupported
from faultlab.slam.contract import FILTER_UNITS, PARTICLE_UNITS, STREAM_UNITS, filter_wise
from faultlab.slam.profiles import get_profile

N = 24
CFG = FastSlamConfig(particles=N)
SEEDS = (11, 5, 902, 3, 47)


@pytest.fixture(scope="module")
def scenario():
    """Fixed-suite values, 16 m^2 map, +2 pi rotation error, 100 idle steps, then 60 active steps."""
    return check_scenario(seed=3, n_steps=60)


def drive(slam, sc, rngs=None, rng=None):
    """Run ``slam`` through ``sc``: a batch if ``rngs`` is given, else a single filter."""
    if rngs is not None:
        slam.reset_batch(sc.start_pose, rngs=rngs)
    else:
        slam.reset(sc.start_pose, rng=rng)
    for t in range(sc.n_steps):
        a, b = sc.obs_offsets[t], sc.obs_offsets[t + 1]
        slam.step(sc.controls[t], Observations(sc.obs_range[a:b], sc.obs_bearing[a:b], sc.obs_ids[a:b]))
    return slam


@dataclasses.dataclass
class Outcome:
    """The end of one repetition: its particles, estimate and resamplings, or its exception."""

    particles: object = None
    estimate: object = None
    n_resamples: int = -1
    error: BaseException | None = None


def single(make, sc, seed) -> Outcome:
    slam = make()
    try:
        with np.errstate(all="ignore"):
            drive(slam, sc, rng=np.random.default_rng(seed))
            return Outcome(slam.particles(), slam.estimate(), slam.n_resamples)
    except Exception as exc:
        return Outcome(error=exc)


def batched(make, sc, seeds) -> list[Outcome]:
    slam = make()
    with np.errstate(all="ignore"):
        drive(slam, sc, rngs=[np.random.default_rng(s) for s in seeds])
        ests = slam.estimates()
    out = []
    for rep, est in enumerate(ests):
        if isinstance(est, BaseException):
            out.append(Outcome(error=est))
        else:
            out.append(Outcome(slam.particles(rep), est, slam._n_resampled[rep]))
    return out


def assert_same(a: Outcome, b: Outcome, what: str) -> None:
    if a.error is not None or b.error is not None:
        assert type(a.error) is type(b.error) and str(a.error) == str(b.error), \
            f"{what}: {a.error!r} != {b.error!r}"
        return
    assert a.n_resamples == b.n_resamples, what
    assert estimates_identical(a.estimate, b.estimate), what
    np.testing.assert_array_equal(a.estimate.trajectory, b.estimate.trajectory, err_msg=f"{what}: trajectory")
    for field in ("poses", "weights", "landmark_ids", "means", "covariances"):
        np.testing.assert_array_equal(getattr(a.particles, field), getattr(b.particles, field),
                                      err_msg=f"{what}: {field}")


def check_batches(make, sc, *, ks=(1, 3, 5)) -> list[Outcome]:
    """Every repetition of batches of size ``ks`` equals its single run; returns the single runs."""
    singles = {s: single(make, sc, s) for s in SEEDS}
    for k in ks:
        seeds = SEEDS[:k] if k != 3 else (SEEDS[3], SEEDS[0], SEEDS[2])  # order is free
        for rep, (seed, got) in enumerate(zip(seeds, batched(make, sc, seeds))):
            assert_same(singles[seed], got, f"K={k}, rep {rep} (seed {seed})")
    return list(singles.values())


# --------------------------------------------------------------------------- the contract


def test_every_unit_is_either_a_particle_unit_or_a_filter_unit():
    assert set(PARTICLE_UNITS) | set(FILTER_UNITS) == set(REFERENCE_STEPS.unit_names())
    assert not set(PARTICLE_UNITS) & set(FILTER_UNITS)
    assert set(STREAM_UNITS) <= set(FILTER_UNITS)  # random units always see one filter and its own stream


def test_reference_repetitions_are_bit_identical_to_single_runs(scenario):
    singles = check_batches(lambda: FastSlam(CFG), scenario)
    assert all(o.error is None and o.n_resamples > 0 for o in singles)  # resampling happened
    assert not np.array_equal(singles[0].particles.poses, singles[1].particles.poses)  # seeds matter


@pytest.mark.parametrize("fault", list(builtin_faults().values()), ids=lambda f: f.name)
def test_every_builtin_fault_batched_is_bit_identical_to_single_runs(scenario, fault):
    check_batches(lambda: fault.apply(FastSlam(CFG)), scenario)


@pytest.mark.parametrize("profile", ["paper", "paper_no_aliasing"])
def test_the_papers_filter_batched_is_bit_identical(scenario, profile):
    """Linear weights reset when all underflow (per filter) and sequential sharers (per filter)."""
    p = get_profile(profile)
    config = dataclasses.replace(p.config, particles=N)
    check_batches(lambda: FastSlam(config, steps=p.steps), scenario, ks=(3,))


class OneFilterPerBlock(FastSlam):
    block_pairs = 1


class TwoFiltersPerBlock(FastSlam):
    block_pairs = 2 * N * 31  # the scenario sees about 31 landmarks per active step


@pytest.mark.parametrize("slam_type", [OneFilterPerBlock, TwoFiltersPerBlock])
@pytest.mark.parametrize("variant", ["baseline", "shallow_copy_resampling", "new_landmark_near_zero"])
def test_blocks_of_filters_give_the_same_repetitions(scenario, slam_type, variant):
    fault = builtin_faults().get(variant)

    def make():
        slam = slam_type(CFG)
        return slam if fault is None else fault.apply(slam)

    check_batches(make, scenario, ks=(5,))


def test_repetitions_of_a_batch_share_no_random_stream(scenario):
    slam = drive(FastSlam(CFG), scenario, rngs=[np.random.default_rng(s) for s in (1, 1, 2)])
    a, b, c = (slam.particles(r) for r in range(3))
    np.testing.assert_array_equal(a.poses, b.poses)  # the same seed twice: the same repetition
    assert not np.array_equal(a.poses, c.poses)


# --------------------------------------------------------------------------- failures


def _unlucky_resample(original):
    def resample(w, n_eff, empty, rng, config):
        idx = original(w, n_eff, empty, rng, config)
        if idx is not None and rng.random() < 0.03:
            raise RuntimeError("unlucky draw")
        return idx

    return resample


def _nan_controls(original):
    def sample_controls(u, n, rng, config):
        controls = original(u, n, rng, config)
        if rng.random() < 0.02:
            controls = controls * np.nan  # NaN poses, then NaN weights: the non-finite weight check stops it
        return controls

    return sample_controls


UNLUCKY = Fault(name="test/unlucky", step="resample", description="raises on an unlucky draw",
                rationale="test", origin="test", replacement=_unlucky_resample)
NAN_WEIGHTS = Fault(name="test/nan_weights", step="sample_controls", description="NaN controls on an unlucky draw",
                    rationale="test", origin="test", replacement=_nan_controls)


@pytest.mark.parametrize("fault", [UNLUCKY, NAN_WEIGHTS], ids=lambda f: f.name)
def test_a_failure_ends_its_own_repetition_only(scenario, fault):
    singles = check_batches(lambda: fault.apply(FastSlam(CFG)), scenario, ks=(5,))
    errors = [o.error for o in singles]
    # the check is meaningful: some repetitions fail on their own, others run to the end
    assert any(e is None for e in errors) and any(e is not None for e in errors)
    expected = RuntimeError if fault is UNLUCKY else SlamOutputError
    assert all(isinstance(e, expected) for e in errors if e is not None)


def _raise_if_far(original):
    def predict_measurement(poses, mu):
        if np.any(np.asarray(poses)[:, 0] > 0.4):
            raise FloatingPointError("far from the start")
        return original(poses, mu)

    return predict_measurement


def test_an_exception_in_a_unit_that_sees_all_filters_ends_the_batch(scenario):
    fault = Fault(name="test/far", step="predict_measurement", description="raises far from the start",
                  rationale="test", origin="test", replacement=_raise_if_far)
    with pytest.raises(FloatingPointError, match="far from the start"):
        with np.errstate(all="ignore"):
            run_slam_batch(fault.apply(FastSlam(CFG)), scenario, rngs=[np.random.default_rng(s) for s in SEEDS])


def test_a_unit_output_the_batch_cannot_split_is_refused(scenario):
    def combine_weights(logw, loglik, known):
        return _units.combine_weights(logw, loglik, known)[None, :]  # (1, N): fine alone, ambiguous stacked

    steps = dataclasses.replace(REFERENCE_STEPS, combine_weights=combine_weights)
    with pytest.raises(BatchUnsupported, match="combine_weights returned shape"):
        run_slam_batch(FastSlam(CFG, steps=steps), scenario, rngs=[np.random.default_rng(s) for s in SEEDS[:2]])


# --------------------------------------------------------------------------- the filter_wise fallback


def _scaled_by_the_largest(ll):
    """Log likelihoods divided by the largest magnitude over the particles: looks across particles."""
    return ll / np.abs(ll).max(axis=0)


def _coupled(original):
    def log_likelihood(nu, S):
        return _scaled_by_the_largest(np.asarray(original(nu, S)))

    return log_likelihood


def _coupled_declared(original):
    return filter_wise(_coupled(original))


def test_a_unit_that_looks_across_particles_needs_filter_wise(scenario):
    coupled = Fault(name="test/coupled", step="log_likelihood", description="max over particles",
                    rationale="test", origin="test", replacement=_coupled)
    declared = dataclasses.replace(coupled, name="test/coupled_declared", replacement=_coupled_declared)
    seeds = SEEDS[:3]
    singles = [single(lambda: coupled.apply(FastSlam(CFG)), scenario, s) for s in seeds]
    # undeclared, the batch's unit sees all filters' particles: the repetitions are not their single runs
    with np.errstate(all="ignore"):
        wrong = run_slam_batch(coupled.apply(FastSlam(CFG)), scenario, rngs=[np.random.default_rng(s) for s in seeds])
    assert not all(estimates_identical(o.estimate, w) for o, w in zip(singles, wrong))
    # declared filter-wise, it sees one filter at a time (with one or several filters per block)
    for slam_type in (FastSlam, TwoFiltersPerBlock):
        got = batched(lambda: declared.apply(slam_type(CFG)), scenario, seeds)
        for rep, (a, b) in enumerate(zip(singles, got)):
            assert_same(a, b, f"{slam_type.__name__} rep {rep}")
    assert all(o.error is None for o in singles)


# --------------------------------------------------------------------------- the interface


def test_batch_interface_errors(scenario):
    slam = FastSlam(CFG)
    with pytest.raises(SlamInputError, match="rngs is empty"):
        slam.reset_batch(scenario.start_pose, rngs=[])
    with pytest.raises(SlamInputError, match=r"rngs\[1\] must be a numpy.random.Generator"):
        slam.reset_batch(scenario.start_pose, rngs=[np.random.default_rng(0), 7])
    with pytest.raises(SlamInputError, match="sequence of numpy.random.Generator"):
        slam.reset_batch(scenario.start_pose, rngs=3)
    with pytest.raises(SlamInputError, match="start pose"):
        slam.reset_batch([0.0, np.nan, 0.0], rngs=[np.random.default_rng(0)])
    slam.reset_batch(scenario.start_pose, rngs=[np.random.default_rng(0), np.random.default_rng(1)])
    with pytest.raises(SlamInputError, match="use estimates"):
        slam.estimate()
    with pytest.raises(SlamInputError, match="no repetition 2"):
        slam.particles(2)
    assert len(slam.estimates()) == 2
    with pytest.raises(SlamInputError, match="does not run repetitions in a batch"):
        run_slam_batch(DeadReckoning(), scenario, rngs=[np.random.default_rng(0)])
    assert FastSlam.supports_batch and not DeadReckoning.supports_batch


def test_run_slam_batch_validates_each_estimate_like_run_slam(scenario):
    def extract_map(state):
        ids, xy = _units.extract_map(state)
        if state.poses[:, 0].mean() < -1.45:  # a condition of this filter's particles only
            xy = xy.copy()
            xy[0] = np.nan
        return ids, xy

    slam_steps = dataclasses.replace(REFERENCE_STEPS, extract_map=extract_map)
    outs = []
    for s in SEEDS:
        try:
            outs.append(run_slam(FastSlam(CFG, steps=slam_steps), scenario, rng=np.random.default_rng(s)))
        except SlamOutputError as exc:
            outs.append(exc)
    got = run_slam_batch(FastSlam(CFG, steps=slam_steps), scenario, rngs=[np.random.default_rng(s) for s in SEEDS])
    for a, b in zip(outs, got):
        if isinstance(a, BaseException):
            assert type(b) is type(a) and str(b) == str(a)
        else:
            assert estimates_identical(a, b)
    assert any(isinstance(o, SlamOutputError) for o in outs) and any(not isinstance(o, Exception) for o in outs)


# --------------------------------------------------------------------------- automatic mutants


def _outcomes_equal(a: Outcome, b: Outcome) -> bool:
    try:
        assert_same(a, b, "")
    except AssertionError:
        return False
    return True


@pytest.mark.slow
def test_a_sample_of_live_mutants_batched_is_bit_identical_to_single_runs(scenario):
    """30 live mutants of the reference (faultlab.mutation), K = 3: each repetition equals its single run.

    A mutant whose single runs are not reproducible (e.g. it reads a work array it no longer fills,
    i.e. uninitialised memory) is not a batching difference; it is recognised by running every single
    run twice, with other allocations in between, and once more built against poisoned numpy (work
    arrays NaN-filled, as the screening builds it), and left out of the comparison.
    """
    import random

    from faultlab.mutation import mutant_catalogue, mutant_fault
    from faultlab.mutation.source import unit_source
    from faultlab.slam import FastSlamSteps

    def poisoned(mutant):
        source = unit_source(mutant.unit, getattr(FastSlamSteps(), mutant.unit), FastSlamSteps)
        unit = source.build({mutant.function: mutant.mutated_source}, poison=True)

        def make():
            slam = FastSlam(CFG)
            return slam.with_steps(dataclasses.replace(slam.steps, **{mutant.unit: unit}))

        return make

    live = list(mutant_catalogue("fastslam", cache=False).report.live())
    sample = random.Random(0).sample(live, 30)
    seeds = SEEDS[:3]
    compared = identical = rerun_alone = 0
    differing = []
    for mutant in sample:
        fault = mutant_fault(mutant, FastSlamSteps)

        def make():
            return fault.apply(FastSlam(CFG))

        first = [single(make, scenario, s) for s in seeds]
        np.ones((4096, 64)) @ np.ones((64, 64))  # other allocations in between
        second = [single(make, scenario, s) for s in seeds]
        third = [single(poisoned(mutant), scenario, s) for s in seeds]
        if not all(_outcomes_equal(a, b) and _outcomes_equal(a, c) for a, b, c in zip(first, second, third)):
            continue  # not reproducible on its own: it reads memory it never wrote
        compared += 1
        try:
            got = batched(make, scenario, seeds)
        except Exception:
            # an exception no repetition can be blamed for: the runner reruns the repetitions alone,
            # which gives the single runs by construction; it must come from a run that fails alone too
            assert all(o.error is not None for o in first), mutant.id
            rerun_alone += 1
            continue
        if all(_outcomes_equal(a, b) for a, b in zip(first, got)):
            identical += 1
            continue
        # a batch that differs: a batching difference only if the batch itself is reproducible (a
        # mutant may read a work array it never fills, whose content depends on earlier allocations)
        np.ones((4096, 64)) @ np.ones((64, 64))
        again = batched(make, scenario, seeds)
        if not all(_outcomes_equal(a, b) for a, b in zip(got, again)):
            compared -= 1
            continue
        differing.append(mutant.id)
    assert compared >= 25
    assert identical + rerun_alone == compared, differing
    assert identical >= compared // 2
