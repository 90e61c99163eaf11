"""The reference units of FastSLAM 1.0 (Probabilistic Robotics, Table 13.1) and the particle state.

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

Randomness: the units named in :data:`STREAM_UNITS` take an ``rng`` argument.  The filter gives
each of them its *own* :class:`numpy.random.Generator`, derived from the SLAM's seed by unit name
(:func:`faultlab.slam.streams.unit_streams`), so a replacement that draws more, fewer or other
random numbers changes no other unit's draws (common random numbers by unit).  A replacement
must draw only from the ``rng`` it is given; no other unit may draw random numbers.

Batched repetitions: which units see which particles
----------------------------------------------------
:meth:`faultlab.slam.FastSlam.reset_batch` runs ``B`` independent repetitions of one scenario
(each with its own particles, weights, resampling and random streams) as one particle set of
``B N`` particles: filter ``b`` holds rows ``b N .. (b + 1) N - 1`` of every per-particle array.
All repetitions see the same controls and observations, so their landmark columns align.  The
"N" in the shapes below then means:

* :data:`PARTICLE_UNITS` (``motion_model``, ``wrap_heading``, ``wrap_bearing``,
  ``init_landmarks``, ``classify_new``, ``predict_measurement``, ``innovation``,
  ``innovation_covariance``, ``log_likelihood``, ``ekf_update``) are called **once per step
  with all B N particles**.  A replacement must be *particle-wise*: row ``i`` of every output
  depends only on row ``i`` of the per-particle inputs (and on the shared ``z``, ``Q``,
  ``seen``, ``wrap``), never on other particles -- every reference unit and every built-in fault
  is.  The wrap units must moreover be element-wise (any shape in, same shape out).  A
  replacement of one of the other particle units that does look across particles (a reduction
  or a normalisation over the particle axis, an index like ``poses[0]``) keeps its
  single-filter meaning by declaring it with :func:`filter_wise`: the batched filter then calls
  it once per filter with that filter's (N, ...) slices and stacks the outputs.
* :data:`FILTER_UNITS` (``sample_controls``, ``combine_weights``, ``effective_sample_size``,
  ``resample``, ``apply_resample``, ``extract_map``) are called **once per filter** with that
  filter's N particles: ``sample_controls`` and ``resample`` with the filter's own streams
  (derived from that repetition's generator), ``combine_weights`` with its (N,) weights and
  (N, k) slices, ``apply_resample`` and ``extract_map`` with its own :class:`ParticleState`
  (whose arrays are views of the batch's; storage rows are numbered per filter, from 0).  The
  weight normalisation (log-sum-exp) is per filter too.

So a unit or fault written for one filter stays correct batched: a filter unit never sees
another filter's particles, a particle unit never needs to.  The filter itself checks nothing
about particle-wise behaviour; ``tests/slam/test_batch.py`` checks that every built-in fault
gives each repetition bit for bit its single-filter result.

Unknown data association
------------------------
With ``association = "unknown"`` (:mod:`faultlab.slam.association`) the observations carry no
landmark ids and each particle has its own map, of its own size.  The filters reuse the units
above with the same signatures -- ``predict_measurement``, ``innovation_covariance``,
``innovation`` and ``log_likelihood`` are called on *all* (particle, observation, landmark)
triples, flattened to (N, k L) pairs (observation ``m``, landmark ``j`` at ``m L + j``) -- and
add three units of their own:

====================== ======================================================================
unit                   signature (shapes)
====================== ======================================================================
associate              ``(loglik (N,k,L), valid (N,L) bool, log_p0) -> (N,k) int`` landmark or
                       :data:`NEW_LANDMARK`
resample_maps          ``(state, indices (N,)) -> state`` on an :class:`AssociationState`
extract_unlabelled_map ``(state) -> labels (M,), xy (M,2)`` the best particle's map
====================== ======================================================================

``classify_new``, ``apply_resample`` and ``extract_map`` (which need landmark ids and the
id-aligned :class:`ParticleState`) are not units of that mode, so their faults do not apply to it.
``combine_weights`` receives the log likelihood of the associated landmark, or ``log_p0`` for an
observation that created a landmark, with ``known`` true for every pair: in that mode the
particles differ in which observations are new, so the new-landmark factor ``p0`` no longer cancels.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = [
    "NEW_LANDMARK",
    "AssociationState",
    "new_landmark_log_likelihood",
    "associate",
    "resample_maps",
    "extract_unlabelled_map",
    "STREAM_UNITS",
    "PARTICLE_UNITS",
    "FILTER_UNITS",
    "filter_wise",
    "ParticleState",
    "landmark_rows",
    "empty_means",
    "empty_covariances",
    "initial_ancestry",
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

#: Units that receive a random stream as ``rng``, each its own one, keyed by this name
#: (``unit_streams(rng, STREAM_UNITS)[name]``).  Part of the unit contract: another SLAM built from
#: replaceable units, and every fault, follows it.
STREAM_UNITS: tuple[str, ...] = ("sample_controls", "resample")

#: Units a batch of repetitions calls once per step with the particles of all its filters (B N rows);
#: they must treat every particle independently (see "Batched repetitions" above).
PARTICLE_UNITS: tuple[str, ...] = ("motion_model", "wrap_heading", "wrap_bearing", "init_landmarks",
                                   "classify_new", "predict_measurement", "innovation", "innovation_covariance",
                                   "log_likelihood", "ekf_update")

#: Units a batch of repetitions calls once per filter, with that filter's N particles and its own streams.
FILTER_UNITS: tuple[str, ...] = ("sample_controls", "combine_weights", "effective_sample_size", "resample",
                                 "apply_resample", "extract_map")


def filter_wise(unit):
    """Declare a replacement of a particle unit that must see one filter at a time.

    A batch of repetitions calls a unit marked this way once per filter with that filter's
    (N, ...) slices of the per-particle arguments and stacks the outputs along the particle
    axis, instead of once with all B N particles.  Needed only for a replacement of one of the
    :data:`PARTICLE_UNITS` other than the wrap units that looks across particles; a single
    filter (B = 1) calls it as it is.  Returns ``unit`` itself, marked (attribute
    ``filter_wise = True``).

    >>> @filter_wise
    ... def log_likelihood(nu, S):          # doctest: +SKIP
    ...     ll = reference_log_likelihood(nu, S)
    ...     return ll - ll.mean(axis=0)     # centred over the filter's particles
    """
    unit.filter_wise = True
    return unit

_TWO_PI = 2.0 * math.pi
_INV_TWO_PI = 1.0 / _TWO_PI
_LOG_TWO_PI = math.log(_TWO_PI)


def _vec2(shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """An uninitialised ``shape + (2,)`` array stored component-major, other axes reversed.

    Returns ``(buf, view)``: ``buf`` has shape ``(2,) + shape[::-1]`` (for
    ``shape = (N, k)`` each component is a contiguous (k, N) block: all
    particles of one observation side by side, matching the landmark
    storage) and ``view`` is the same memory with the documented shape
    ``shape + (2,)``.
    """
    nd = len(shape)
    buf = np.empty((2,) + tuple(shape)[::-1])
    return buf, buf.transpose(tuple(range(nd, 0, -1)) + (0,))


def _mat22(shape: tuple[int, ...]) -> tuple[np.ndarray, np.ndarray]:
    """An uninitialised ``shape + (2, 2)`` array, stored as ``(2, 2) + shape[::-1]``: ``(buf, view)``."""
    nd = len(shape)
    buf = np.empty((2, 2) + tuple(shape)[::-1])
    return buf, buf.transpose(tuple(range(nd + 1, 1, -1)) + (0, 1))


def _scratch(shape: tuple[int, ...], m: int) -> list[np.ndarray]:
    """``m`` uninitialised work arrays of ``shape``, in the same (reversed) order as :func:`_vec2`.

    One allocation for all of them; the formulas below write every intermediate
    into these with ``out=`` instead of allocating a temporary per operation.
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
# particle state
# ---------------------------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class ParticleState:
    """All particles of the filter, in arrays (see the storage scheme in :mod:`faultlab.slam.fastslam`).

    Landmark ``j`` (column ``j``, id ``ids[j]``) of particle ``i`` has mean
    ``mu[r, j]`` and covariance ``P[r, j]`` with ``r = anc[lineage[i], j]``
    (use :func:`landmark_rows`).  Storage is copy-on-write: resampling only
    composes ``lineage``; the filter rewrites the observed columns of every
    particle each step (into row ``owner[i]`` for particle ``i``) and then
    points ``anc[:, cols]`` at those rows.

    Attributes
    ----------
    poses : ndarray, shape (N, 3)
        Particle poses (x, y, theta), theta wrapped by ``wrap_heading``.
    logw : ndarray, shape (N,)
        Normalised log importance weights (``logsumexp(logw) == 0``).
    ids : ndarray of int64, shape (C,)
        Landmark id of each storage column, in order of first observation.
    mu : ndarray, shape (N, cap, 2)
        Landmark mean storage, ``cap >= C``; only the first ``C`` columns are used.
        Unused and never-written entries are 0.  The filter keeps it as a view of a
        (2, cap, N) buffer (:func:`empty_means`); a state with other layouts is
        accepted and copied into that layout once.
    P : ndarray, shape (N, cap, 2, 2)
        Landmark covariance storage (a view of a (2, 2, cap, N) buffer).
    anc : ndarray of int32, shape (N, cap)
        Storage row of each (lineage row, column); C-ordered.
    lineage : ndarray of intp, shape (N,)
        Row of ``anc`` that particle ``i`` reads (composition of the resampling
        indices since the filter last rewrote ``anc``; ``arange(N)`` right after).
    owner : ndarray of intp, shape (N,)
        Storage row particle ``i`` writes its updated landmarks to; ``arange(N)``
        in the reference (every particle owns its row).  A shallow-copy fault makes
        resampled duplicates share one row by composing it too.
    sequential_sharers : bool
        How particles that share a storage row (``owner``) update it.  False (the
        default): all particles are corrected in parallel from the same stored values
        and the last writer wins.  True: the sharers of a row update it one after
        another in particle order, each starting from the previous sharer's result,
        as a per-particle loop over shared landmark arrays does
        (:func:`apply_resample_aliased`; the filter then runs
        :func:`faultlab.slam.sharing.correct_in_sharer_order`).
    """

    poses: np.ndarray
    logw: np.ndarray
    ids: np.ndarray
    mu: np.ndarray
    P: np.ndarray
    anc: np.ndarray
    lineage: np.ndarray
    owner: np.ndarray
    sequential_sharers: bool = False

    @property
    def n_particles(self) -> int:
        return int(self.poses.shape[0])

    def replace(self, **changes) -> "ParticleState":
        """A copy with some fields replaced (a faster ``dataclasses.replace``; arrays are shared)."""
        return ParticleState(**{**self.__dict__, **changes})

    @property
    def n_landmarks(self) -> int:
        """Number of landmark columns in use, C."""
        return int(self.ids.shape[0])

    @classmethod
    def initial(cls, pose: np.ndarray, n: int, *, capacity: int = 16) -> "ParticleState":
        """All ``n`` particles at ``pose`` with equal weights and an empty map."""
        ident = np.arange(n, dtype=np.intp)
        ident.flags.writeable = False
        return cls(
            poses=np.tile(np.asarray(pose, dtype=float), (n, 1)),
            logw=np.full(n, -math.log(n)),
            ids=np.empty(0, dtype=np.int64),
            mu=empty_means(n, capacity),
            P=empty_covariances(n, capacity),
            anc=initial_ancestry(n, capacity),
            lineage=ident,
            owner=ident,
        )


