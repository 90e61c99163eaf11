"""Compiled twins: bit-identical to the numpy reference units, alone, fused and inside the filter.

The independent reference is always the numpy unit of :mod:`faultlab.slam.units` (the readable
contract) or the numpy filter (``FAULTLAB_JIT=0``); results are compared bit for bit (the sign of
zero included, NaN equal to NaN).
"""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from faultlab.faults import builtin_faults
from faultlab.faults.check import CheckStatus, check_faults, check_scenario, estimates_identical
from faultlab.mutation.examples import unit_examples
from faultlab.mutation.mutant import generate_mutants, mutant_fault
from faultlab.mutation.outcome import MutantOutcome
from faultlab.mutation.screening import screen_mutants
from faultlab.slam import (REFERENCE_STEPS, EkfSlam, FastSlam, FastSlam2, FastSlamConfig, FastSlamUnknown, run_slam,
                           run_slam_batch)
from faultlab.slam import twins
from faultlab.slam import paperunits as PU
from faultlab.slam import sharing
from faultlab.slam import units as U
from faultlab.slam.fastslam import FastSlamSteps
from faultlab.slam.profiles import get_profile

pytestmark = pytest.mark.skipif(not twins.JIT_ENABLED, reason="compiled twins turned off (FAULTLAB_JIT=0)")


def bits(a) -> np.ndarray:
    """The IEEE bit patterns of ``a`` (all NaNs mapped to one pattern)."""
    a = np.array(a, dtype=np.float64)
    a[np.isnan(a)] = np.nan
    return a.view(np.int64)


def same_bits(a, b) -> bool:
    return np.shape(a) == np.shape(b) and np.array_equal(bits(a), bits(b))


# values: ordinary magnitudes, tiny and huge ones, signed zeros and non-finite values
VALUES = st.one_of(st.floats(-1e3, 1e3), st.floats(-1e-150, 1e-150), st.floats(-1e150, 1e150),
                   st.sampled_from([0.0, -0.0, np.inf, -np.inf, np.nan, np.pi, -np.pi]))
SHAPES = st.tuples(st.integers(1, 6), st.integers(0, 4))


@st.composite
def pair_arrays(draw, tail: tuple[int, ...], shape=None, elements=VALUES):
    """An (N, k) + tail float array, in C order or in the filter's component-major layout."""
    n, k = shape if shape is not None else draw(SHAPES)
    a = draw(arrays(np.float64, (n, k) + tail, elements=elements))
    if draw(st.booleans()):  # component-major, particle-fastest (a transposed view)
        perm = tuple(range(2, a.ndim)) + (1, 0)
        a = np.ascontiguousarray(a.transpose(perm)).transpose(tuple(np.argsort(perm)))
    return a


def symmetric(a: np.ndarray) -> np.ndarray:
    a = np.array(a)
    a[..., 1, 0] = a[..., 0, 1]
    return a


@st.composite
def problems(draw):
    """Inputs of one correction: poses (N, 3), mu (N, k, 2), symmetric P (N, k, 2, 2), z (k, 2), Q (2, 2)."""
    shape = draw(SHAPES)
    n, k = shape
    poses = draw(arrays(np.float64, (n, 3), elements=VALUES))
    mu = draw(pair_arrays((2,), shape))
    P = symmetric(draw(pair_arrays((2, 2), shape)))
    z = draw(arrays(np.float64, (k, 2), elements=VALUES))
    q01 = draw(st.sampled_from([0.0, 0.0, 1e-3, -0.02]))
    Q = np.array([[draw(st.floats(1e-6, 10.0)), q01], [q01, draw(st.floats(1e-6, 10.0))]])
    return poses, mu, P, z, Q


def quiet():
    return np.errstate(all="ignore")


@settings(max_examples=150, deadline=None)
@given(problems())
def test_every_twin_is_bit_identical_to_its_unit(problem):
    poses, mu, P, z, Q = problem
    with quiet():
        zhat, H = U.predict_measurement(poses, mu)
        t_zhat, t_H = twins.predict_measurement(poses, mu)
        assert same_bits(zhat, t_zhat) and same_bits(H, t_H)
        nu = U.innovation(z, zhat, wrap=U.wrap_bearing)
        assert same_bits(nu, twins.innovation(z, zhat, wrap=U.wrap_bearing))
        S = U.innovation_covariance(H, P, Q)
        assert same_bits(S, twins.innovation_covariance(H, P, Q))
        ll = U.log_likelihood(nu, S)
        assert same_bits(ll, twins.log_likelihood(nu, S))
        m1, P1 = U.ekf_update(mu, P, H, S, nu)
        t_m1, t_P1 = twins.ekf_update(mu, P, H, S, nu)
        assert same_bits(m1, t_m1) and same_bits(P1, t_P1)
        # the same inputs in C order (a replacement unit may return ordinary arrays)
        C = np.ascontiguousarray
        assert same_bits(nu, twins.innovation(z, C(zhat), wrap=U.wrap_bearing))
        assert same_bits(S, twins.innovation_covariance(C(H), C(P), Q))
        assert same_bits(ll, twins.log_likelihood(C(nu), C(S)))
        for got, want in zip(twins.ekf_update(C(mu), C(P), C(H), C(S), C(nu)), (m1, P1)):
            assert same_bits(got, want)
        # the paper's filter's units
        for got, want in zip(twins.predict_measurement_wrapped(poses, mu), PU.predict_measurement_wrapped(poses, mu)):
            assert same_bits(got, want)
        assert same_bits(PU.log_likelihood_wrapped(nu, S), twins.log_likelihood_wrapped(nu, S))


