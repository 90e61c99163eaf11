"""The paper's FastSLAM 1.0 units against transcriptions of its loops (faultlab.slam.paperunits)."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import multivariate_normal

from faultlab.slam import FastSlamConfig
from faultlab.slam import paperunits
from faultlab.slam import particles
from faultlab.slam import units as U

Q = FastSlamConfig().Q


def _random_case(seed, n=5, k=4):
    rng = np.random.default_rng(seed)
    poses = np.column_stack([rng.uniform(-3, 3, n), rng.uniform(-3, 3, n), rng.uniform(-math.pi, math.pi, n)])
    mu = poses[:, None, :2] + rng.uniform(0.3, 2.0, (n, k, 1)) * np.stack(
        [np.cos(a := rng.uniform(-math.pi, math.pi, (n, k))), np.sin(a)], axis=-1)
    A = rng.normal(size=(n, k, 2, 2))
    P = A @ np.swapaxes(A, -1, -2) * 0.05 + 0.01 * np.eye(2)
    return rng, poses, mu, P


def _paper_wrap(a: float) -> float:
    """The paper's pi_2_pi, scalar: (a + pi) mod 2 pi - pi."""
    return (a + math.pi) % (2 * math.pi) - math.pi


def test_predict_measurement_wrapped_wraps_the_predicted_bearing_only():
    poses = np.array([[0.0, 0.0, -3.0], [1.0, 1.0, 3.0], [0.0, 0.0, 0.2]])
    mu = np.array([[[-1.0, 1.0]], [[1.0, 0.0]], [[1.0, 0.5]]])  # atan2 - theta: 5.36, -4.57, 0.26
    zhat, H = paperunits.predict_measurement_wrapped(poses, mu)
    zref, Href = U.predict_measurement(poses, mu)
    for i in range(3):
        dx, dy = mu[i, 0] - poses[i, :2]
        raw = math.atan2(dy, dx) - poses[i, 2]
        assert zhat[i, 0, 1] == pytest.approx(_paper_wrap(raw), abs=1e-12)
        assert -math.pi <= zhat[i, 0, 1] < math.pi
        assert zref[i, 0, 1] == pytest.approx(raw, abs=1e-12)  # the reference leaves it unwrapped
    assert abs(zref[0, 0, 1]) > math.pi and abs(zref[1, 0, 1]) > math.pi
    np.testing.assert_array_equal(zhat[..., 0], zref[..., 0])
    np.testing.assert_array_equal(H, Href)


def test_log_likelihood_wrapped_uses_the_wrapped_bearing_innovation():
    rng, poses, mu, P = _random_case(5)
    _, H = U.predict_measurement(poses, mu)
    S = U.innovation_covariance(H, P, Q)
    nu = rng.normal(scale=0.2, size=mu.shape)
    turns = rng.integers(-2, 3, size=mu.shape[:2])
    shifted = nu.copy()
    shifted[..., 1] += 2 * math.pi * turns
    before = shifted.copy()
    ll = paperunits.log_likelihood_wrapped(shifted, S)
    np.testing.assert_array_equal(shifted, before)  # the input is not modified
    ref = np.array([[multivariate_normal(mean=np.zeros(2), cov=S[i, j]).logpdf(nu[i, j])
                     for j in range(S.shape[1])] for i in range(S.shape[0])])
    np.testing.assert_allclose(ll, ref, rtol=1e-9)
    np.testing.assert_array_equal(paperunits.log_likelihood_wrapped(nu, S), U.log_likelihood(nu, S))  # already wrapped
    assert not np.allclose(U.log_likelihood(shifted, S), ref)


def _linear_weights_loop(logw, loglik, known, length_unit):
    """The paper's weights, scalar: w *= lik per known observation in order, normalise, zero sum -> 1/N."""
    n, k = loglik.shape
    w = [math.exp(x) for x in logw]
    for i in range(n):
        for j in range(k):
            if known[i, j]:
                w[i] *= math.exp(loglik[i, j] + math.log(length_unit))
    total = sum(w)
    if total == 0.0:
        return [1.0 / n] * n
    return [x / total for x in w]