def empty_means(n: int, capacity: int) -> np.ndarray:
    """Zeroed mean storage of shape (n, capacity, 2).

    Laid out as a (2, capacity, n) buffer: per component, one landmark's
    values for all particles are contiguous (all particles read the same
    columns, so gathers stay cache-local).
    """
    return np.zeros((2, capacity, n)).transpose(2, 1, 0)


def empty_covariances(n: int, capacity: int) -> np.ndarray:
    """Zeroed covariance storage of shape (n, capacity, 2, 2), laid out as a (2, 2, capacity, n) buffer."""
    return np.zeros((2, 2, capacity, n)).transpose(3, 2, 0, 1)


def initial_ancestry(n: int, capacity: int) -> np.ndarray:
    """Identity ancestry of shape (n, capacity) (``anc[i, j] = i``), int32, C-ordered.

    Row-major, so materialising a resampling (``anc[lineage]``) copies whole rows.
    """
    return np.ascontiguousarray(np.broadcast_to(np.arange(n, dtype=np.int32)[:, None], (n, capacity)))


def landmark_rows(state: ParticleState, cols: np.ndarray) -> np.ndarray:
    """Storage rows of columns ``cols`` (k,) for every particle: shape (N, k).

    Particle ``i``'s landmark in column ``cols[m]`` is ``state.mu[rows[i, m], cols[m]]``.
    """
    return state.anc[state.lineage[:, None], np.asarray(cols)[None, :]]


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
    out = np.empty_like(poses)
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