@settings(max_examples=150, deadline=None)
@given(problems())
def test_the_fused_correction_is_the_units_in_sequence(problem):
    poses, mu, P, z, Q = problem
    with quiet():
        zhat, H = U.predict_measurement(poses, mu)
        nu = U.innovation(z, zhat, wrap=U.wrap_bearing)
        S = U.innovation_covariance(H, P, Q)
        ll = U.log_likelihood(nu, S)
        m1, P1 = U.ekf_update(mu, P, H, S, nu)
        mb = np.ascontiguousarray(mu.transpose(2, 1, 0))
        pb = np.ascontiguousarray(P.transpose(2, 3, 1, 0))
        t_ll, t_mb, t_pb = twins.correct_pairs(poses, z, mb, pb, Q)
    assert same_bits(ll, t_ll)
    assert same_bits(m1, t_mb.transpose(2, 1, 0))
    assert same_bits(P1, t_pb.transpose(3, 2, 0, 1))


@settings(max_examples=150, deadline=None)
@given(problems(), st.data())
def test_the_sharer_order_correction_is_the_numpy_loop(problem, data):
    """The compiled sharer-order correction against faultlab.slam.sharing's loop over the numpy
    units: shared rows (any owners), new and known landmarks, extreme values."""
    poses, mu, P, z, Q = problem
    n, k = mu.shape[:2]
    owner = np.array(data.draw(st.lists(st.integers(0, max(0, n - 1)), min_size=n, max_size=n)), dtype=np.intp)
    seen = np.array(data.draw(st.lists(st.booleans(), min_size=k, max_size=k)), dtype=bool)
    logw = np.array(data.draw(st.lists(st.floats(-50.0, 0.0), min_size=n, max_size=n)))
    with quiet():
        want = sharing.correct_in_sharer_order(REFERENCE_STEPS, logw, owner, poses, z, seen, mu, P, Q)
        got = twins.correct_in_sharer_order(twins.twinned(REFERENCE_STEPS), logw, owner, poses, z, seen, mu, P, Q)
    for g, w in zip(got, want):
        assert same_bits(g, w)


def test_the_sharer_order_twin_runs_the_numpy_loop_for_other_units():
    """With a replaced correction unit the twin is the numpy loop with that unit (called per rank)."""
    calls = []

    def counting(H, P, Q):
        calls.append(H.shape[0])
        return U.innovation_covariance(H, P, Q)

    steps = dataclasses.replace(REFERENCE_STEPS, innovation_covariance=counting)
    rng = np.random.default_rng(4)
    n, k = 5, 3
    poses = rng.normal(size=(n, 3))
    mu = rng.normal(size=(n, k, 2)) + 3.0
    P = np.broadcast_to(np.eye(2) * 0.1, (n, k, 2, 2)).copy()
    z = np.column_stack([rng.uniform(1, 2, k), rng.uniform(-1, 1, k)])
    owner = np.array([0, 0, 0, 3, 3])
    args = (np.full(n, -np.log(n)), owner, poses, z, np.ones(k, dtype=bool), mu, P, np.diag([0.1, 0.01]))
    got = twins.correct_in_sharer_order(steps, *args)
    assert calls == [2, 2, 1]  # one call per rank: two groups, then two, then the larger group's third
    for g, w in zip(got, sharing.correct_in_sharer_order(steps, *args)):
        assert same_bits(g, w)


def test_twins_hand_other_inputs_to_the_numpy_unit():
    """A wrap other than the reference, broadcast or integer inputs: the unit's own result."""
    rng = np.random.default_rng(4)
    z, zhat = rng.normal(size=(3, 2)), rng.normal(size=(5, 3, 2)) * 10
    no_wrap = lambda a: a  # noqa: E731
    np.testing.assert_array_equal(twins.innovation(z, zhat, wrap=no_wrap), U.innovation(z, zhat, wrap=no_wrap))
    assert not np.array_equal(twins.innovation(z, zhat, wrap=no_wrap), U.innovation(z, zhat, wrap=U.wrap_bearing))
    mu_int = rng.integers(-5, 5, size=(5, 3, 2))
    poses = rng.normal(size=(5, 3))
    with quiet():
        for got, want in zip(twins.predict_measurement(poses, mu_int), U.predict_measurement(poses, mu_int)):
            assert same_bits(got, want)


