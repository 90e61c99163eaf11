"""Compiled twins of the reference units: the same functions, bit for bit, in one pass each.

The reference units (:mod:`faultlab.slam.units`) are numpy formulas: readable, replaceable by a
fault, mutated by ``faultlab mutate``.  Each evaluates its 2 x 2 algebra as a chain of whole-array
operations, about 145 passes over the (particle, observation) arrays per step.  A *twin* has the
reference unit's signature and returns bit-identical arrays, but does the element-wise work in a
compiled loop (:mod:`faultlab.slam.kernels`) that keeps every intermediate in registers.

Twins are keyed by function identity (:data:`TWINS`): :func:`twinned` gives a unit table in which
every slot that holds a reference function holds its twin instead, and leaves every other slot
(a fault, a mutant, a plugin) as it is.  A filter calls the units of ``twinned(steps)``, so a fault
author writes numpy as always and the rest of the filter runs compiled.  Where the units of a
whole correction are references, :func:`correct_pairs` does their work in one fused pass; a fault
in any of them falls back to the unit-by-unit path.

Exactness.  A twin performs the same IEEE operations in the same order as its unit, with no
fused multiply-add and no reassociation (no ``fastmath``), and leaves the transcendental
functions (``arctan2``, ``log``, ``cos``, ``sin``) to numpy, whose SIMD implementations can
differ from the C library's in the last bit.  So twin and unit agree bit for bit on every input
on every CPU, and with them every guarantee of the campaigns: an equivalent fault or mutant still
gives maps bit-identical to the baseline, the random streams are untouched (a twin draws exactly
what its unit draws, from the unit's stream), a batched
repetition equals the single run and results do not depend on ``--jobs``.  A twin applies only
to float64 arrays of the documented shapes (without broadcasting); anything else is handed to
the numpy unit.

``FAULTLAB_JIT=0`` in the environment (read once, here: :data:`JIT_ENABLED`) turns the twins off:
the filters then run the numpy units only and numba is never imported.
"""

from __future__ import annotations

import dataclasses
import math
import os
from types import SimpleNamespace
from typing import Callable

import numpy as np

from faultlab.slam import paperunits as _paperunits
from faultlab.slam import particles as _particles
from faultlab.slam import sharing as _sharing
from faultlab.slam import units as _units
from faultlab.slam.units import _mat22, _vec2

__all__ = ["JIT_VARIABLE", "JIT_ENABLED", "TWINS", "twinned", "fused", "correct_pairs", "predict_poses",
           "correct_observed", "finish_log_likelihood", "combine_pairs", "correct_staged", "staged", "STAGES", "noise_entries", "gather_rows",
           "scatter_rows", "take_rows", "correct_in_sharer_order", "warm_up",
           "sample_controls", "motion_model", "predict_measurement", "innovation", "innovation_covariance",
           "log_likelihood", "ekf_update",
           "predict_measurement_wrapped", "log_likelihood_wrapped", "resample"]

#: The environment variable that turns the compiled twins off (value ``0``).
JIT_VARIABLE = "FAULTLAB_JIT"

#: Whether the filters run the compiled twins (``FAULTLAB_JIT`` is not ``0``).
JIT_ENABLED: bool = os.environ.get(JIT_VARIABLE, "1").strip() != "0"

_kernels = None


def _k():
    """The kernels module (imports numba on first use)."""
    global _kernels
    if _kernels is None:
        from faultlab.slam import kernels
        _kernels = kernels
    return _kernels


_F64 = np.dtype(np.float64)


def _pairs(*arrays, ndim: int) -> bool:
    """True if all ``arrays`` are float64 ndarrays (not subclasses) of one shape with ``ndim`` dimensions.

    Called once per unit call, also on tiny arrays (the sharer-order correction calls the units once
    per sharer), so written for speed.
    """
    first = arrays[0]
    if type(first) is not np.ndarray:
        return False
    shape = first.shape
    if len(shape) != ndim:
        return False
    for a in arrays:
        if type(a) is not np.ndarray or a.shape != shape or (a.dtype is not _F64 and a.dtype != _F64):
            return False
    return True


def _kt(a: np.ndarray) -> np.ndarray:
    """The (k, M) view of an (M, k) component array (the transpose)."""
    return a.T


# ---------------------------------------------------------------------------------------------
# unit twins (signatures and results of the reference units)
# ---------------------------------------------------------------------------------------------


def sample_controls(u: np.ndarray, n: int, rng: np.random.Generator, config) -> np.ndarray:
    """Twin of :func:`faultlab.slam.units.sample_controls` (the same single draw from ``rng``)."""
    if not (type(u) is np.ndarray and u.shape == (2,) and u.dtype == _F64):
        return _units.sample_controls(u, n, rng, config)
    std = np.array([config.std_v, config.std_omega])
    if std.dtype != _F64:
        return _units.sample_controls(u, n, rng, config)
    eps = rng.standard_normal((n, 2))
    out = np.empty((n, 2))
    _k().noisy_controls(u, eps, std[0], std[1], out)
    return out


