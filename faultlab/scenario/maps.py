"""Landmark maps (Sec. VI-A): square, centred on the origin, uniform, partly point-symmetric."""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from faultlab.errors import ScenarioError

__all__ = ["generate_landmarks", "n_symmetric_pairs"]

#: Candidate draws allowed per requested landmark before giving up.
MAX_DRAWS_PER_LANDMARK = 200


def n_symmetric_pairs(n_landmarks: int, symmetry: float) -> int:
    """Number of mirrored pairs: ``round(symmetry * n / 2)`` (half up), at most ``n // 2``."""
    return min(int(math.floor(symmetry * n_landmarks / 2.0 + 0.5)), n_landmarks // 2)


def generate_landmarks(*, side: float, n_landmarks: int, symmetry: float = 0.0, min_distance: float = 0.1,
                       rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """Draw a landmark map (Sec. VI-A).

    Positions are uniform in the square ``[-side/2, side/2]^2``.  The first
    ``2 * n_symmetric_pairs(n, symmetry)`` landmarks are placed as pairs
    ``p, -p`` mirrored through the centre (rows ``2i`` and ``2i + 1``); the
    rest are placed individually.  A draw closer than ``min_distance`` to an
    already placed landmark (or, for a pair, to its own mirror image) is
    rejected and repeated.

    Draws are made in vectorised batches: a batch's candidates are checked
    against the placed landmarks with a k-d tree, and a candidate (pair) that
    conflicts with an earlier candidate of the same batch is rejected.

    Parameters
    ----------
    side : float
        Side length of the square map, m.
    n_landmarks : int
    symmetry : float
        Share of landmarks in mirrored pairs, in [0, 1].
    min_distance : float
        Minimum distance between two landmarks, m (0 disables the check).
    rng : numpy.random.Generator

    Returns
    -------
    landmarks : ndarray, shape (L, 2)
        Positions, m.
    landmark_ids : ndarray, shape (L,), int64
        Unique ids ``0 .. L-1``.

    Raises
    ------
    ScenarioError
        If ``n_landmarks`` landmarks cannot be placed at ``min_distance``
        within ``MAX_DRAWS_PER_LANDMARK * n_landmarks`` draws (density too high).
    """
    n = int(n_landmarks)
    if n < 0 or side < 0 or not 0.0 <= symmetry <= 1.0 or min_distance < 0:
        raise ScenarioError(f"map: invalid settings side={side}, n_landmarks={n}, symmetry={symmetry}, "
                            f"min_distance={min_distance}")
    half = side / 2.0
    n_pairs = n_symmetric_pairs(n, symmetry)
    placed = np.empty((0, 2))
    budget = MAX_DRAWS_PER_LANDMARK * max(n, 1)
    drawn = 0

    def fail() -> ScenarioError:
        return ScenarioError(
            f"map: cannot place {n} landmarks at least {min_distance} m apart in a {side:.3g} m x {side:.3g} m "
            f"map ({placed.shape[0]} placed after {drawn} draws); lower the landmark density or the "
            f"minimum distance")

    # Sec. VI-A: symmetric pairs first, then the individual landmarks.
    for group, n_groups in ((2, n_pairs), (1, n - 2 * n_pairs)):
        todo = n_groups
        while todo > 0:
            if drawn > budget:
                raise fail()
            m = int(todo * 1.25) + 8
            drawn += m * group
            p = rng.uniform(-half, half, size=(m, 2))
            cand = np.concatenate([p, -p], axis=1).reshape(-1, 2) if group == 2 else p  # rows p0, -p0, p1, ...
            ok = _accept(cand, group, placed, min_distance)
            accepted = cand.reshape(m, group, 2)[ok][:todo].reshape(-1, 2)
            placed = np.concatenate([placed, accepted])
            todo -= accepted.shape[0] // group
    return placed, np.arange(n, dtype=np.int64)


def _accept(cand: np.ndarray, group: int, placed: np.ndarray, dmin: float) -> np.ndarray:
    """Which candidate groups (rows ``group*i .. group*i+group-1``) may be placed, shape (m,)."""
    m = cand.shape[0] // group
    gid = np.repeat(np.arange(m), group)
    bad = np.zeros(m, dtype=bool)
    if dmin <= 0:
        return ~bad
    if placed.shape[0]:
        dist, _ = cKDTree(placed).query(cand, k=1)
        np.logical_or.at(bad, gid, dist < dmin)
    pairs = cKDTree(cand).query_pairs(dmin, output_type="ndarray")
    if pairs.size:
        ga, gb = gid[pairs[:, 0]], gid[pairs[:, 1]]
        # a group too close to itself (p near -p) or to an earlier group of the batch is rejected
        bad[ga[ga == gb]] = True
        bad[np.maximum(ga, gb)[ga != gb]] = True
    return ~bad