@settings(max_examples=80, deadline=None)
@given(st.integers(0, 2**32 - 1), st.sampled_from([1.0, 0.1]), st.floats(0.0, 400.0))
def test_combine_weights_linear_is_the_sequential_product_with_reset(seed, unit, scale):
    rng = np.random.default_rng(seed)
    n, k = 7, 9
    logw = np.log(rng.dirichlet(np.ones(n)))
    loglik = -scale * rng.random((n, k)) + rng.normal(size=(n, k))  # underflows for large scale
    known = rng.random((n, k)) < 0.8
    out = paperunits.combine_weights_linear(logw, loglik, known, length_unit=unit)
    assert out.shape == (n,)
    w = np.exp(out - np.max(out))
    expected = _linear_weights_loop(logw, loglik, known, unit)
    np.testing.assert_allclose(w / w.sum(), expected, rtol=1e-12, atol=0)
    # exactly the sequential floating-point product: a weight is 0 exactly where the loop's is
    np.testing.assert_array_equal(w == 0.0, np.array(expected) == 0.0)


def test_combine_weights_linear_resets_to_uniform_when_every_weight_underflows():
    logw = np.log([0.5, 0.3, 0.2])
    loglik = np.full((3, 4), -300.0)  # exp(-1200) per particle: 0 in floating point
    out = paperunits.combine_weights_linear(logw, loglik, np.ones((3, 4), dtype=bool))
    np.testing.assert_array_equal(out, np.full(3, -math.log(3)))
    # the log-domain reference keeps the relative weights instead
    np.testing.assert_allclose(U.combine_weights(logw, loglik, np.ones((3, 4), dtype=bool)), logw - 1200.0)
    # one survivor: the others are exactly 0 (log -inf), no reset
    loglik[1] = -1.0
    with np.errstate(divide="ignore"):
        out = paperunits.combine_weights_linear(logw, loglik, np.ones((3, 4), dtype=bool))
    assert out[0] == -np.inf and out[2] == -np.inf and out[1] == pytest.approx(math.log(0.3) - 4.0)
    # new landmarks (not known) contribute no factor
    out = paperunits.combine_weights_linear(logw, loglik, np.zeros((3, 4), dtype=bool))
    np.testing.assert_allclose(out, logw, rtol=1e-15)


def test_classify_new_near_zero_x_tests_the_stored_x_only():
    mu = np.array([[[0.0, 0.0], [0.0009, 5.0], [-0.001, 1.0], [0.0011, 0.0], [2.0, 0.0]]])
    seen = np.array([False, True, True, False, False])
    np.testing.assert_array_equal(paperunits.classify_new_near_zero_x(seen, mu, tolerance=0.001),
                                  [[True, True, True, False, False]])
    np.testing.assert_array_equal(paperunits.classify_new_near_zero_x(seen, mu),  # default tolerance 0.01
                                  [[True, True, True, True, False]])


def _paper_resampling_loop(w, uniforms):
    """The paper's index search: base + rand / N, advance while u > cumsum[ind] (capped at N - 1)."""
    n = len(w)
    w_cum = np.cumsum(w)
    inds, ind = [], 0
    for m in range(n):
        u = m / n + uniforms[m] / n
        while ind < n - 1 and u > w_cum[ind]:
            ind += 1
        inds.append(ind)
    return inds


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=30).filter(lambda w: sum(w) > 1e-3),
       st.integers(0, 2**32 - 1))
def test_stratified_indices_match_the_paper_loop_with_one_uniform_per_stratum(w, seed):
    w = np.array(w) / np.sum(w)
    idx = paperunits.stratified_indices(w, np.random.default_rng(seed))
    uniforms = np.random.default_rng(seed).random(w.size)  # the same draws, N of them
    np.testing.assert_array_equal(idx, _paper_resampling_loop(w, uniforms))