def motion_model(poses: np.ndarray, u: np.ndarray, *, wrap) -> np.ndarray:
    """Twin of :func:`faultlab.slam.units.motion_model` (``cos`` and ``sin`` by numpy; with the
    reference heading wrap only, any other ``wrap`` runs the numpy unit with it)."""
    if not (wrap is _units.wrap_heading and type(poses) is np.ndarray and poses.dtype == _F64
            and poses.ndim == 2 and poses.shape[1] == 3 and type(u) is np.ndarray and u.dtype == _F64
            and u.shape == (poses.shape[0], 2)):
        return _units.motion_model(poses, u, wrap=wrap)
    th = poses[:, 2]
    out = np.empty_like(poses)
    _k().motion(poses, u, np.cos(th), np.sin(th), out)
    return out


def predict_measurement(poses: np.ndarray, mu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Twin of :func:`faultlab.slam.units.predict_measurement` (``arctan2`` by numpy)."""
    if not (_pairs(mu, ndim=3) and mu.shape[2] == 2 and isinstance(poses, np.ndarray) and poses.dtype == np.float64
            and poses.shape == (mu.shape[0], 3)):
        return _units.predict_measurement(poses, mu)
    kn = _k()
    n, k = mu.shape[:2]
    dx = np.empty((k, n))
    dy = np.empty((k, n))
    kn.offsets(poses, _kt(mu[..., 0]), _kt(mu[..., 1]), dx, dy)
    bearing = np.arctan2(dy, dx)
    zbuf, zhat = _vec2((n, k))
    hbuf, H = _mat22((n, k))
    kn.measurement(poses, dx, dy, bearing, zbuf[0], zbuf[1], hbuf[0, 0], hbuf[0, 1], hbuf[1, 0], hbuf[1, 1])
    return zhat, H


def innovation(z: np.ndarray, zhat: np.ndarray, *, wrap) -> np.ndarray:
    """Twin of :func:`faultlab.slam.units.innovation` (with the reference wrap only; any other
    ``wrap`` runs the numpy unit with it)."""
    if not (wrap is _units.wrap_bearing and _pairs(zhat, ndim=3) and zhat.shape[2] == 2
            and isinstance(z, np.ndarray) and z.dtype == np.float64 and z.shape == (zhat.shape[1], 2)):
        return _units.innovation(z, zhat, wrap=wrap)
    n, k = zhat.shape[:2]
    buf, nu = _vec2((n, k))
    _k().innovation_pairs(z, _kt(zhat[..., 0]), _kt(zhat[..., 1]), buf[0], buf[1])
    return nu


def noise_entries(Q) -> tuple[float, float, float, bool]:
    """The entries the kernels read of the measurement noise ``Q`` (2, 2): ``(Q[0, 0], Q[0, 1],
    Q[1, 1], Q[0, 1] != 0)`` (the last: whether the reference adds ``Q[0, 1]`` at all)."""
    Q = np.asarray(Q)
    return float(Q[0, 0]), float(Q[0, 1]), float(Q[1, 1]), bool(Q[0, 1] != 0.0)


def innovation_covariance(H: np.ndarray, P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """Twin of :func:`faultlab.slam.units.innovation_covariance` (the covariance sandwich)."""
    if not (_pairs(H, P, ndim=4) and H.shape[2:] == (2, 2) and np.shape(Q) == (2, 2)
            and np.asarray(Q).dtype == np.float64):
        return _units.innovation_covariance(H, P, Q)
    n, k = H.shape[:2]
    buf, S = _mat22((n, k))
    q00, q01, q11, add = noise_entries(Q)
    _k().sandwich(_kt(H[..., 0, 0]), _kt(H[..., 0, 1]), _kt(H[..., 1, 0]), _kt(H[..., 1, 1]),
                  _kt(P[..., 0, 0]), _kt(P[..., 0, 1]), _kt(P[..., 1, 1]), q00, q01, q11, add,
                  buf[0, 0], buf[0, 1], buf[1, 1])
    buf[1, 0] = buf[0, 1]
    return S


def log_likelihood(nu: np.ndarray, S: np.ndarray) -> np.ndarray:
    """Twin of :func:`faultlab.slam.units.log_likelihood` (``log`` by numpy)."""
    if not (_pairs(nu, ndim=3) and nu.shape[2] == 2 and _pairs(S, ndim=4) and S.shape == nu.shape[:2] + (2, 2)):
        return _units.log_likelihood(nu, S)
    kn = _k()
    n, k = nu.shape[:2]
    t = np.empty((k, n))
    det = np.empty((k, n))
    kn.quadratic_form(_kt(nu[..., 0]), _kt(nu[..., 1]), _kt(S[..., 0, 0]), _kt(S[..., 0, 1]), _kt(S[..., 1, 1]),
                      t, det)
    kn.finish_log_likelihood(t, np.log(det, out=det))
    return t.T


def ekf_update(mu: np.ndarray, P: np.ndarray, H: np.ndarray, S: np.ndarray,
               nu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Twin of :func:`faultlab.slam.units.ekf_update`."""
    if not (_pairs(mu, nu, ndim=3) and mu.shape[2] == 2 and _pairs(P, H, S, ndim=4)
            and P.shape == mu.shape[:2] + (2, 2)):
        return _units.ekf_update(mu, P, H, S, nu)
    n, k = mu.shape[:2]
    mbuf, mu_new = _vec2((n, k))
    pbuf, P_new = _mat22((n, k))
    _k().ekf_correction(_kt(mu[..., 0]), _kt(mu[..., 1]), _kt(P[..., 0, 0]), _kt(P[..., 0, 1]), _kt(P[..., 1, 1]),
                        _kt(H[..., 0, 0]), _kt(H[..., 0, 1]), _kt(H[..., 1, 0]), _kt(H[..., 1, 1]),
                        _kt(S[..., 0, 0]), _kt(S[..., 0, 1]), _kt(S[..., 1, 1]), _kt(nu[..., 0]), _kt(nu[..., 1]),
                        mbuf[0], mbuf[1], pbuf[0, 0], pbuf[0, 1], pbuf[1, 1])
    pbuf[1, 0] = pbuf[0, 1]
    return mu_new, P_new


def predict_measurement_wrapped(poses: np.ndarray, mu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Twin of :func:`faultlab.slam.paperunits.predict_measurement_wrapped` (the paper's measurement model)."""
    zhat, H = predict_measurement(poses, mu)
    zhat[..., 1] = _units._wrap(zhat[..., 1])
    return zhat, H


def log_likelihood_wrapped(nu: np.ndarray, S: np.ndarray) -> np.ndarray:
    """Twin of :func:`faultlab.slam.paperunits.log_likelihood_wrapped` (the paper's weight)."""
    nu = np.array(nu, dtype=float)
    nu[..., 1] = _units._wrap(nu[..., 1])
    return log_likelihood(nu, S)


def resample(w: np.ndarray, n_eff: float, empty: bool, rng: np.random.Generator, config) -> np.ndarray | None:
    """Twin of :func:`faultlab.slam.units.resample` (same decision, same single draw from ``rng``)."""
    n = w.shape[0]
    if empty or n_eff >= n / config.resample_ratio:
        return None
    if not (isinstance(w, np.ndarray) and w.dtype == np.float64 and w.ndim == 1 and np.minimum.reduce(w) >= 0.0):
        return _units.low_variance_indices(w, rng)  # NaN or negative weights: numpy's search
    r = rng.uniform(0.0, 1.0 / n)
    out = np.empty(n, dtype=np.intp)
    _k().systematic_indices(w, r, out)
    return out


#: Reference unit (or alternative unit of the paper's filter) -> its compiled twin.
TWINS: dict[Callable, Callable] = {
    _units.sample_controls: sample_controls,
    _units.motion_model: motion_model,
    _units.predict_measurement: predict_measurement,
    _units.innovation: innovation,
    _units.innovation_covariance: innovation_covariance,
    _units.log_likelihood: log_likelihood,
    _units.ekf_update: ekf_update,
    _paperunits.predict_measurement_wrapped: predict_measurement_wrapped,
    _paperunits.log_likelihood_wrapped: log_likelihood_wrapped,
    _units.resample: resample,
}

#: The units that :func:`correct_pairs` fuses (with ``wrap_bearing``, which ``innovation`` calls).
FUSED_UNITS: tuple[str, ...] = ("predict_measurement", "innovation", "wrap_bearing", "innovation_covariance",
                                "log_likelihood", "ekf_update")


def twinned(table):
    """``table`` (a unit table, :class:`~faultlab.slam.bookkeeping.UnitTable`) with every reference unit
    that has a twin replaced by it; the table itself if no slot holds such a unit.

    The filters call it only when :data:`JIT_ENABLED`.
    """
    swaps = {f.name: TWINS[getattr(table, f.name)] for f in dataclasses.fields(table)
             if getattr(table, f.name) in TWINS}
    return dataclasses.replace(table, **swaps) if swaps else table


def fused(table) -> bool:
    """Whether :func:`correct_pairs` may do the work of ``table``'s correction units: every unit of
    :data:`FUSED_UNITS` is the reference (or its twin).  The filters ask only when :data:`JIT_ENABLED`."""
    for name in FUSED_UNITS:
        fn = getattr(table, name, None)
        ref = getattr(_units, name)
        if fn is not ref and fn is not TWINS.get(ref):
            return False
    return True


def correct_pairs(x: np.ndarray, z: np.ndarray, mb: np.ndarray, pb: np.ndarray,
                  Q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The reference correction of M particles x k observations in one fused pass.

    Equals, bit for bit, ``predict_measurement``, ``innovation`` (with ``wrap_bearing``),
    ``innovation_covariance``, ``log_likelihood`` and ``ekf_update`` of
    :mod:`faultlab.slam.units` called in that order.

    Parameters
    ----------
    x : ndarray, shape (M, 3)
        Poses.
    z : ndarray, shape (k, 2)
        Observations (range, bearing).
    mb : ndarray, shape (2, k, M)
        Landmark means, component-major (the filter's gathered layout).
    pb : ndarray, shape (2, 2, k, M)
        Landmark covariances (symmetric; ``pb[0, 1]`` is read for both off-diagonal entries).
    Q : ndarray, shape (2, 2)

    Returns
    -------
    loglik : ndarray, shape (M, k)
    mu_new : ndarray, shape (2, k, M)
    P_new : ndarray, shape (2, 2, k, M)
    """
    kn = _k()
    k, m = mb.shape[1:]
    dx = np.empty((k, m))
    dy = np.empty((k, m))
    kn.offsets(x, mb[0], mb[1], dx, dy)
    bearing = np.arctan2(dy, dx)
    mu_new = np.empty((2, k, m))
    P_new = np.empty((2, 2, k, m))
    q00, q01, q11, add = noise_entries(Q)
    t = np.empty((k, m))
    det = np.empty((k, m))
    kn.fused_correction(x, z, mb, pb, dx, dy, bearing, q00, q01, q11, add, mu_new, P_new, t, det)
    kn.finish_log_likelihood(t, np.log(det, out=det))
    return t.T, mu_new, P_new


def predict_poses(poses: np.ndarray, u: np.ndarray, eps: np.ndarray | None, config) -> np.ndarray:
    """``motion_model(poses, sample_controls(u, ...))`` of the reference units, after the draw.

    Equals, bit for bit, :func:`faultlab.slam.units.motion_model` (with ``wrap_heading``) applied
    to the noisy controls ``u + eps * (std_v, std_omega)`` of
    :func:`faultlab.slam.units.sample_controls` whose draw ``rng.standard_normal((N, 2))`` is
    ``eps``, or to ``u`` itself for every particle when ``eps`` is None (an empty update).

    Parameters
    ----------
    poses : ndarray, shape (N, 3)
    u : ndarray, shape (2,)
    eps : ndarray, shape (N, 2), or None
    config : FastSlamConfig
        Supplies ``std_v`` and ``std_omega``.

    Returns
    -------
    ndarray, shape (N, 3)
    """
    th = poses[:, 2]
    out = np.empty((poses.shape[0], 3))
    noisy = eps is not None
    _k().predict_poses(poses, u, eps if noisy else _NO_DRAWS, noisy, float(config.std_v), float(config.std_omega),
                       np.cos(th), np.sin(th), out)
    return out


_NO_DRAWS = np.empty((0, 2))
_NO_INIT_MU = np.empty((2, 0, 0))
_NO_INIT_P = np.empty((2, 2, 0, 0))


def _observed_inputs(cols, seen, init) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``cols`` and ``seen`` in the kernels' dtypes, and ``init_landmarks``' ``(mu, P)`` in the
    kernels' pair-last layout ((2, k_new, M) and (2, 2, k_new, M)); placeholders when ``init`` is None."""
    cols = np.asarray(cols, dtype=np.intp)
    seen = np.asarray(seen, dtype=np.bool_)
    if init is None:
        return cols, seen, _NO_INIT_MU, _NO_INIT_P
    mi = np.ascontiguousarray(np.asarray(init[0], dtype=float).transpose(2, 1, 0))
    pi = np.ascontiguousarray(np.asarray(init[1], dtype=float).transpose(2, 3, 1, 0))
    return cols, seen, mi, pi


def correct_observed(poses: np.ndarray, z: np.ndarray, cols: np.ndarray, seen: np.ndarray,
                     init: tuple[np.ndarray, np.ndarray] | None, q: tuple[float, float, float, bool],
                     logw: np.ndarray, n: int, mu_store: np.ndarray, P_store: np.ndarray,
                     anc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The correction of every particle by the reference units, writing the storage in place.

    Equals, bit for bit, what the filter does with the reference units in a step with
    observations: gather the stored landmarks of ``cols``, put ``init_landmarks``'s values where
    new, ``predict_measurement``, ``innovation``, ``innovation_covariance``, ``log_likelihood``,
    ``ekf_update``, the write-back of every particle's new landmarks into its own storage row,
    ``combine_weights`` (``known[i, j] = seen[j]``) and the first half of the normalisation,
    ``logw - max(logw)``, of each filter of ``n`` particles.  numpy's ``arctan2`` and ``log`` are
    called once each on all pairs.

    Parameters
    ----------
    poses : ndarray, shape (M, 3)
        Predicted poses of all particles (filters of ``n`` side by side).
    z : ndarray, shape (k, 2)
    cols : ndarray of intp, shape (k,)
        Storage columns of the observations (distinct: an id is observed at most once per step).
    seen : ndarray of bool, shape (k,)
        Whether each observation's landmark was seen before.
    init : (mu (M, k_new, 2), P (M, k_new, 2, 2)) or None
        ``init_landmarks(poses, z[flatnonzero(~seen)], Q, wrap=wrap_bearing)`` (None if every
        landmark was seen).
    q : tuple
        ``noise_entries(Q)`` of the measurement noise ``Q`` (2, 2).
    logw : ndarray, shape (M,), or None
        Normalised log weights before the step; None returns the log likelihoods instead.
    n : int
        Particles per filter.
    mu_store, P_store, anc : ndarray
        The filter's storage (2, cap, M), (2, 2, cap, M) and materialised ancestry (M, cap) (:func:`~faultlab.slam.particles.ancestry_dtype`);
        updated in place.

    Returns
    -------
    shifted : ndarray, shape (M,)
        ``combine_weights(logw, loglik, known)`` minus its maximum, per filter (unshifted where the
        maximum is not finite).
    tops : ndarray, shape (M // n,)
        The maximum of each filter.

    With ``logw`` None: ``(loglik, None)``, ``loglik`` (M, k) the ``log_likelihood`` of every pair
    (the transpose of a (k, M) array, the layout of :func:`correct_pairs`' result).
    """
    kn = _k()
    k, m = z.shape[0], poses.shape[0]
    cols, seen, mi, pi = _observed_inputs(cols, seen, init)
    rows = np.empty((k, m), dtype=np.intp)
    mb = np.empty((2, k, m))
    dx = np.empty((k, m))
    dy = np.empty((k, m))
    kn.gather_observed(mu_store, anc, cols, seen, mi, poses, n, rows, mb, dx, dy)
    bearing = np.arctan2(dy, dx)
    q00, q01, q11, add = q
    # the kernel reads each pair's dy and bearing before it writes its det and t: they share memory
    t, det = bearing, dy
    kn.correct_observed(poses, z, seen, mb, rows, pi, dx, dy, bearing, q00, q01, q11, add, cols, n,
                        mu_store, P_store, anc, t, det)
    np.log(det, out=det)
    if logw is None:  # the log likelihoods themselves, for a replaced combine_weights
        kn.finish_log_likelihood(t, det)
        return t.T, None
    return combine_pairs(t, det, seen, logw, n)


def finish_log_likelihood(t: np.ndarray, log_det: np.ndarray) -> None:
    """``log_likelihood``'s last operations, in place: ``t = (t + log_det) * -0.5 - log(2 pi)`` (k, M)."""
    _k().finish_log_likelihood(t, log_det)


def combine_pairs(t: np.ndarray, log_det: np.ndarray, seen: np.ndarray, logw: np.ndarray,
                  n: int) -> tuple[np.ndarray, np.ndarray]:
    """``log_likelihood``'s last operations on the quadratic forms ``t`` and numpy's ``log`` of the
    determinants ``log_det`` (k, M), then ``combine_weights`` (``known[i, j] = seen[j]``) and the
    first half of the normalisation of each filter of ``n``: the ``(shifted, tops)`` of
    :func:`correct_observed` (see :func:`faultlab.slam.kernels.combine_observed`)."""
    m = t.shape[1]
    shifted = np.empty(m)
    tops = np.empty(m // n)
    _k().combine_observed(t, log_det, np.asarray(seen, dtype=np.bool_), logw, n, shifted, tops)
    return shifted, tops


#: The correction units a staged correction (:func:`correct_staged`) can run a replacement of, in
#: the order the correction calls them: the stage of each (``wrap_bearing`` is called by ``innovation``).
STAGES: dict[str, int] = {"predict_measurement": 0, "innovation": 1, "wrap_bearing": 1, "innovation_covariance": 2,
                          "log_likelihood": 3, "ekf_update": 4}


def staged(table) -> int | None:
    """The stage (:data:`STAGES`) whose unit :func:`correct_staged` calls for ``table``: the one stage
    whose units are not all the references (or their twins) when every other correction unit is;
    None when every one is (the fused correction) or several stages are replaced."""
    replaced = {STAGES[name] for name in FUSED_UNITS
                if getattr(table, name, None) is not getattr(_units, name)
                and getattr(table, name, None) is not TWINS.get(getattr(_units, name))}
    return replaced.pop() if len(replaced) == 1 else None


def _float_pairs(a, shape: tuple[int, ...]) -> bool:
    """Whether ``a`` is a float64 ndarray (not a subclass) of ``shape``: what the twins take."""
    return type(a) is np.ndarray and a.shape == shape and (a.dtype is _F64 or a.dtype == _F64)


_NO_PAIRS = np.empty((0, 0))


def correct_staged(stage: int, unit: Callable, poses: np.ndarray, z: np.ndarray, cols: np.ndarray, seen: np.ndarray,
                   init: tuple[np.ndarray, np.ndarray] | None, q: tuple[float, float, float, bool], n: int,
                   mu_store: np.ndarray, P_store: np.ndarray, anc: np.ndarray):
    """The correction of every particle with one correction unit replaced, writing the storage in place.

    Equals, bit for bit, the filter's unit-by-unit correction (gather, ``init_landmarks``' values
    where new, ``predict_measurement``, ``innovation``, ``innovation_covariance``,
    ``log_likelihood``, ``ekf_update``, write-back into every particle's own row) when the units of
    ``stage`` (:data:`STAGES`) are replaced by ``unit`` and every other one is the reference: the
    stages before the replaced one run as their twins' kernels (into arrays of the layout the twins
    return, which ``unit`` receives), ``unit`` is called once on all pairs, and the stages after it
    run in one pass with the write-back (:func:`faultlab.slam.kernels.finish_staged`).

    ``unit`` is called with the arguments of the replaced unit that vary per step: ``(poses, mu)``,
    ``(z, z_hat)`` (``innovation`` with its ``wrap`` bound), ``(H, P)`` (``Q`` bound), ``(nu, S)``
    or ``(mu, P, H, S, nu)``.  The other arguments are those of :func:`correct_observed`.

    Returns ``(t, det)`` (k, M), the quadratic form and ``det S`` of every pair as written by
    :func:`correct_observed` (before numpy's ``log`` of ``det``), or at the ``log_likelihood``
    stage ``(loglik, None)``, the unit's (M, k) result; None, with nothing written, when the unit
    returned anything but float64 arrays of the documented shapes (the filter then runs its
    unit-by-unit path, which hands such values to the numpy units).
    """
    kn = _k()
    k, m = z.shape[0], poses.shape[0]
    cols, seen, mi, pi = _observed_inputs(cols, seen, init)
    mb = np.empty((2, k, m))
    pb = np.empty((2, 2, k, m))
    dx = np.empty((k, m))
    dy = np.empty((k, m))
    kn.gather_landmarks(mu_store, P_store, anc, cols, seen, mi, pi, poses, n, mb, pb, dx, dy)
    mu = mb.transpose(2, 1, 0)  # the (M, k, 2) and (M, k, 2, 2) views the units see
    P = pb.transpose(3, 2, 0, 1)
    vec, mat = (m, k, 2), (m, k, 2, 2)
    none = _NO_PAIRS
    a = b = s = e = (none,) * 4
    t = det = none
    if stage == 0:
        out = unit(poses, mu)
        if not (type(out) is tuple and len(out) == 2 and _float_pairs(out[0], vec) and _float_pairs(out[1], mat)):
            return None
        zhat, H = out
        a = (_kt(zhat[..., 0]), _kt(zhat[..., 1]))
    else:
        hbuf = np.empty((2, 2, k, m))
        zbuf = np.empty((2, k, m))
        kn.measurement(poses, dx, dy, np.arctan2(dy, dx), zbuf[0], zbuf[1], hbuf[0, 0], hbuf[0, 1], hbuf[1, 0],
                       hbuf[1, 1])
        H = hbuf.transpose(3, 2, 0, 1)
        if stage == 1:
            nu = unit(z, zbuf.transpose(2, 1, 0))
            if not _float_pairs(nu, vec):
                return None
        else:
            nbuf = np.empty((2, k, m))
            kn.innovation_pairs(z, zbuf[0], zbuf[1], nbuf[0], nbuf[1])
            nu = nbuf.transpose(2, 1, 0)
            if stage == 2:
                S = unit(H, P)
                if not _float_pairs(S, mat):
                    return None
            else:
                sbuf = np.empty((2, 2, k, m))
                q00, q01, q11, add = q
                kn.sandwich(hbuf[0, 0], hbuf[0, 1], hbuf[1, 0], hbuf[1, 1], pb[0, 0], pb[0, 1], pb[1, 1],
                            q00, q01, q11, add, sbuf[0, 0], sbuf[0, 1], sbuf[1, 1])
                sbuf[1, 0] = sbuf[0, 1]
                S = sbuf.transpose(3, 2, 0, 1)
                if stage == 3:
                    loglik = unit(nu, S)
                    if not _float_pairs(loglik, (m, k)):
                        return None
                else:
                    t = np.empty((k, m))
                    det = np.empty((k, m))
                    kn.quadratic_form(nbuf[0], nbuf[1], sbuf[0, 0], sbuf[0, 1], sbuf[1, 1], t, det)
                    out = unit(mu, P, H, S, nu)
                    if not (type(out) is tuple and len(out) == 2 and _float_pairs(out[0], vec)
                            and _float_pairs(out[1], mat)):
                        return None
                    mu_new, P_new = out
                    a = (_kt(mu_new[..., 0]), _kt(mu_new[..., 1]))
                    e = (_kt(P_new[..., 0, 0]), _kt(P_new[..., 0, 1]), _kt(P_new[..., 1, 0]), _kt(P_new[..., 1, 1]))
            s = (_kt(S[..., 0, 0]), _kt(S[..., 0, 1]), _kt(S[..., 1, 1]))
        b = (_kt(nu[..., 0]), _kt(nu[..., 1]))
    if stage < 3:
        t = np.empty((k, m))
        det = np.empty((k, m))
    q00, q01, q11, add = q
    kn.finish_staged(stage, z, seen, mb, pb, _kt(H[..., 0, 0]), _kt(H[..., 0, 1]), _kt(H[..., 1, 0]),
                     _kt(H[..., 1, 1]), a[0], a[1], b[0], b[1], s[0], s[1], s[2], e[0], e[1], e[2], e[3],
                     q00, q01, q11, add, cols, n, mu_store, P_store, anc, t, det)
    return (loglik, None) if stage == 3 else (t, det)


def correct_in_sharer_order(steps, logw: np.ndarray, owner: np.ndarray, poses: np.ndarray, z: np.ndarray,
                            seen: np.ndarray, mu: np.ndarray, P: np.ndarray,
                            Q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Twin of :func:`faultlab.slam.sharing.correct_in_sharer_order` for a table whose correction units
    (:data:`FUSED_UNITS`) and ``classify_new`` are the references; any other table runs the numpy one.

    The same loop over the sharers' ranks, each rank one call of :func:`faultlab.slam.kernels.sharer_rank`
    after numpy's ``arctan2`` of its pairs: the chain from one sharer to the next goes through the
    bearing, so ``arctan2`` is called once per rank, on that rank's pairs.  The ``log`` of
    ``log_likelihood`` does not feed the chain and is called once, on all pairs, after the loop;
    ``init_landmarks`` (called once, for the first sharers, as by the numpy loop) and
    ``combine_weights`` are the table's own units.  Returns the numpy function's outputs bit for bit.
    """
    if not (fused(steps) and steps.classify_new is _units.classify_new and _pairs(mu, ndim=3)
            and _pairs(P, ndim=4) and type(poses) is np.ndarray and poses.dtype == _F64
            and type(z) is np.ndarray and z.dtype == _F64 and mu.shape[2:] == (2,) and P.shape[2:] == (2, 2)):
        return _sharing.correct_in_sharer_order(steps, logw, owner, poses, z, seen, mu, P, Q)
    kn = _k()
    n, k = mu.shape[:2]
    group, rank, order = _sharing.sharer_ranks(owner)
    by_rank = order[np.argsort(rank[order], kind="stable")]
    bounds = np.searchsorted(rank[by_rank], np.arange(int(rank.max()) + 2))
    first = by_rank[:bounds[1]]  # the first sharer of every group, by group
    g = np.empty((6, k, first.size))  # every group's landmarks, component-major
    g[0:2] = mu[first].transpose(2, 1, 0)
    g[2:6] = P[first].transpose(2, 3, 1, 0).reshape(4, k, first.size)
    seen = np.asarray(seen, dtype=bool)
    if not seen.all():  # the first sharers initialise the never-seen landmarks
        c = np.flatnonzero(~seen)
        mu0, P0 = steps.init_landmarks(poses[first], z[c], Q, wrap=steps.wrap_bearing)
        g[0:2, c] = np.asarray(mu0, dtype=float).transpose(2, 1, 0)
        g[2:6, c] = np.asarray(P0, dtype=float).transpose(2, 3, 1, 0).reshape(4, c.size, first.size)
    q00, q01, q11, add = noise_entries(Q)
    ints = np.concatenate([bounds, by_rank, group, seen]).astype(np.intp, copy=False)
    consts = np.concatenate([np.asarray(poses, dtype=float).ravel(), z.ravel(), [q00, q01, q11, 1.0 if add else 0.0]])
    work = np.empty((3, n, k))
    out = np.empty((2, n, k))
    step = kn.sharer_rank
    step(-1, ints, consts, g, work, out)
    arctan2 = np.arctan2
    views = {}  # rank size -> the views of (dx, dy, bearing) that numpy's arctan2 reads and writes
    for t, size in enumerate(np.diff(bounds).tolist()):
        v = views.get(size)
        if v is None:
            v = views[size] = (work[1, :size], work[0, :size], work[2, :size])
        arctan2(v[0], v[1], out=v[2])
        step(t, ints, consts, g, work, out)
    loglik, det = out
    kn.finish_log_likelihood(loglik, np.log(det, out=det))
    known = np.ones((n, k), dtype=bool)
    known[first] = seen
    logw = np.asarray(steps.combine_weights(logw, loglik, known), dtype=float)
    gm = g[:, :, group]  # (6, k, N): every particle's row after the step
    return logw, gm[0:2].transpose(2, 1, 0), gm[2:6].reshape(2, 2, k, n).transpose(3, 2, 0, 1)


def gather_rows(mu_store: np.ndarray, P_store: np.ndarray, anc: np.ndarray, cols: np.ndarray, p0: int, n: int,
                mb: np.ndarray, pb: np.ndarray) -> None:
    """Copy the stored landmarks of ``cols`` (k,) for particles ``p0 ..`` into ``mb`` (2, k, M) and
    ``pb`` (2, 2, k, M) (the filter's gather; see :func:`faultlab.slam.kernels.gather_pairs`)."""
    _k().gather_pairs(mu_store, P_store, anc, np.asarray(cols, dtype=np.intp), p0, n, mb, pb)


def scatter_rows(mu_new: np.ndarray, P_new: np.ndarray, cols: np.ndarray, p0: int, owner: np.ndarray,
                 mu_store: np.ndarray, P_store: np.ndarray, anc: np.ndarray) -> None:
    """Write new landmarks of ``cols`` into each particle's own storage row and point ``anc`` at
    ``owner`` (the filter's write-back; see :func:`faultlab.slam.kernels.scatter_pairs`)."""
    _k().scatter_pairs(mu_new, P_new, np.asarray(cols, dtype=np.intp), p0, np.asarray(owner, dtype=np.intp),
                       mu_store, P_store, anc)


def take_rows(src: np.ndarray, rows: np.ndarray, dst: np.ndarray, width: int) -> None:
    """``dst[i, :width] = src[rows[i], :width]`` for 2-D ``src`` and ``dst`` (the filter's ancestry gather)."""
    _k().take_rows(src, np.asarray(rows, dtype=np.intp), dst, width)


_warmed = False


def warm_up() -> float:
    """Compile (or load from the cache) every kernel on a tiny input, once per process.

    Called by a campaign's job executors before they start the clock of their first job, so that
    no execution's runtime includes the compilation.  Returns the seconds it took (0 when JIT is
    off or the kernels are already loaded).
    """
    global _warmed
    if not JIT_ENABLED or _warmed:
        return 0.0
    import time

    t0 = time.perf_counter()
    rng = np.random.default_rng(0)
    n, k = 2, 2
    poses = rng.normal(size=(n, 3))
    mu = rng.normal(size=(n, k, 2))
    Q = np.diag([0.1, 0.01])
    z = np.abs(rng.normal(size=(k, 2)))
    P0 = np.broadcast_to(np.eye(2), (n, k, 2, 2)).copy()
    u = np.array([0.5, 0.1])
    config = type("Noise", (), {"std_v": 0.1, "std_omega": 0.01})
    motion_model(poses, sample_controls(u, n, rng, config), wrap=_units.wrap_heading)
    motion_model(poses, np.broadcast_to(u, (n, 2)), wrap=_units.wrap_heading)
    zhat, H = predict_measurement(poses, mu)
    nu = innovation(z, zhat, wrap=_units.wrap_bearing)
    S = innovation_covariance(H, P0, Q)
    log_likelihood(nu, S)
    ekf_update(mu, P0, H, S, nu)
    mb = np.ascontiguousarray(mu.transpose(2, 1, 0))
    pb = np.ascontiguousarray(P0.transpose(2, 3, 1, 0))
    _, mu_new, P_new = correct_pairs(poses, z, mb, pb, Q)
    store_mu, store_P = np.zeros((2, 4, n)), np.zeros((2, 2, 4, n))
    anc = np.zeros((n, 4), dtype=_particles.ancestry_dtype(n))  # the type the filter stores
    cols = np.arange(k, dtype=np.intp)
    scatter_rows(mu_new, P_new, cols, 0, np.arange(n, dtype=np.intp), store_mu, store_P, anc)
    gather_rows(store_mu, store_P, anc, cols, 0, n, mb, pb)
    take_rows(anc, np.arange(n)[::-1], np.empty_like(anc), k)
    x = predict_poses(poses, u, rng.standard_normal((n, 2)), config)
    predict_poses(x, u, None, config)
    seen = np.array([True, False])
    new = np.flatnonzero(~seen)
    logw = np.full(n, -math.log(n))
    correct_observed(x, z, cols, seen, _units.init_landmarks(x, z[new], Q, wrap=_units.wrap_bearing),
                     noise_entries(Q), logw, n, store_mu, store_P, anc)
    correct_observed(x, z, cols, np.ones(k, dtype=bool), None, noise_entries(Q), logw, n, store_mu, store_P, anc)
    _k().systematic_indices(np.full(n, 1.0 / n), 0.1, np.empty(n, dtype=np.intp))
    reference = SimpleNamespace(**{name: getattr(_units, name) for name in FUSED_UNITS + (
        "classify_new", "init_landmarks", "combine_weights")})
    correct_in_sharer_order(reference, logw, np.zeros(n, dtype=np.intp), x, z, seen, mu, P0, Q)
    _warmed = True
    return time.perf_counter() - t0
