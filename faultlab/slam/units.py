"""The reference units of FastSLAM 1.0 (Probabilistic Robotics, Table 13.1).

Every function here is one replaceable unit of :class:`faultlab.slam.fastslam.FastSlamSteps`.
Each is a pure function over arrays for *all* particles ``N`` and all of a step's observations
``k`` at once; 2 x 2 matrix algebra is written out with explicit formulas (much faster than
``np.linalg`` on millions of tiny matrices).  The docstrings give the exact signatures and shapes
a replacement (a fault) must honour.

Layout: the reference units return arrays of the documented shapes (e.g. ``H`` of shape
(N, k, 2, 2)) as views of *component-major* buffers (shape (2, 2, k, N), the same order as the
landmark storage), so that ``H[..., 0, 1]`` is one contiguous block and the elementwise formulas
run at full memory speed.  This is invisible to
callers: every unit accepts inputs in any memory layout, and a replacement may return ordinary
C-ordered arrays.

Randomness: the units named in :data:`~faultlab.slam.contract.STREAM_UNITS` take an ``rng`` argument.  The filter gives
each of them its *own* :class:`numpy.random.Generator`, derived from the SLAM's seed by unit name
(:func:`faultlab.slam.streams.unit_streams`), so a replacement that draws more, fewer or other
random numbers changes no other unit's draws (common random numbers by unit).  A replacement
must draw only from the ``rng`` it is given; no other unit may draw random numbers.

The particle state the units work on is :class:`faultlab.slam.particles.ParticleState`; which
units a batch of repetitions calls with which particles is the unit contract of
:mod:`faultlab.slam.contract`.  The units of the paper's FastSLAM 1.0 are in
:mod:`faultlab.slam.paperunits`, those of unknown data association in
:mod:`faultlab.slam.associationunits`.
"""

from __future__ import annotations

import math

import numpy as np

from faultlab.slam.particles import ParticleState

__all__ = [
    "sample_controls",
    "motion_model",
    "wrap_heading",
    "wrap_bearing",
    "init_landmarks",
    "classify_new",
    "predict_measurement",
    "innovation",
    "innovation_covariance",
    "log_likelihood",
    "combine_weights",
    "ekf_update",
    "effective_sample_size",
    "resample",
    "low_variance_indices",
    "apply_resample",
    "extract_map",
]

_TWO_PI = 2.0 * math.pi
_INV_TWO_PI = 1.0 / _TWO_PI
_LOG_TWO_PI = math.log(_TWO_PI)


