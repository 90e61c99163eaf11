"""The units of unknown data association (Montemerlo et al., FastSLAM; Probabilistic Robotics Sec. 13.6).

Maximum-likelihood association per particle with a new-landmark likelihood ``p0``.

Unknown data association
------------------------
With ``association = "unknown"`` (:mod:`faultlab.slam.association`) the observations carry no
landmark ids and each particle has its own map, of its own size.  The filters reuse the units of
:mod:`faultlab.slam.units` with the same signatures -- ``predict_measurement``, ``innovation_covariance``,
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
id-aligned :class:`~faultlab.slam.particles.ParticleState`) are not units of that mode, so their faults do not apply to it.
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
]

_LOG_TWO_PI = math.log(2.0 * math.pi)

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