# ---------------------------------------------------------------------------------------------
# alternative units: the FastSLAM 1.0 the paper tested (Sec. VII-A)
#
# PythonRobotics' SLAM/FastSLAM1/fast_slam1.py as modified in the paper's replication package
# (slam/slam_correct.py).  Each function below is the replication package's choice for one unit;
# :mod:`faultlab.slam.profiles` assembles them into the ``paper`` profile.  The reference units
# above are unchanged.
# ---------------------------------------------------------------------------------------------


def predict_measurement_wrapped(poses: np.ndarray, mu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """:func:`predict_measurement` with the predicted bearing wrapped to [-pi, pi).

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
        As :func:`predict_measurement` (the wrap does not change the derivative).
    """
    zhat, H = predict_measurement(poses, mu)
    zhat[..., 1] = _wrap(zhat[..., 1])
    return zhat, H


def log_likelihood_wrapped(nu: np.ndarray, S: np.ndarray) -> np.ndarray:
    """:func:`log_likelihood` of the innovation with its bearing wrapped to [-pi, pi) first.

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
    rows = np.empty((factors.shape[1] + 1, logw.shape[0]))
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
    it low variance, which would use one shared ``U``: :func:`low_variance_indices`).

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
    """:func:`resample` with :func:`stratified_indices` instead of the low-variance sampler.

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


# ---------------------------------------------------------------------------------------------
# unknown data association (Montemerlo et al., FastSLAM; Probabilistic Robotics Sec. 13.6):
# maximum-likelihood association per particle with a new-landmark likelihood p0
# ---------------------------------------------------------------------------------------------

#: What :func:`associate` returns for an observation that creates a new landmark.
NEW_LANDMARK = -1


@dataclass(frozen=True, eq=False)
class AssociationState:
    """All particles of a filter with unknown data association: every particle has its own map.

    Particle ``i``'s map is slots ``0 .. size[i] - 1`` of its rows of ``mu`` and ``P`` (in order of
    creation); the slots beyond are padding (zeros), so the maps of different sizes share one
    (N, cap) layout and the valid slots are ``arange(cap) < size[:, None]``.  Resampling copies
    whole rows (:func:`resample_maps`): without ids the particles' maps do not align, so the
    copy-on-write columns of :class:`ParticleState` do not apply.

    Attributes
    ----------
    poses : ndarray, shape (N, 3)
    logw : ndarray, shape (N,)
        Normalised log importance weights.
    mu : ndarray, shape (N, cap, 2)
        Landmark means.
    P : ndarray, shape (N, cap, 2, 2)
        Landmark covariances.
    size : ndarray of intp, shape (N,)
        Number of landmarks of each particle (<= cap).
    """

    poses: np.ndarray
    logw: np.ndarray
    mu: np.ndarray
    P: np.ndarray
    size: np.ndarray

    @property
    def n_particles(self) -> int:
        return int(self.poses.shape[0])

    @property
    def valid(self) -> np.ndarray:
        """Which slots hold a landmark, (N, cap) bool."""
        return np.arange(self.mu.shape[1])[None, :] < self.size[:, None]

    def replace(self, **changes) -> "AssociationState":
        """A copy with some fields replaced (arrays are shared)."""
        return AssociationState(**{**self.__dict__, **changes})

    @classmethod
    def initial(cls, pose: np.ndarray, n: int, *, capacity: int = 16) -> "AssociationState":
        """All ``n`` particles at ``pose`` with equal weights and empty maps."""
        return cls(poses=np.tile(np.asarray(pose, dtype=float), (n, 1)), logw=np.full(n, -math.log(n)),
                   mu=np.zeros((n, capacity, 2)), P=np.zeros((n, capacity, 2, 2)),
                   size=np.zeros(n, dtype=np.intp))


def new_landmark_log_likelihood(Q: np.ndarray, sigmas: float) -> float:
    """``log p0``: the Gaussian log density under ``Q`` of an innovation ``sigmas`` Mahalanobis units long.

    ``log p0 = -sigmas^2 / 2 - log(2 pi) - log(det Q) / 2``: an observation whose best landmark
    explains it less well than an innovation of ``sigmas`` standard deviations would (with the
    measurement noise alone) starts a new landmark.

    Parameters
    ----------
    Q : ndarray, shape (2, 2)
        Measurement noise covariance.
    sigmas : float
        Mahalanobis distance, >= 0.
    """
    det = float(Q[0, 0] * Q[1, 1] - Q[0, 1] * Q[1, 0])
    return -0.5 * sigmas * sigmas - _LOG_TWO_PI - 0.5 * math.log(det)


def associate(loglik: np.ndarray, valid: np.ndarray, log_p0: float) -> np.ndarray:
    """Maximum-likelihood data association of every particle's observations (Montemerlo's FastSLAM).

    Each observation of particle ``i`` is associated with the valid landmark of ``i`` that
    explains it best (highest log likelihood); if even that one is below ``log_p0`` (or the
    particle has no landmark) it creates a new landmark.  A landmark produces at most one
    observation per step: when several observations of one particle choose the same landmark,
    the one with the highest likelihood (ties: the lowest observation index) keeps it and the
    others create new landmarks.  The result does not depend on the order of the observations
    except through exact ties.

    Parameters
    ----------
    loglik : ndarray, shape (N, k, L)
        Log likelihood of observation ``m`` under landmark ``j`` of particle ``i``
        (entries of invalid slots are ignored, whatever their value).
    valid : ndarray of bool, shape (N, L)
        Which landmark slots hold a landmark.
    log_p0 : float
        The new-landmark log likelihood (:func:`new_landmark_log_likelihood`).

    Returns
    -------
    ndarray of intp, shape (N, k)
        Landmark slot ``j`` (0 <= j < L), or :data:`NEW_LANDMARK`.
    """
    n, k, L = loglik.shape
    if L == 0 or k == 0:
        return np.full((n, k), NEW_LANDMARK, dtype=np.intp)
    masked = np.where(valid[:, None, :], loglik, -np.inf)
    best = np.argmax(masked, axis=2)  # (N, k)
    best_ll = np.take_along_axis(masked, best[..., None], axis=2)[..., 0]
    accepted = best_ll >= log_p0  # False for NaN and for particles without landmarks
    # mutual exclusion: per (particle, landmark) the accepted observation with the highest
    # likelihood wins, ties to the lowest observation index
    rows, obs = np.nonzero(accepted)
    key = rows * L + best[rows, obs]
    order = np.lexsort((obs, -best_ll[rows, obs], key))
    first = np.ones(order.size, dtype=bool)
    first[1:] = key[order[1:]] != key[order[:-1]]
    keep = np.zeros((n, k), dtype=bool)
    keep[rows[order[first]], obs[order[first]]] = True
    return np.where(keep, best, NEW_LANDMARK).astype(np.intp, copy=False)


def resample_maps(state: AssociationState, indices: np.ndarray) -> AssociationState:
    """The particle set after resampling: new particle ``i`` is a copy of old particle ``indices[i]``.

    Copies poses, maps and map sizes (a deep copy: every particle owns its rows) and makes the
    weights uniform.

    Parameters
    ----------
    state : AssociationState
    indices : ndarray of int, shape (N,)

    Returns
    -------
    AssociationState
        A new state with its own arrays.
    """
    n = state.n_particles
    return AssociationState(poses=state.poses[indices], logw=np.full(n, -math.log(n)), mu=state.mu[indices],
                            P=state.P[indices], size=state.size[indices])


def extract_unlabelled_map(state: AssociationState) -> tuple[np.ndarray, np.ndarray]:
    """The map estimate: the landmarks of the highest-weight particle, labelled in order of creation.

    Ties go to the lowest particle index.

    Parameters
    ----------
    state : AssociationState

    Returns
    -------
    labels : ndarray of int64, shape (M,)
        ``0 .. M - 1``: the particle's own landmark labels (not the ground truth's ids).
    xy : ndarray, shape (M, 2)
    """
    i = int(np.argmax(state.logw))
    m = int(state.size[i])
    return np.arange(m, dtype=np.int64), state.mu[i, :m].copy()