def _vec2(shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """A zero-filled ``shape + (2,)`` array stored component-major, other axes reversed.

    Returns ``(buf, view)``: ``buf`` has shape ``(2,) + shape[::-1]`` (for
    ``shape = (N, k)`` each component is a contiguous (k, N) block: all
    particles of one observation side by side, matching the landmark
    storage) and ``view`` is the same memory with the documented shape
    ``shape + (2,)``.

    Every array a unit returns is zero-filled, not ``np.empty``: a mutant or fault that leaves
    an entry unwritten then gives the same result on every run, never whatever an earlier
    computation left in that memory.
    """
    nd = len(shape)
    buf = np.zeros((2,) + tuple(shape)[::-1])
    return buf, buf.transpose(tuple(range(nd, 0, -1)) + (0,))


def _mat22(shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """A zero-filled ``shape + (2, 2)`` array, stored as ``(2, 2) + shape[::-1]``: ``(buf, view)``."""
    nd = len(shape)
    buf = np.zeros((2, 2) + tuple(shape)[::-1])
    return buf, buf.transpose(tuple(range(nd + 1, 1, -1)) + (0, 1))


def _scratch(shape: tuple[int, ...], m: int) -> list[np.ndarray]:
    """``m`` uninitialised work arrays of ``shape``, in the same (reversed) order as :func:`_vec2`.

    One allocation for all of them; the formulas below write every intermediate
    into these with ``out=`` instead of allocating a temporary per operation.  Never an output:
    a mutant that skips writing one reads memory it never wrote, which screening detects
    (:mod:`faultlab.mutation.screening`: *nondeterministic*, never run).
    """
    nd = len(shape)
    return list(np.empty((m,) + tuple(shape)[::-1]).transpose((0,) + tuple(range(nd, 0, -1))))


def _common_shape(*xs) -> tuple[int, ...]:
    """The broadcast shape of ``xs`` (fast path: all shapes equal)."""
    shapes = [np.shape(x) for x in xs]
    first = shapes[0]
    if all(sh == first for sh in shapes):
        return first
    return np.broadcast_shapes(*shapes)



# ---------------------------------------------------------------------------------------------
# prediction (Table 13.1, line 4: sample the motion model)
# ---------------------------------------------------------------------------------------------


def sample_controls(u: np.ndarray, n: int, rng: np.random.Generator, config) -> np.ndarray:
    """Per-particle noisy controls for the prediction.

    Parameters
    ----------
    u : ndarray, shape (2,)
        The measured control (v, omega).
    n : int
        Number of particles N.
    rng : numpy.random.Generator
        The unit's own stream (:data:`STREAM_UNITS`); consumed as exactly one call
        ``rng.standard_normal((n, 2))``.
    config : FastSlamConfig
        Supplies ``std_v`` and ``std_omega``.

    Returns
    -------
    ndarray, shape (N, 2)
        ``u + eps`` with independent ``eps ~ N(0, diag(std_v^2, std_omega^2))`` per particle.
    """
    eps = rng.standard_normal((n, 2))
    return u[None, :] + eps * np.array([config.std_v, config.std_omega])


def motion_model(poses: np.ndarray, u: np.ndarray, *, wrap) -> np.ndarray:
    """Move every particle by its control (dt = 1).

    ``x' = x + v cos(theta)``, ``y' = y + v sin(theta)``, ``theta' = wrap(theta + omega)``
    (drive along the old heading, then turn; i.e. x' = F x + B(theta) u).

    Parameters
    ----------
    poses : ndarray, shape (N, 3)
    u : ndarray, shape (N, 2)
        Per-particle controls (v, omega).
    wrap : callable
        The heading wrap (``steps.wrap_heading``), applied to theta'.

    Returns
    -------
    ndarray, shape (N, 3)
        New poses (a new array).
    """
    th = poses[:, 2]
    v = u[:, 0]
    out = np.zeros_like(poses)
    out[:, 0] = poses[:, 0] + v * np.cos(th)
    out[:, 1] = poses[:, 1] + v * np.sin(th)
    out[:, 2] = wrap(th + u[:, 1])
    return out


def _wrap(a):
    """``a - 2 pi floor((a + pi) / 2 pi)``, evaluated in one work array."""
    t = np.add(a, math.pi)
    if type(t) is not np.ndarray:  # scalar input
        return a - _TWO_PI * np.floor(t * _INV_TWO_PI)
    t *= _INV_TWO_PI
    np.floor(t, out=t)
    t *= _TWO_PI
    return np.subtract(a, t, out=t)


def wrap_heading(a: np.ndarray) -> np.ndarray:
    """Wrap headings to [-pi, pi): ``a - 2 pi floor((a + pi) / 2 pi)``.  Any shape, same shape out."""
    return _wrap(a)


def wrap_bearing(a: np.ndarray) -> np.ndarray:
    """Wrap bearing angles to [-pi, pi): ``a - 2 pi floor((a + pi) / 2 pi)``.  Any shape, same shape out.

    Used only for the bearing innovation (:func:`innovation`) and for yaw + bearing
    at landmark initialisation (:func:`init_landmarks`); the paper's
    *missing angle wrap* fault replaces exactly this unit.
    """
    return _wrap(a)


# ---------------------------------------------------------------------------------------------
# correction (Table 13.1, lines 7-21)
# ---------------------------------------------------------------------------------------------


def init_landmarks(poses: np.ndarray, z: np.ndarray, Q: np.ndarray, *, wrap) -> tuple[np.ndarray, np.ndarray]:
    """Initialise landmarks from their first observation (Table 13.1, lines 9-11).

    Inverse measurement model ``mu = (x, y) + r (cos a, sin a)`` with
    ``a = wrap(theta + bearing)``; covariance ``G^-1 Q G^-T`` where ``G`` is the
    measurement Jacobian w.r.t. the landmark at ``mu`` (see
    :func:`predict_measurement`); in closed form
    ``G = [[cos a, sin a], [-sin a / r, cos a / r]]`` and
    ``G^-1 = [[cos a, -r sin a], [sin a, r cos a]]``.
    The filter calls it with the observations that have at least one new
    (particle, observation) pair and keeps only the new pairs.

    Parameters
    ----------
    poses : ndarray, shape (N, 3)
    z : ndarray, shape (k, 2)
        Observations (range, bearing).
    Q : ndarray, shape (2, 2)
        Measurement noise covariance diag(std_range^2, std_bearing^2) (symmetric).
    wrap : callable
        The bearing wrap (``steps.wrap_bearing``), applied to theta + bearing.

    Returns
    -------
    mu : ndarray, shape (N, k, 2)
    P : ndarray, shape (N, k, 2, 2)
        Exactly symmetric.
    """
    a = wrap(poses[:, 2:3] + z[None, :, 1])
    r = z[None, :, 0]
    c, s = np.cos(a), np.sin(a)
    _, mu = _vec2(a.shape)
    np.add(poses[:, 0:1], r * c, out=mu[..., 0])
    np.add(poses[:, 1:2], r * s, out=mu[..., 1])
    rc = r * c
    _, P = _sandwich_sym(c, -r * s, s, rc, Q[0, 0], Q[0, 1], Q[1, 1])
    return mu, P


def _sandwich_sym(a, b, c, e, p00, p01, p11) -> tuple[np.ndarray, np.ndarray]:
    """``A P A^T`` for A = [[a, b], [c, e]] and symmetric P = [[p00, p01], [p01, p11]].

    Returns ``(buf (2, 2, ...), view (..., 2, 2))``; the result is exactly symmetric.
    """
    shape = _common_shape(a, b, c, e, p00, p01, p11)
    h00, h01, h10, h11, t = _scratch(shape, 5)
    mul = np.multiply
    mul(a, p00, out=h00)  # (A P)
    h00 += mul(b, p01, out=t)
    mul(a, p01, out=h01)
    h01 += mul(b, p11, out=t)
    mul(c, p00, out=h10)
    h10 += mul(e, p01, out=t)
    mul(c, p01, out=h11)
    h11 += mul(e, p11, out=t)
    buf, out = _mat22(shape)
    o00, o01, o11 = out[..., 0, 0], out[..., 0, 1], out[..., 1, 1]
    mul(h00, a, out=o00)
    o00 += mul(h01, b, out=t)
    mul(h00, c, out=o01)
    o01 += mul(h01, e, out=t)
    out[..., 1, 0] = o01
    mul(h10, c, out=o11)
    o11 += mul(h11, e, out=t)
    return buf, out


def classify_new(seen: np.ndarray, mu: np.ndarray) -> np.ndarray:
    """Which (particle, observation) pairs initialise a new landmark.

    Parameters
    ----------
    seen : ndarray of bool, shape (k,)
        Whether each observed id was observed in an earlier step.
    mu : ndarray, shape (N, k, 2)
        The particles' stored means of the observed landmarks (zeros for
        never-seen landmarks).

    Returns
    -------
    ndarray of bool, shape (N, k)
        Reference: ``~seen`` for every particle (ids never seen before are new).
    """
    return np.broadcast_to(~np.asarray(seen, dtype=bool)[None, :], mu.shape[:2])


def predict_measurement(poses: np.ndarray, mu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Predicted measurement and its Jacobian w.r.t. the landmark (Table 13.1, lines 13-14).

    ``z_hat = (sqrt(q), atan2(dy, dx) - theta)`` with ``(dx, dy) = mu - (x, y)``,
    ``q = dx^2 + dy^2``; the bearing is *not* wrapped here (the innovation is).
    ``H = [[dx/sqrt(q), dy/sqrt(q)], [-dy/q, dx/q]]``.

    Parameters
    ----------
    poses : ndarray, shape (N, 3)
    mu : ndarray, shape (N, k, 2)

    Returns
    -------
    z_hat : ndarray, shape (N, k, 2)
    H : ndarray, shape (N, k, 2, 2)
    """
    dx = mu[..., 0] - poses[:, 0:1]
    dy = mu[..., 1] - poses[:, 1:2]
    _, zhat = _vec2(dx.shape)
    d = np.sqrt(dx * dx + dy * dy, out=zhat[..., 0])
    np.subtract(np.arctan2(dy, dx), poses[:, 2:3], out=zhat[..., 1])
    inv_d = 1.0 / d
    _, H = _mat22(dx.shape)
    np.multiply(dx, inv_d, out=H[..., 0, 0])
    np.multiply(dy, inv_d, out=H[..., 0, 1])
    inv_d *= inv_d  # 1 / q
    np.multiply(dy, inv_d, out=H[..., 1, 0])
    np.negative(H[..., 1, 0], out=H[..., 1, 0])
    np.multiply(dx, inv_d, out=H[..., 1, 1])
    return zhat, H


def innovation(z: np.ndarray, zhat: np.ndarray, *, wrap) -> np.ndarray:
    """Innovation ``nu = z - z_hat`` with the bearing component wrapped.

    Parameters
    ----------
    z : ndarray, shape (k, 2)
    zhat : ndarray, shape (N, k, 2)
    wrap : callable
        The bearing wrap (``steps.wrap_bearing``).

    Returns
    -------
    ndarray, shape (N, k, 2)
    """
    _, nu = _vec2(zhat.shape[:-1])
    np.subtract(z[:, 0], zhat[..., 0], out=nu[..., 0])
    nu[..., 1] = wrap(z[:, 1] - zhat[..., 1])
    return nu


def innovation_covariance(H: np.ndarray, P: np.ndarray, Q: np.ndarray) -> np.ndarray:
    """``S = H P H^T + Q`` (Table 13.1, line 15).

    Parameters
    ----------
    H : ndarray, shape (N, k, 2, 2)
    P : ndarray, shape (N, k, 2, 2)
        Symmetric (the reference reads ``P[..., 0, 1]`` for both off-diagonal entries).
    Q : ndarray, shape (2, 2)
        Symmetric.

    Returns
    -------
    ndarray, shape (N, k, 2, 2)
        Exactly symmetric.
    """
    buf, S = _sandwich_sym(H[..., 0, 0], H[..., 0, 1], H[..., 1, 0], H[..., 1, 1],
                           P[..., 0, 0], P[..., 0, 1], P[..., 1, 1])
    S[..., 0, 0] += Q[0, 0]
    S[..., 1, 1] += Q[1, 1]
    if Q[0, 1] != 0.0:
        S[..., 0, 1] += Q[0, 1]
        S[..., 1, 0] = S[..., 0, 1]
    return S


def log_likelihood(nu: np.ndarray, S: np.ndarray) -> np.ndarray:
    """Gaussian log density of the innovation (Table 13.1, line 19, in logs).

    ``log N(nu; 0, S) = -0.5 nu^T S^-1 nu - log(2 pi) - 0.5 log det S``.

    Parameters
    ----------
    nu : ndarray, shape (N, k, 2)
    S : ndarray, shape (N, k, 2, 2)
        Symmetric positive definite (the reference reads ``S[..., 0, 1]`` for both
        off-diagonal entries).

    Returns
    -------
    ndarray, shape (N, k)
    """
    s00, s01, s11 = S[..., 0, 0], S[..., 0, 1], S[..., 1, 1]
    det = s00 * s11
    det -= s01 * s01
    n0, n1 = nu[..., 0], nu[..., 1]
    # nu^T S^-1 nu = (n0^2 s11 - 2 n0 n1 s01 + n1^2 s00) / det
    t = n0 * s11
    t -= 2.0 * (n1 * s01)
    t *= n0
    t += n1 * n1 * s00
    t /= det
    t += np.log(det)
    t *= -0.5
    t -= _LOG_TWO_PI
    return t


def combine_weights(logw: np.ndarray, loglik: np.ndarray, known: np.ndarray) -> np.ndarray:
    """Fold a step's likelihoods into the log weights (weights multiply).

    Called only in steps with at least one observation.  New landmarks
    contribute a factor 1 (Table 13.1's constant ``p0`` cancels in the
    normalisation).

    Parameters
    ----------
    logw : ndarray, shape (N,)
        Current normalised log weights.
    loglik : ndarray, shape (N, k)
        Log likelihood of every (particle, observation) pair.
    known : ndarray of bool, shape (N, k)
        Pairs updated as known landmarks (the others were initialised).

    Returns
    -------
    ndarray, shape (N,)
        Unnormalised log weights ``logw + sum_k known * loglik`` (the filter normalises).
    """
    return logw + np.where(known, loglik, 0.0).sum(axis=1)


def ekf_update(mu: np.ndarray, P: np.ndarray, H: np.ndarray, S: np.ndarray,
               nu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per-landmark EKF correction (Table 13.1, lines 16-18).

    ``K = P H^T S^-1``, ``mu' = mu + K nu``, ``P' = (I - K H) P``; the reference
    evaluates the covariance as ``P - K M^T`` with ``M = P H^T`` (equal for
    symmetric ``P``) so that ``P'`` stays exactly symmetric.

    Parameters
    ----------
    mu : ndarray, shape (N, k, 2)
    P : ndarray, shape (N, k, 2, 2)
        Symmetric (the reference reads ``P[..., 0, 1]`` for both off-diagonal entries).
    H : ndarray, shape (N, k, 2, 2)
    S : ndarray, shape (N, k, 2, 2)
        Symmetric (``S[..., 0, 1]`` read for both off-diagonal entries).
    nu : ndarray, shape (N, k, 2)

    Returns
    -------
    mu : ndarray, shape (N, k, 2)
    P : ndarray, shape (N, k, 2, 2)
        New arrays (the inputs are not modified).
    """
    p00, p01, p11 = P[..., 0, 0], P[..., 0, 1], P[..., 1, 1]
    h00, h01, h10, h11 = H[..., 0, 0], H[..., 0, 1], H[..., 1, 0], H[..., 1, 1]
    s00, s01, s11 = S[..., 0, 0], S[..., 0, 1], S[..., 1, 1]
    # M = P H^T
    m00 = p00 * h00 + p01 * h01
    m01 = p00 * h10 + p01 * h11
    m10 = p01 * h00 + p11 * h01
    m11 = p01 * h10 + p11 * h11
    # K = M S^-1 with S^-1 = [[s11, -s01], [-s01, s00]] / det
    inv_det = s00 * s11
    inv_det -= s01 * s01
    np.divide(1.0, inv_det, out=inv_det)
    k00 = m00 * s11
    k00 -= m01 * s01
    k00 *= inv_det
    k01 = m01 * s00
    k01 -= m00 * s01
    k01 *= inv_det
    k10 = m10 * s11
    k10 -= m11 * s01
    k10 *= inv_det
    k11 = m11 * s00
    k11 -= m10 * s01
    k11 *= inv_det
    n0, n1 = nu[..., 0], nu[..., 1]
    _, mu_new = _vec2(mu.shape[:-1])
    np.add(mu[..., 0], k00 * n0 + k01 * n1, out=mu_new[..., 0])
    np.add(mu[..., 1], k10 * n0 + k11 * n1, out=mu_new[..., 1])
    # P' = P - K M^T
    _, P_new = _mat22(P.shape[:-2])
    np.subtract(p00, k00 * m00 + k01 * m01, out=P_new[..., 0, 0])
    np.subtract(p01, k00 * m10 + k01 * m11, out=P_new[..., 0, 1])
    P_new[..., 1, 0] = P_new[..., 0, 1]
    np.subtract(p11, k10 * m10 + k11 * m11, out=P_new[..., 1, 1])
    return mu_new, P_new


# ---------------------------------------------------------------------------------------------
# resampling (Table 13.1, lines 24-28; low variance sampler of Table 4.4)
# ---------------------------------------------------------------------------------------------


def effective_sample_size(w: np.ndarray) -> float:
    """``N_eff = 1 / sum(w^2)`` of normalised weights ``w`` (N,)."""
    return float(1.0 / np.dot(w, w))


def low_variance_indices(w: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Low-variance (systematic) resampling indices (Probabilistic Robotics, Table 4.4).

    One draw ``r = rng.uniform(0, 1/N)``; sample ``m`` (0-based) picks the first
    particle whose cumulative weight reaches ``r + m/N``.

    Parameters
    ----------
    w : ndarray, shape (N,)
        Normalised weights.
    rng : numpy.random.Generator

    Returns
    -------
    ndarray of intp, shape (N,)
    """
    n = w.shape[0]
    r = rng.uniform(0.0, 1.0 / n)
    u = r + np.arange(n) / n
    idx = np.searchsorted(np.cumsum(w), u, side="left")
    return np.minimum(idx, n - 1).astype(np.intp, copy=False)


def resample(w: np.ndarray, n_eff: float, empty: bool, rng: np.random.Generator, config) -> np.ndarray | None:
    """Decide whether to resample and draw the indices.

    Parameters
    ----------
    w : ndarray, shape (N,)
        Normalised weights after this step's correction.
    n_eff : float
        ``effective_sample_size(w)``.
    empty : bool
        True for an empty update (control exactly (0, 0) and no observation).
    rng : numpy.random.Generator
        The unit's own stream (:data:`STREAM_UNITS`).
    config : FastSlamConfig
        Supplies ``resample_ratio``.

    Returns
    -------
    ndarray of intp, shape (N,), or None
        Reference: None (keep the particles) if ``empty`` or ``n_eff >= N / resample_ratio``,
        else :func:`low_variance_indices` (one uniform draw from ``rng``).
    """
    n = w.shape[0]
    if empty or n_eff >= n / config.resample_ratio:
        return None
    return low_variance_indices(w, rng)


def apply_resample(state: ParticleState, indices: np.ndarray) -> ParticleState:
    """The particle set after resampling: new particle ``i`` is a copy of old particle ``indices[i]``.

    Reference: poses and lineage are gathered (``lineage[indices]`` gives each
    copy its ancestor's landmarks without copying the landmark storage) and
    the weights become uniform.  ``owner`` stays ``arange(N)``, so each copy
    writes its own storage row from then on (copy-on-write: a deep copy).

    Parameters
    ----------
    state : ParticleState
    indices : ndarray of int, shape (N,)

    Returns
    -------
    ParticleState
        A new state (may share the landmark storage arrays with ``state``).
    """
    n = state.n_particles
    return state.replace(poses=state.poses[indices], lineage=state.lineage[indices],
                         logw=np.full(n, -math.log(n)))


def extract_map(state: ParticleState) -> tuple[np.ndarray, np.ndarray]:
    """The map estimate: the landmark means of the highest-weight particle.

    Ties (e.g. uniform weights right after resampling) go to the lowest index.

    Parameters
    ----------
    state : ParticleState

    Returns
    -------
    ids : ndarray of int64, shape (M,)
    xy : ndarray, shape (M, 2)
    """
    i = int(np.argmax(state.logw))
    C = state.n_landmarks
    cols = np.arange(C)
    rows = state.anc[state.lineage[i], :C]
    return state.ids.copy(), state.mu[rows, cols].copy()