def test_twinned_swaps_reference_units_only():
    fault = lambda *a, **kw: U.ekf_update(*a, **kw)  # noqa: E731
    steps = dataclasses.replace(REFERENCE_STEPS, ekf_update=fault)
    run = twins.twinned(steps)
    assert run.ekf_update is fault
    assert run.predict_measurement is twins.predict_measurement
    assert run.combine_weights is U.combine_weights  # no twin
    assert run.motion_model is twins.motion_model
    assert twins.fused(REFERENCE_STEPS) and twins.fused(twins.twinned(REFERENCE_STEPS))
    assert not twins.fused(steps)
    assert not twins.fused(dataclasses.replace(REFERENCE_STEPS, wrap_bearing=lambda a: a))


@dataclasses.dataclass(frozen=True)
class _Noise:
    std_v: float
    std_omega: float


@settings(max_examples=150, deadline=None)
@given(st.integers(1, 6), arrays(np.float64, 2, elements=VALUES), st.floats(0.0, 10.0), st.floats(0.0, 1.0),
       st.integers(0, 2 ** 32 - 1))
def test_the_prediction_twins_are_bit_identical_to_their_units(n, u, std_v, std_omega, seed):
    config = _Noise(std_v, std_omega)
    rng_a, rng_b = np.random.default_rng(seed), np.random.default_rng(seed)
    with quiet():
        want = U.sample_controls(u, n, rng_a, config)
        got = twins.sample_controls(u, n, rng_b, config)
        assert same_bits(got, want)
        assert rng_a.random() == rng_b.random()  # the same draws were consumed
        poses = np.random.default_rng(seed).normal(size=(n, 3)) * np.array([10.0, 10.0, 4.0])
        poses[0] = u[0], u[1], u[0] * u[1]  # special values (signed zeros, inf, nan) in the poses too
        for controls in (want, np.broadcast_to(u, (n, 2))):
            assert same_bits(twins.motion_model(poses, controls, wrap=U.wrap_heading),
                             U.motion_model(poses, controls, wrap=U.wrap_heading))
        no_wrap = lambda a: a  # noqa: E731  another wrap: the unit's own result
        assert same_bits(twins.motion_model(poses, want, wrap=no_wrap), U.motion_model(poses, want, wrap=no_wrap))


@dataclasses.dataclass(frozen=True)
class _Ratio:
    resample_ratio: float


WEIGHTS = st.one_of(st.floats(0.0, 1.0), st.floats(0.0, 1e-300), st.sampled_from([0.0, 1e-320, 0.5, 1.0]))


@settings(max_examples=200, deadline=None)
@given(arrays(np.float64, st.integers(1, 40), elements=WEIGHTS), st.booleans(), st.booleans(),
       st.integers(0, 2 ** 32 - 1))
def test_the_resampling_twin_draws_and_picks_as_the_unit(w, normalise, empty, seed):
    if normalise and w.sum() > 0:
        w = w / w.sum()
    config = _Ratio(resample_ratio=1.5)
    n_eff = float(len(w)) / 2.0  # below N / 1.5: resample unless empty
    rng_a, rng_b = np.random.default_rng(seed), np.random.default_rng(seed)
    want = U.resample(w, n_eff, empty, rng_a, config)
    got = twins.resample(w, n_eff, empty, rng_b, config)
    if want is None:
        assert got is None
    else:
        assert got.dtype == want.dtype and np.array_equal(got, want)
    assert rng_a.random() == rng_b.random()  # the same draws were consumed


@settings(max_examples=150, deadline=None)
@given(st.integers(1, 6), arrays(np.float64, 2, elements=VALUES), st.floats(0.0, 10.0), st.floats(0.0, 1.0),
       st.booleans(), st.integers(0, 2 ** 32 - 1))
def test_the_fused_prediction_is_sample_controls_then_motion_model(n, u, std_v, std_omega, empty, seed):
    config = _Noise(std_v, std_omega)
    poses = np.random.default_rng(seed).normal(size=(n, 3)) * np.array([10.0, 10.0, 4.0])
    rng_a, rng_b = np.random.default_rng(seed), np.random.default_rng(seed)
    with quiet():
        poses[0] = u[0], u[1], u[0] * u[1]
        controls = np.broadcast_to(u, (n, 2)) if empty else U.sample_controls(u, n, rng_a, config)
        want = U.motion_model(poses, controls, wrap=U.wrap_heading)
        got = twins.predict_poses(poses, u, None if empty else rng_b.standard_normal((n, 2)), config)
    assert same_bits(got, want)
    assert rng_a.random() == rng_b.random()  # the draw is the unit's