def test_resample_stratified_decides_like_the_reference():
    cfg = FastSlamConfig(particles=4)
    peaked = np.array([0.85, 0.05, 0.05, 0.05])
    n_eff = U.effective_sample_size(peaked)
    assert paperunits.resample_stratified(np.full(4, 0.25), 4.0, False, np.random.default_rng(0), cfg) is None
    assert paperunits.resample_stratified(peaked, n_eff, True, np.random.default_rng(0), cfg) is None
    idx = paperunits.resample_stratified(peaked, n_eff, False, np.random.default_rng(0), cfg)
    np.testing.assert_array_equal(idx, paperunits.stratified_indices(peaked, np.random.default_rng(0)))


def _shallow_copy_loop(indices):
    """The paper's resampling copies: tmp = particles[:] and views of the landmark arrays, in place.

    Returns, per particle, where its pose came from and which original landmark array it holds.
    """

    class Particle:
        def __init__(self, i):
            self.x = float(i)
            self.lm = np.full((1, 2), float(i))

    particles = [Particle(i) for i in range(len(indices))]
    bases = [p.lm for p in particles]
    tmp = particles[:]
    for i, j in enumerate(indices):
        particles[i].x = tmp[j].x
        particles[i].lm = tmp[j].lm[:, :]
    arrays = [next(b for b, a in enumerate(bases) if np.shares_memory(a, p.lm)) for p in particles]
    return np.array([int(p.x) for p in particles]), np.array(arrays)


@settings(max_examples=80, deadline=None)
@given(st.lists(st.integers(0, 9), min_size=10, max_size=10))
def test_shallow_copy_ancestors_and_apply_resample_aliased_match_the_shallow_copy_loop(indices):
    idx = np.array(indices)
    poses_from, arrays = _shallow_copy_loop(idx)
    np.testing.assert_array_equal(paperunits.shallow_copy_ancestors(idx), poses_from)
    state = particles.ParticleState.initial(np.zeros(3), 10)
    state = state.replace(poses=np.arange(30.0).reshape(10, 3), logw=np.log(np.full(10, 0.1)))
    out = paperunits.apply_resample_aliased(state, idx)
    np.testing.assert_array_equal(out.poses[:, 0], 3.0 * poses_from)
    np.testing.assert_array_equal(out.owner, arrays)  # the storage row = the landmark array it holds
    assert out.sequential_sharers and not state.sequential_sharers
    np.testing.assert_allclose(np.exp(out.logw), 0.1)
    # a second resampling composes the sharing: arrays are never renewed
    out2 = paperunits.apply_resample_aliased(out, idx[::-1])
    np.testing.assert_array_equal(out2.owner, out.owner[paperunits.shallow_copy_ancestors(idx[::-1])])


def test_extract_map_closest_to_mean_against_the_sorted_key():
    rng = np.random.default_rng(8)
    n, C = 6, 3
    state = particles.ParticleState.initial(np.zeros(3), n, capacity=4)
    state.mu[:, :C] = rng.uniform(-2, 2, (n, C, 2))
    w = rng.dirichlet(np.ones(n))
    poses = np.column_stack([rng.normal(size=n), rng.normal(size=n), np.zeros(n)])
    state = state.replace(ids=np.array([4, 1, 9]), logw=np.log(w), poses=poses)
    mx, my = sum(w[i] * poses[i, 0] for i in range(n)), sum(w[i] * poses[i, 1] for i in range(n))
    best = sorted(range(n), key=lambda i: math.hypot(poses[i, 0] - mx, poses[i, 1] - my) * w[i])[0]
    ids, xy = paperunits.extract_map_closest_to_mean(state)
    np.testing.assert_array_equal(ids, [4, 1, 9])
    expected = [[round(1000 * v) / 1000 for v in row] for row in state.mu[best, :C]]
    np.testing.assert_allclose(xy, expected, atol=1e-12)
    # a particle whose weight is 0 has key 0 and wins (the lowest such index)
    w0 = w.copy()
    w0[[2, 4]] = 0.0
    with np.errstate(divide="ignore"):
        _, xy0 = paperunits.extract_map_closest_to_mean(state.replace(logw=np.log(w0)), resolution=0.01)
    np.testing.assert_allclose(xy0, np.round(state.mu[2, :C] * 100) / 100, atol=1e-12)
