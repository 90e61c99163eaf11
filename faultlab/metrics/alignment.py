"""Kabsch-aligned RMS map error for SLAMs that keep landmark ids (Sec. VII-B).

A SLAM estimates its map in its own frame: a small early pose error rotates and
shifts the whole map (Fig. 4, left) without making it wrong.  The paper
therefore aligns the estimate to the ground truth with the Kabsch algorithm
[39] -- the best *proper* rotation plus translation, no scaling -- and reports
the root-mean-square distance of the aligned landmarks.

In 2-D the Kabsch solution has a closed form.  With centred truth points
``p_i`` and centred estimated points ``q_i``, the sum of squared residuals
``sum |R(theta) q_i - p_i|^2`` is minimised by

    theta = atan2(sum(q_i x p_i), sum(q_i . p_i))

(``x`` the scalar 2-D cross product), which is what the SVD of the 2x2
cross-covariance with the determinant-sign correction yields, without the
special case: the parametrisation by an angle admits proper rotations only, so
a mirrored map can never be "fitted" by a reflection.  (scipy's
``Rotation.align_vectors`` works in 3-D, where a 2-D reflection *is* a proper
rotation -- a half turn about an in-plane axis -- so it would fit mirrored maps;
that is why it is not used here.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from faultlab.errors import ScenarioError, SlamOutputError

__all__ = ["MapError", "kabsch_rms", "match_ids"]


@dataclass(frozen=True, eq=False)
class MapError:
    """Result of :func:`kabsch_rms`.

    Attributes
    ----------
    rms : float
        Root-mean-square landmark error after alignment, m.  NaN when no
        landmark was mapped (there is nothing to compare); 0 for one mapped
        landmark (a translation fits it exactly).
    n_mapped : int
        Ground-truth landmarks present in the estimate (used in the RMS).
    n_unmapped : int
        Ground-truth landmarks the SLAM never mapped (excluded from the RMS).
    rotation : ndarray, shape (2, 2)
        Proper rotation ``R`` (``det R = +1``) of the alignment.
    translation : ndarray, shape (2,)
        Translation ``t``; the aligned estimate is ``est_xy @ R.T + t``.
    """

    rms: float
    n_mapped: int
    n_unmapped: int
    rotation: np.ndarray
    translation: np.ndarray

    @property
    def angle(self) -> float:
        """Rotation angle of the alignment, rad, in (-pi, pi]."""
        return float(np.arctan2(self.rotation[1, 0], self.rotation[0, 0]))

    def apply(self, xy) -> np.ndarray:
        """Map points from the estimate's frame into the truth frame.

        Parameters
        ----------
        xy : array_like, shape (M, 2)

        Returns
        -------
        ndarray, shape (M, 2)
        """
        return np.asarray(xy, dtype=float).reshape(-1, 2) @ self.rotation.T + self.translation


def _points(xy, ids, *, what: str, error: type[Exception]) -> tuple[np.ndarray, np.ndarray]:
    """Validate an (ids, xy) pair; return (int64 ids, float xy)."""
    ids = np.asarray(ids)
    xy = np.asarray(xy, dtype=float)
    if ids.ndim != 1:
        raise error(f"{what} landmark ids must be 1-d, got shape {ids.shape}")
    if xy.size == 0 and ids.size == 0:
        xy = xy.reshape(0, 2)
    if xy.shape != (ids.shape[0], 2):
        raise error(f"{what} landmarks must have shape (n, 2) matching ids (n,), got {xy.shape} "
                    f"and {ids.shape}")
    if ids.size and not np.issubdtype(ids.dtype, np.integer):
        as_float = ids.astype(float)
        if not np.all(np.isfinite(as_float)) or np.any(as_float != np.round(as_float)):
            raise error(f"{what} landmark ids must be integers, got dtype {ids.dtype}")
    ids = ids.astype(np.int64)
    uniq, counts = np.unique(ids, return_counts=True)
    if np.any(counts > 1):
        raise error(f"{what} landmark id {uniq[counts > 1][0]} appears more than once")
    bad = ~np.all(np.isfinite(xy), axis=1)
    if np.any(bad):
        raise error(f"{what} landmark {ids[bad][0]} has a non-finite position")
    return ids, xy


def match_ids(truth_ids, est_ids) -> np.ndarray:
    """Index into ``truth_ids`` of every estimated id.

    Parameters
    ----------
    truth_ids : ndarray of int, shape (L,), unique
    est_ids : ndarray of int, shape (M,), unique

    Returns
    -------
    ndarray of intp, shape (M,)
        ``truth_ids[result] == est_ids``.

    Raises
    ------
    SlamOutputError
        If an estimated id is not a ground-truth landmark (names the id).
    """
    truth_ids = np.asarray(truth_ids, dtype=np.int64)
    est_ids = np.asarray(est_ids, dtype=np.int64)
    order = np.argsort(truth_ids, kind="stable")
    sorted_ids = truth_ids[order]
    pos = np.searchsorted(sorted_ids, est_ids)
    pos_c = np.minimum(pos, max(sorted_ids.size - 1, 0))
    found = (pos < sorted_ids.size) & (sorted_ids[pos_c] == est_ids) if sorted_ids.size else \
        np.zeros(est_ids.shape, dtype=bool)
    if not np.all(found):
        raise SlamOutputError(f"estimate contains landmark id {est_ids[~found][0]}, which is not in "
                              f"the ground-truth map ({int((~found).sum())} unknown id(s))")
    return order[pos_c]


def kabsch_rms(truth_ids, truth_xy, est_ids, est_xy) -> MapError:
    """RMS landmark error after the best rigid (proper) alignment, matched by id.

    Parameters
    ----------
    truth_ids : array_like of int, shape (L,)
        Ground-truth landmark ids, unique.
    truth_xy : array_like, shape (L, 2)
        Ground-truth positions, m.
    est_ids : array_like of int, shape (M,)
        Ids of the landmarks the SLAM mapped, unique, a subset of ``truth_ids``.
    est_xy : array_like, shape (M, 2)
        Estimated positions, m, in the SLAM's frame.

    Returns
    -------
    MapError
        ``rms`` in m (NaN if ``M == 0``), counts, and the alignment ``(R, t)``
        that maps the estimate onto the truth.

    Raises
    ------
    ScenarioError
        Malformed ground truth (shape, duplicate id, non-finite position).
    SlamOutputError
        Malformed estimate, or an estimated id that is not in the ground truth.

    Notes
    -----
    Landmarks the SLAM never mapped are excluded from the RMS and counted in
    ``n_unmapped`` (Sec. VII-B compares the final map estimate; an unmapped
    landmark has no estimate).  No scaling is fitted.
    """
    truth_ids, truth_xy = _points(truth_xy, truth_ids, what="ground-truth", error=ScenarioError)
    est_ids, est_xy = _points(est_xy, est_ids, what="estimated", error=SlamOutputError)
    idx = match_ids(truth_ids, est_ids)
    n_mapped = int(est_ids.size)
    n_unmapped = int(truth_ids.size - n_mapped)
    if n_mapped == 0:
        return MapError(float("nan"), 0, n_unmapped, np.eye(2), np.zeros(2))
    p = truth_xy[idx]
    q = est_xy
    p_mean = p.mean(axis=0)
    q_mean = q.mean(axis=0)
    pc = p - p_mean
    qc = q - q_mean
    # Closed-form 2-D Kabsch: maximise sum p_i . R q_i over proper rotations.
    s_dot = float(np.sum(qc * pc))
    s_cross = float(np.sum(qc[:, 0] * pc[:, 1] - qc[:, 1] * pc[:, 0]))
    theta = np.arctan2(s_cross, s_dot)
    c, s = np.cos(theta), np.sin(theta)
    rot = np.array([[c, -s], [s, c]])
    trans = p_mean - rot @ q_mean
    resid = qc @ rot.T - pc  # == aligned estimate - truth, computed from the centred sets
    rms = float(np.sqrt(np.mean(np.sum(resid * resid, axis=1))))
    return MapError(rms, n_mapped, n_unmapped, rot, trans)