@st.composite
def stored_steps(draw):
    """A filter's storage and one step: B filters of n particles, their ancestry, k observed columns
    (some never seen before), predicted poses, observations, log weights."""
    # k from 8 sums a particle's terms by numpy's eight accumulators, above 128 by halves; n from 9
    # fills the kernels' vector lanes
    b = draw(st.integers(1, 3))
    n = draw(st.one_of(st.integers(1, 5), st.integers(9, 20)))
    k = draw(st.one_of(st.integers(1, 6), st.integers(7, 20), st.sampled_from([128, 129, 140])))
    rng = np.random.default_rng(draw(st.integers(0, 2 ** 32 - 1)))
    cap, m = k + draw(st.integers(0, 3)), b * n
    mu_store = rng.normal(size=(2, cap, m)) * 5.0
    L = rng.normal(size=(2, 2, cap, m)) * 0.3
    P_store = np.einsum("ikcp,jkcp->ijcp", L, L) + 0.01 * np.eye(2)[:, :, None, None]
    anc = rng.integers(0, n, size=(m, cap)).astype(np.int16)  # as the filter stores it
    cols = rng.permutation(cap)[:k].astype(np.intp)
    seen = rng.random(k) < draw(st.sampled_from([0.0, 0.7, 1.0]))
    poses = rng.normal(size=(m, 3)) * np.array([3.0, 3.0, 2.0])
    if draw(st.booleans()):  # a landmark on a particle (zero range: inf and NaN in that pair)
        mu_store[:, cols[0], anc[0, cols[0]]] = poses[0, :2]
    z = np.column_stack([rng.uniform(0.0, 6.0, k), rng.uniform(-np.pi, np.pi, k)])
    q01 = draw(st.sampled_from([0.0, 1e-3]))
    Q = np.array([[0.09, q01], [q01, 0.003]])
    logw = rng.normal(size=m) * draw(st.sampled_from([0.0, 1.0, 30.0]))
    return n, mu_store, P_store, anc, cols, seen, poses, z, Q, logw


