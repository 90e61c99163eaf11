"""Alternative units: the FastSLAM 1.0 the paper tested (Sec. VII-A).

PythonRobotics' SLAM/FastSLAM1/fast_slam1.py as modified in the paper's replication package
(slam/slam_correct.py).  Each function here is the replication package's choice for one unit of
:class:`faultlab.slam.FastSlamSteps`, with the signature of the reference unit it replaces
(:mod:`faultlab.slam.units`); :mod:`faultlab.slam.profiles` assembles them into the ``paper``
profile.
"""

from __future__ import annotations

import math

import numpy as np

from faultlab.slam.particles import ParticleState
from faultlab.slam.units import _wrap, apply_resample, log_likelihood, predict_measurement

__all__ = [
    "predict_measurement_wrapped",
    "log_likelihood_wrapped",
    "combine_weights_linear",
    "classify_new_near_zero_x",
    "stratified_indices",
    "resample_stratified",
    "shallow_copy_ancestors",
    "apply_resample_aliased",
    "extract_map_closest_to_mean",
]


def predict_measurement_wrapped(poses: np.ndarray, mu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~faultlab.slam.units.predict_measurement` with the predicted bearing wrapped to [-pi, pi).

    ``z_hat = (sqrt(q), wrap(atan2(dy, dx) - theta))``, as the paper's filter
    computes it: the wrap is part of the measurement model, so it is the unit's
    own (``a - 2 pi floor((a + pi) / 2 pi)``) and not ``steps.wrap_bearing``; a
    fault that removes the innovation wrap leaves it in place.

    Parameters
    ----------
    poses : ndarray, shape (N, 3)
    mu : ndarray, shape (N, k, 2)

    Returns
    -------
    z_hat : ndarray, shape (N, k, 2)
        Bearing component in [-pi, pi).
    H : ndarray, shape (N, k, 2, 2)
        As :func:`~faultlab.slam.units.predict_measurement` (the wrap does not change the derivative).
    """
    zhat, H = predict_measurement(poses, mu)
    zhat[..., 1] = _wrap(zhat[..., 1])
    return zhat, H


def log_likelihood_wrapped(nu: np.ndarray, S: np.ndarray) -> np.ndarray:
    """:func:`~faultlab.slam.units.log_likelihood` of the innovation with its bearing wrapped to [-pi, pi) first.

    The paper's filter computes the innovation twice, once for the importance
    weight and once for the EKF update, and wraps the bearing in both places.
    Here the weight's wrap belongs to this unit (it is not ``steps.wrap_bearing``),
    so removing the innovation wrap (the paper's *faulty rotation*) changes the
    EKF update only and the weights stay as in the paper.  For an innovation that
    is already wrapped the extra wrap changes nothing.

    Parameters
    ----------
    nu : ndarray, shape (N, k, 2)
    S : ndarray, shape (N, k, 2, 2)
        Symmetric positive definite.

    Returns
    -------
    ndarray, shape (N, k)
        ``log N(nu'; 0, S)`` with ``nu' = (nu_r, wrap(nu_b))``.
    """
    nu = np.array(nu, dtype=float)
    nu[..., 1] = _wrap(nu[..., 1])
    return log_likelihood(nu, S)


def combine_weights_linear(logw: np.ndarray, loglik: np.ndarray, known: np.ndarray, *,
                           length_unit: float = 1.0) -> np.ndarray:
    """Weights multiplied in the linear domain, one observation after another; all zero -> uniform.

    The paper's filter keeps linear weights: every known observation multiplies
    the particle's weight by its Gaussian likelihood, in observation order, so a
    product of small likelihoods underflows to exactly 0; when the weights of
    *all* particles are 0 their normalisation divides by zero and every weight is
    reset to 1/N (which damps a fault that makes every innovation huge).  New
    landmarks contribute no factor.  Where the product underflows depends on the
    length unit the filter computes in (a density per unit of range scales with
    it), so the factors are densities per ``length_unit`` metres:
    ``length_unit * exp(loglik)``.

    Parameters
    ----------
    logw : ndarray, shape (N,)
        Current normalised log weights (``-inf`` for a weight that is 0).
    loglik : ndarray, shape (N, k)
        Log likelihood of every (particle, observation) pair.
    known : ndarray of bool, shape (N, k)
        Pairs updated as known landmarks.
    length_unit : float
        The length unit of the likelihoods, m (the paper's filter: 0.1 m, see
        :mod:`faultlab.slam.profiles`).

    Returns
    -------
    ndarray, shape (N,)
        ``log(w * prod_k lik_k)`` with the product evaluated in floating point
        from the first observation to the last (``-inf`` where it underflowed), or
        ``log(1 / N)`` for every particle if all products are 0.
    """
    logw = np.asarray(logw, dtype=float)
    factors = np.where(np.asarray(known, dtype=bool), np.exp(np.asarray(loglik) + math.log(length_unit)), 1.0)
    # rows: the weights, then one row per observation; a reduction over axis 0 multiplies the rows
    # elementwise in order, i.e. ((w * l_1) * l_2) * ... for every particle
    rows = np.zeros((factors.shape[1] + 1, logw.shape[0]))
    rows[0] = np.exp(logw)
    rows[1:] = factors.T
    w = np.multiply.reduce(rows, axis=0)
    if not w.sum() > 0.0:
        return np.full(logw.shape, -math.log(logw.shape[0]))
    with np.errstate(divide="ignore"):
        return np.log(w)


def classify_new_near_zero_x(seen: np.ndarray, mu: np.ndarray, *, tolerance: float = 0.01) -> np.ndarray:
    """A landmark is new while its stored x is near 0: ``abs(mu_x) <= tolerance``.

    PythonRobotics' filter has no list of seen landmarks; it pre-allocates every
    landmark at (0, 0) and tests ``abs(x) <= 0.01`` in its length unit.  A
    landmark whose estimate lies that close to the y axis is therefore initialised
    again (its estimate discarded, no weight update) at every sighting.

    Parameters
    ----------
    seen : ndarray of bool, shape (k,)
        Ignored.
    mu : ndarray, shape (N, k, 2)
        Stored means (zeros for never-seen landmarks).
    tolerance : float
        m; 0.01 in a filter working in metres, 0.001 in the paper's (0.01 of its 0.1 m unit).

    Returns
    -------
    ndarray of bool, shape (N, k)
    """
    return np.abs(np.asarray(mu)[..., 0]) <= tolerance


def stratified_indices(w: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Stratified resampling indices: one uniform draw per stratum.

    ``u_m = (m + U_m) / N`` with ``N`` independent ``U_m ~ U[0, 1)``
    (``rng.random(N)``); sample ``m`` picks the first particle whose cumulative
    weight reaches ``u_m``.  The paper's filter draws this way (its docstring calls
    it low variance, which would use one shared ``U``: :func:`~faultlab.slam.units.low_variance_indices`).

    Parameters
    ----------
    w : ndarray, shape (N,)
        Normalised weights.
    rng : numpy.random.Generator
        Consumed as exactly one call ``rng.random(N)``.

    Returns
    -------
    ndarray of intp, shape (N,)
    """
    n = w.shape[0]
    u = (np.arange(n) + rng.random(n)) / n
    idx = np.searchsorted(np.cumsum(w), u, side="left")
    return np.minimum(idx, n - 1).astype(np.intp, copy=False)


def resample_stratified(w: np.ndarray, n_eff: float, empty: bool, rng: np.random.Generator,
                        config) -> np.ndarray | None:
    """:func:`~faultlab.slam.units.resample` with :func:`stratified_indices` instead of the low-variance sampler.

    Same decision: None if ``empty`` or ``n_eff >= N / config.resample_ratio``.

    Parameters
    ----------
    w : ndarray, shape (N,)
    n_eff : float
    empty : bool
    rng : numpy.random.Generator
    config : FastSlamConfig

    Returns
    -------
    ndarray of intp, shape (N,), or None
    """
    n = w.shape[0]
    if empty or n_eff >= n / config.resample_ratio:
        return None
    return stratified_indices(w, rng)


def shallow_copy_ancestors(indices: np.ndarray) -> np.ndarray:
    """The particles an in-place resampling loop over a shallow list copy really copies.

    ``for i: particles[i] <- particles[indices[i]]`` over a shallow copy of the
    list overwrites the particles in place, so slot ``indices[i] < i`` has already
    been overwritten when slot ``i`` reads it: ``eff[i] = eff[indices[i]]`` if
    ``indices[i] < i``, else ``indices[i]``.  Vectorised by pointer jumping (each
    hop moves to a strictly smaller slot).

    Parameters
    ----------
    indices : ndarray of int, shape (N,)

    Returns
    -------
    ndarray of intp, shape (N,)
    """
    idx = np.asarray(indices, dtype=np.intp)
    eff = idx.copy()
    pending = eff < np.arange(idx.size)
    while pending.any():
        slot = eff[pending]
        nxt = idx[slot]
        eff[pending] = nxt
        pending[pending] = nxt < slot
    return eff


def apply_resample_aliased(state: ParticleState, indices: np.ndarray) -> ParticleState:
    """Resampling by shallow copies: copies share their ancestor's landmark arrays, for good.

    The paper's filter resamples with ``tmp = particles[:]`` (a shallow list copy)
    and assigns views ``lm[:, :]`` of the ancestor's landmark arrays: particle
    ``i`` becomes a copy of :func:`shallow_copy_ancestors` ``(indices)[i]`` and
    *shares* that particle's landmark storage (``owner`` is composed, never
    renewed, so the number of distinct maps can only shrink).  The particles that
    share a row update it one after another in particle order
    (``sequential_sharers``): a later observation of a shared landmark is applied
    once per sharer, each from the previous sharer's result.

    Parameters
    ----------
    state : ParticleState
    indices : ndarray of int, shape (N,)

    Returns
    -------
    ParticleState
        Poses and lineage gathered, uniform weights, ``owner = state.owner[eff]``,
        ``sequential_sharers = True``.
    """
    eff = shallow_copy_ancestors(indices)
    out = apply_resample(state, eff)
    return out.replace(owner=np.asarray(state.owner)[eff], sequential_sharers=True)


def extract_map_closest_to_mean(state: ParticleState, *,
                                resolution: float = 0.001) -> tuple[np.ndarray, np.ndarray]:
    """The map of the particle minimising ``distance to the mean position x weight``, rounded.

    The paper's adapter takes the weighted mean of the particle positions,
    sorts the particles by ``hypot(x - mean_x, y - mean_y) * w`` and returns the
    first one's landmarks rounded to whole millimetres (its maps are integer mm).
    Ties go to the lowest index, so a particle whose weight is 0 wins.

    Parameters
    ----------
    state : ParticleState
    resolution : float
        Grid the coordinates are rounded to, m (half to even).

    Returns
    -------
    ids : ndarray of int64, shape (M,)
    xy : ndarray, shape (M, 2)
        Multiples of ``resolution`` (up to floating point).
    """
    w = np.exp(np.asarray(state.logw, dtype=float))
    total = w.sum()
    w = w / total if total > 0.0 else np.full(w.shape, 1.0 / w.shape[0])
    poses = np.asarray(state.poses, dtype=float)
    mx, my = w @ poses[:, 0], w @ poses[:, 1]
    i = int(np.argmin(np.hypot(poses[:, 0] - mx, poses[:, 1] - my) * w))
    C = state.n_landmarks
    cols = np.arange(C)
    rows = state.anc[state.lineage[i], :C]
    return state.ids.copy(), np.round(state.mu[rows, cols] / resolution) * resolution

