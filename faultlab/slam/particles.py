"""The particle state of FastSLAM with known correspondences, and its copy-on-write landmark storage.

The units of :mod:`faultlab.slam.units` read and return a :class:`ParticleState`; the storage
scheme is described in :mod:`faultlab.slam.fastslam`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["ParticleState", "landmark_rows", "empty_means", "empty_covariances", "ancestry_dtype", "initial_ancestry"]


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
    anc : ndarray of integers, shape (N, cap)
        Storage row of each (lineage row, column), in ``[0, N)``; C-ordered.  The filter stores
        it as :func:`ancestry_dtype` (int16 up to 32767 particles per filter); a unit may return
        any integer array in range.
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
        (:func:`faultlab.slam.paperunits.apply_resample_aliased`; the filter then runs
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


def ancestry_dtype(n: int) -> type:
    """The integer type of an ancestry index over ``n`` particles: int16 while ``n <= 32767``, else int32.

    Materialising a resampling copies the ancestry's used columns of every particle at nearly every
    step of a large map (200 particles x 3338 landmarks: 1.3 MB as int16); the narrowest type that
    holds every row number halves that memory traffic against int32.
    """
    return np.int16 if n <= np.iinfo(np.int16).max else np.int32


def initial_ancestry(n: int, capacity: int) -> np.ndarray:
    """Identity ancestry of shape (n, capacity) (``anc[i, j] = i``), :func:`ancestry_dtype`, C-ordered.

    Row-major, so materialising a resampling (``anc[lineage]``) copies whole rows.
    """
    return np.ascontiguousarray(np.broadcast_to(np.arange(n, dtype=ancestry_dtype(n))[:, None], (n, capacity)))


def landmark_rows(state: ParticleState, cols: np.ndarray) -> np.ndarray:
    """Storage rows of columns ``cols`` (k,) for every particle: shape (N, k).

    Particle ``i``'s landmark in column ``cols[m]`` is ``state.mu[rows[i, m], cols[m]]``.
    """
    return state.anc[state.lineage[:, None], np.asarray(cols)[None, :]]