@settings(max_examples=120, deadline=None)
@given(stored_steps())
def test_the_observed_step_is_the_units_in_sequence(step):
    """correct_observed against the filter's unit-by-unit correction written out with the numpy
    units: gather through the ancestry, init_landmarks where new, the five correction units, the
    write-back, combine_weights and log-sum-exp's shift, filter by filter."""
    n, mu_store, P_store, anc, cols, seen, poses, z, Q, logw = step
    m, k = poses.shape[0], cols.size
    rows = anc[:, cols] + (np.arange(m) // n * n)[:, None]  # (M, k) storage row of each pair
    mu = mu_store[:, cols[None, :], rows].transpose(1, 2, 0)  # (M, k, 2)
    P = P_store[:, :, cols[None, :], rows].transpose(2, 3, 0, 1)  # (M, k, 2, 2)
    new = None if seen.all() else np.flatnonzero(~seen)
    init = None
    with quiet():
        if new is not None:
            init = U.init_landmarks(poses, z[new], Q, wrap=U.wrap_bearing)
            mu[:, new], P[:, new] = init
        zhat, H = U.predict_measurement(poses, mu)
        nu = U.innovation(z, zhat, wrap=U.wrap_bearing)
        S = U.innovation_covariance(H, P, Q)
        ll = U.log_likelihood(nu, S)
        mu1, P1 = U.ekf_update(mu, P, H, S, nu)
        known = np.empty((m, k), dtype=bool)
        known[...] = seen
        combined = np.concatenate([U.combine_weights(logw[f:f + n], ll[f:f + n], known[f:f + n])
                                   for f in range(0, m, n)])
        mu1, P1 = np.where(known[..., None], mu1, mu), np.where(known[..., None, None], P1, P)
        want_mu, want_P, want_anc = mu_store.copy(), P_store.copy(), anc.copy()
        want_mu[:, cols[None, :], np.arange(m)[:, None]] = mu1.transpose(2, 0, 1)
        want_P[:, :, cols[None, :], np.arange(m)[:, None]] = P1.transpose(2, 3, 0, 1)
        want_anc[:, cols] = (np.arange(m) % n)[:, None]
        shifted, tops = twins.correct_observed(poses, z, cols, seen, init, twins.noise_entries(Q), logw, n,
                                               mu_store, P_store, anc)
    assert same_bits(mu_store, want_mu) and same_bits(P_store, want_P)
    np.testing.assert_array_equal(anc, want_anc)
    for f in range(m // n):
        part = combined[f * n:(f + 1) * n]
        top = part.max()
        assert same_bits(tops[f], top)
        assert same_bits(shifted[f * n:(f + 1) * n], part - top if np.isfinite(top) else part)


# --------------------------------------------------------------------------- the filter


N = 24
CFG = FastSlamConfig(particles=N)


@pytest.fixture(scope="module")
def scenario():
    return check_scenario(seed=3, n_steps=60)


def numpy_filter(monkeypatch, make):
    """A filter built with the twins turned off (the pure numpy path)."""
    with monkeypatch.context() as m:
        m.setattr(twins, "JIT_ENABLED", False)
        slam = make()
    assert not getattr(slam, "_jit", False)
    return slam


def final(slam, sc, seed):
    with quiet():
        try:
            est = run_slam(slam, sc, rng=np.random.default_rng(seed))
        except Exception as exc:  # a fault may end the run: both paths must end it alike
            return repr(exc), None
    return est, slam.particles()


def assert_same_run(a, b, what):
    if a[1] is None or b[1] is None:
        assert a[0] == b[0], what
        return
    assert estimates_identical(a[0], b[0]), what
    assert same_bits(a[0].trajectory, b[0].trajectory), f"{what}: trajectory"
    for field in ("poses", "weights", "landmark_ids", "means", "covariances"):
        assert same_bits(getattr(a[1], field), getattr(b[1], field)), f"{what}: {field}"


@pytest.mark.parametrize("seed", [1, 7])
def test_compiled_filter_equals_the_numpy_filter(monkeypatch, scenario, seed):
    compiled = FastSlam(CFG)
    assert compiled._jit and compiled._fused and compiled._ref_step
    assert_same_run(final(compiled, scenario, seed), final(numpy_filter(monkeypatch, lambda: FastSlam(CFG)),
                                                          scenario, seed), f"seed {seed}")


@pytest.mark.slow
def test_compiled_filter_equals_the_numpy_filter_on_a_generated_case(monkeypatch):
    """A fixed-suite scenario (200 particles, ~29 observations per step), first 150 steps."""
    from faultlab.scenario import generate_scenario
    from faultlab.space.case import FIXED_VALUES, CaseSpec
    sc = generate_scenario(CaseSpec(dict(FIXED_VALUES, n_steps=150)), rng=np.random.default_rng(2))
    assert_same_run(final(FastSlam(), sc, 2), final(numpy_filter(monkeypatch, FastSlam), sc, 2), "fixed suite")


@pytest.mark.parametrize("fault", list(builtin_faults().values()), ids=lambda f: f.name)
def test_every_builtin_fault_under_the_compiled_path_equals_numpy(monkeypatch, scenario, fault):
    compiled = fault.apply(FastSlam(CFG))
    plain = numpy_filter(monkeypatch, lambda: fault.apply(FastSlam(CFG)))
    assert_same_run(final(compiled, scenario, 5), final(plain, scenario, 5), fault.name)


@pytest.mark.parametrize("profile", ["paper", "paper_no_aliasing"])
def test_the_papers_filter_under_the_compiled_path_equals_numpy(monkeypatch, scenario, profile):
    """Twins of the paper's wrapped units; with aliasing, the sharer-order correction runs them too."""
    make = lambda: dataclasses.replace(get_profile(profile), config=dataclasses.replace(  # noqa: E731
        get_profile(profile).config, particles=N)).slam()
    compiled = make()
    assert compiled._units(1).predict_measurement is twins.predict_measurement_wrapped
    assert_same_run(final(compiled, scenario, 4), final(numpy_filter(monkeypatch, make), scenario, 4), profile)


def test_batched_compiled_repetitions_equal_single_numpy_runs(monkeypatch, scenario):
    seeds = (11, 5, 902)
    with quiet():
        batch = run_slam_batch(FastSlam(CFG), scenario, rngs=[np.random.default_rng(s) for s in seeds])
    for seed, est in zip(seeds, batch):
        want = final(numpy_filter(monkeypatch, lambda: FastSlam(CFG)), scenario, seed)[0]
        assert estimates_identical(est, want), seed


def test_equivalent_mutants_stay_hidden_under_the_compiled_path():
    """Screened-equivalent mutants of twinned units give maps bit-identical to the compiled baseline."""
    units = ["innovation_covariance", "log_likelihood", "ekf_update"]
    mutants = generate_mutants(REFERENCE_STEPS, units=units, plugins=False)
    report = screen_mutants(mutants, unit_examples())
    equivalent = [i for i, r in report.results.items() if r.outcome is MutantOutcome.EQUIVALENT]
    eq = [next(i for i in equivalent if i.startswith(f"{unit}:")) for unit in units]  # one per unit
    live = next(i for i, r in report.results.items() if r.live and i.startswith("ekf_update"))
    checked = check_faults([mutant_fault(mutants.get(i), FastSlamSteps) for i in eq + [live]], n_steps=40,
                           particles=20, n_seeds=1, plugins=False)
    statuses = [c.status for c in checked]
    assert statuses[:-1] == [CheckStatus.EQUIVALENT] * len(eq) and statuses[-1] is not CheckStatus.EQUIVALENT


@pytest.mark.parametrize("make", [
    lambda: FastSlam2(FastSlamConfig(particles=N)),
    EkfSlam,
    lambda: FastSlamUnknown(FastSlamConfig(particles=N, association="unknown")),
], ids=["fastslam2", "ekf", "fastslam1-unknown"])
def test_the_other_unit_slams_run_the_twins_bit_identically(monkeypatch, scenario, make):
    compiled = make()
    assert compiled._run_steps is not compiled.steps  # some slot holds a reference unit with a twin
    plain = numpy_filter(monkeypatch, make)
    assert plain._run_steps is plain.steps
    with quiet():
        a = run_slam(compiled, scenario, rng=np.random.default_rng(3))
        b = run_slam(plain, scenario, rng=np.random.default_rng(3))
    assert estimates_identical(a, b)


_CHILD = """
import json, sys
import numpy as np
from faultlab.faults.check import check_scenario
from faultlab.slam import FastSlam, FastSlamConfig, run_slam, twins
est = run_slam(FastSlam(FastSlamConfig(particles=24)), check_scenario(seed=3, n_steps=60),
               rng=np.random.default_rng(9))
print(json.dumps({"jit": twins.JIT_ENABLED, "numba": "numba" in sys.modules,
                  "landmarks": est.landmarks.view(np.int64).tolist(), "pose": est.pose.view(np.int64).tolist()}))
"""


def test_faultlab_jit_0_runs_pure_numpy_with_the_same_result(scenario):
    env = dict(os.environ, FAULTLAB_JIT="0")
    out = subprocess.run([sys.executable, "-c", _CHILD], env=env, capture_output=True, text=True, check=True)
    child = json.loads(out.stdout)
    assert child["jit"] is False and child["numba"] is False
    est = run_slam(FastSlam(CFG), scenario, rng=np.random.default_rng(9))
    assert child["landmarks"] == est.landmarks.view(np.int64).tolist()
    assert child["pose"] == est.pose.view(np.int64).tolist()


def test_non_finite_weights_end_the_compiled_step_as_the_numpy_one(monkeypatch):
    """A particle on a known landmark (zero range) makes the weights NaN: the reference step raises
    the numpy path's error, and in a batch it ends each repetition with that error."""
    from faultlab.errors import SlamOutputError
    from faultlab.slam.protocol import Observations
    cfg = FastSlamConfig(particles=4, std_v=0.0, std_omega=0.0)
    steps = [([0.0, 0.0], Observations(np.array([1.0]), np.array([0.0]), np.array([7]))),
             ([1.0, 0.0], Observations(np.array([0.5]), np.array([0.1]), np.array([7])))]

    def run(slam, batch):
        if batch:
            slam.reset_batch(np.zeros(3), rngs=[np.random.default_rng(s) for s in (1, 2)])
        else:
            slam.reset(np.zeros(3), rng=np.random.default_rng(1))
        with quiet():
            for u, obs in steps:
                slam.update(np.array(u), obs)
        return [repr(e) for e in slam.estimates()] if batch else None

    compiled, plain = FastSlam(cfg), numpy_filter(monkeypatch, lambda: FastSlam(cfg))
    assert compiled._ref_step and not plain._jit
    messages = []
    for slam in (compiled, plain):
        with pytest.raises(SlamOutputError, match="weights are not finite at step 1") as info:
            run(slam, batch=False)
        messages.append(str(info.value))
    assert messages[0] == messages[1]
    got, want = run(FastSlam(cfg), True), run(numpy_filter(monkeypatch, lambda: FastSlam(cfg)), True)
    assert got == want and all("not finite" in m for m in got)


# --------------------------------------------------------------------------- the partial reference step


def _odd_resample(w, n_eff, empty, rng, config):
    """Indices as floats: the reference apply_resample's indexing raises (IndexError)."""
    idx = U.resample(w, n_eff, empty, rng, config)
    return None if idx is None else idx.astype(float)


def _short_resample(w, n_eff, empty, rng, config):
    """One index too few: the state apply_resample returns has the wrong shape."""
    idx = U.resample(w, n_eff, empty, rng, config)
    return None if idx is None else idx[:-1]


def _mean_init(poses, z, Q, *, wrap):
    """init_landmarks returning one row for all particles (broadcast by the unit-by-unit path)."""
    mu, P = U.init_landmarks(poses, z, Q, wrap=wrap)
    return mu.mean(axis=0, keepdims=True), P[:1]


def _flat_weights(logw, loglik, known):
    """combine_weights that ignores which pairs are known."""
    return logw + np.nan_to_num(loglik).sum(axis=1) * 0.5


def _every_step_resample(w, n_eff, empty, rng, config):
    return U.low_variance_indices(w, rng)


@pytest.mark.parametrize("name, unit", [("resample", _odd_resample), ("resample", _short_resample),
                                        ("resample", _every_step_resample), ("init_landmarks", _mean_init),
                                        ("combine_weights", _flat_weights)],
                         ids=["float-indices", "short-indices", "every-step", "broadcast-init", "flat-weights"])
def test_the_partial_reference_step_equals_numpy_on_odd_replacements(monkeypatch, scenario, name, unit):
    """Replacements with outputs the reference stages do not expect (other types, other shapes)
    end or run the filter exactly as the numpy path does, single and batched."""
    steps = dataclasses.replace(REFERENCE_STEPS, **{name: unit})
    compiled = FastSlam(CFG, steps=steps)
    assert not compiled._ref_step and compiled._ref_predict
    plain = numpy_filter(monkeypatch, lambda: FastSlam(CFG, steps=steps))
    assert_same_run(final(compiled, scenario, 6), final(plain, scenario, 6), name)
    seeds = (3, 8)

    def batch(slam):
        with quiet():
            try:
                return run_slam_batch(slam, scenario, rngs=[np.random.default_rng(s) for s in seeds])
            except Exception as exc:
                return [repr(exc)] * len(seeds)

    for got, want in zip(batch(FastSlam(CFG, steps=steps)), batch(numpy_filter(monkeypatch,
                                                                            lambda: FastSlam(CFG, steps=steps)))):
        assert (estimates_identical(got, want) if not isinstance(got, (str, BaseException))
                else repr(got) == repr(want))


def test_sampled_mutants_outside_the_correction_equal_numpy(monkeypatch, scenario):
    """Live mutants of the units outside the correction (the partial reference step's other stages)."""
    units = ["sample_controls", "motion_model", "combine_weights", "init_landmarks", "effective_sample_size",
             "resample", "apply_resample"]
    mutants = generate_mutants(REFERENCE_STEPS, units=units, plugins=False)
    report = screen_mutants(mutants, unit_examples())
    chosen = [next(i for i, r in report.results.items() if r.live and i.startswith(f"{u}:")) for u in units]
    for mutant_id in chosen:
        fault = mutant_fault(mutants.get(mutant_id), FastSlamSteps)
        compiled = fault.apply(FastSlam(CFG))
        assert compiled._ref_predict or compiled._ref_correct
        assert_same_run(final(compiled, scenario, 2),
                        final(numpy_filter(monkeypatch, lambda: fault.apply(FastSlam(CFG))), scenario, 2), mutant_id)


# --------------------------------------------------------------------------- the staged correction


def _c_order(unit):
    """The unit with its outputs copied to ordinary C-ordered arrays (a replacement's usual layout)."""

    def replaced(*args, **kwargs):
        out = unit(*args, **kwargs)
        return tuple(np.array(o, order="C") for o in out) if isinstance(out, tuple) else np.array(out, order="C")

    return replaced


def _lopsided_ekf(mu, P, H, S, nu):
    """An ekf_update whose covariance is not symmetric (its P[1, 0] is stored as returned)."""
    mu_new, P_new = U.ekf_update(mu, P, H, S, nu)
    P_new = np.array(P_new)
    P_new[..., 1, 0] += 1e-3
    return mu_new, P_new


def _scaling_covariance(H, P, Q):
    """An innovation_covariance that scales its input P in place (the later units see the change)."""
    P *= 1.5
    return U.innovation_covariance(H, P, Q)


def _float32_likelihood(nu, S):
    """log_likelihood in float32: not what the compiled stages take (the unit-by-unit path runs)."""
    return U.log_likelihood(nu, S).astype(np.float32)


def _broadcast_innovation(z, zhat, *, wrap):
    """An innovation of one row for all particles: numpy broadcasts it in the later units."""
    return U.innovation(z, zhat, wrap=wrap)[:1]


def _nan_jacobian(poses, mu):
    zhat, H = U.predict_measurement(poses, mu)
    H = np.array(H)
    H[::3, :, 1, 1] = np.nan
    return zhat, H


_STAGED = [("predict_measurement", twins.predict_measurement, 0), ("innovation", twins.innovation, 1),
           ("innovation_covariance", twins.innovation_covariance, 2), ("log_likelihood", twins.log_likelihood, 3),
           ("ekf_update", twins.ekf_update, 4),
           ("predict_measurement", _c_order(U.predict_measurement), 0), ("innovation", _c_order(U.innovation), 1),
           ("innovation_covariance", _c_order(U.innovation_covariance), 2),
           ("log_likelihood", _c_order(U.log_likelihood), 3), ("ekf_update", _c_order(U.ekf_update), 4),
           ("predict_measurement", _nan_jacobian, 0), ("ekf_update", _lopsided_ekf, 4),
           ("innovation_covariance", _scaling_covariance, 2)]


def _wrapped(unit):
    """A new function calling ``unit`` (a replacement the filter does not recognise as a reference)."""

    def replaced(*args, **kwargs):
        return unit(*args, **kwargs)

    return replaced


@pytest.mark.parametrize("name, unit, stage", _STAGED,
                         ids=[f"{n}-{getattr(u, '__name__', '')}-{i}" for i, (n, u, _) in enumerate(_STAGED)])
def test_a_replaced_correction_unit_runs_staged_and_equals_numpy(monkeypatch, scenario, name, unit, stage):
    """One correction unit replaced: the other stages run compiled around it (never the unit-by-unit
    path), with the run, the particles and batched repetitions bit-identical to the numpy filter."""
    steps = dataclasses.replace(REFERENCE_STEPS, **{name: _wrapped(unit)})
    compiled = FastSlam(CFG, steps=steps)
    assert compiled._stage == stage and not compiled._fused

    def unit_by_unit(*args, **kwargs):
        raise AssertionError("the unit-by-unit correction ran")

    monkeypatch.setattr(compiled, "_correct", unit_by_unit)
    plain = numpy_filter(monkeypatch, lambda: FastSlam(CFG, steps=steps))
    assert_same_run(final(compiled, scenario, 6), final(plain, scenario, 6), name)
    seeds = (3, 8)
    with quiet():
        batch = run_slam_batch(FastSlam(CFG, steps=steps), scenario, rngs=[np.random.default_rng(s) for s in seeds])
    for seed, est in zip(seeds, batch):
        want = final(numpy_filter(monkeypatch, lambda: FastSlam(CFG, steps=steps)), scenario, seed)[0]
        assert (repr(est) == want if isinstance(want, str) else estimates_identical(est, want)), (name, seed)


@pytest.mark.parametrize("name, unit", [("log_likelihood", _float32_likelihood),
                                        ("innovation", _broadcast_innovation)], ids=["float32", "broadcast"])
def test_the_staged_correction_hands_other_outputs_to_the_unit_by_unit_path(monkeypatch, scenario, name, unit):
    """A replaced unit whose output the compiled stages do not take: the step runs unit by unit,
    as the numpy filter does, and the storage is untouched before it."""
    steps = dataclasses.replace(REFERENCE_STEPS, **{name: unit})
    compiled = FastSlam(CFG, steps=steps)
    assert compiled._stage is not None
    plain = numpy_filter(monkeypatch, lambda: FastSlam(CFG, steps=steps))
    assert_same_run(final(compiled, scenario, 2), final(plain, scenario, 2), name)


def test_the_staged_correction_with_a_replaced_combine_weights_equals_numpy(monkeypatch, scenario):
    steps = dataclasses.replace(REFERENCE_STEPS, ekf_update=_wrapped(U.ekf_update), combine_weights=_flat_weights)
    compiled = FastSlam(CFG, steps=steps)
    assert compiled._stage == 4 and not compiled._ref_combine
    assert_same_run(final(compiled, scenario, 4),
                    final(numpy_filter(monkeypatch, lambda: FastSlam(CFG, steps=steps)), scenario, 4), "combine")


def test_sampled_mutants_inside_the_correction_equal_numpy(monkeypatch, scenario):
    """A live mutant of each correction unit (the staged correction), against the numpy filter."""
    units = ["predict_measurement", "innovation", "wrap_bearing", "innovation_covariance", "log_likelihood",
             "ekf_update"]
    mutants = generate_mutants(REFERENCE_STEPS, units=units, plugins=False)
    report = screen_mutants(mutants, unit_examples())
    for unit in units:
        live = [i for i, r in report.results.items() if r.live and i.startswith(f"{unit}:")]
        for mutant_id in live[len(live) // 2:len(live) // 2 + 1]:
            fault = mutant_fault(mutants.get(mutant_id), FastSlamSteps)
            compiled = fault.apply(FastSlam(CFG))
            assert compiled._stage == twins.STAGES[unit]
            assert_same_run(final(compiled, scenario, 2),
                            final(numpy_filter(monkeypatch, lambda: fault.apply(FastSlam(CFG))), scenario, 2),
                            mutant_id)


@pytest.mark.parametrize("mutant_id", ["ekf_update:index:51", "predict_measurement:statement_deletion:5"])
def test_mutants_that_leave_an_output_entry_unwritten_are_deterministic_on_both_paths(monkeypatch, scenario,
                                                                                      mutant_id):
    """The units return zero-filled arrays: a mutant that skips writing an entry gives the same run
    twice, and the compiled path (the staged correction) the numpy filter's."""
    mutants = generate_mutants(REFERENCE_STEPS, units=[mutant_id.split(":")[0]], plugins=False)
    fault = mutant_fault(mutants.get(mutant_id), FastSlamSteps)
    first, again = final(fault.apply(FastSlam(CFG)), scenario, 2), final(fault.apply(FastSlam(CFG)), scenario, 2)
    assert_same_run(first, again, mutant_id)
    assert_same_run(first, final(numpy_filter(monkeypatch, lambda: fault.apply(FastSlam(CFG))), scenario, 2), mutant_id)
