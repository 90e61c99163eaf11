"""Earth mover's distance between two landmark sets (Sec. VII-B, [40]).

For SLAM algorithms that do not preserve landmark correspondences the paper
offers the earth mover's distance (EMD) as an alternative to the RMS error.
It needs no ids: each map is a uniform distribution over its landmarks, and the
EMD is the least average distance the truth's mass must travel to become the
estimate's (Wasserstein-1 with a Euclidean ground cost).  Counts may differ:
with ``n`` truth and ``m`` estimated landmarks every truth landmark carries mass
``1/n`` and every estimated one ``1/m``, so missing or spurious landmarks cost
transport.

:func:`earth_movers_distance` applies **no alignment**: the two sets are
compared in the coordinates given.  An algorithm without correspondences offers
nothing to align on; when ids exist, :func:`faultlab.metrics.map_errors`
aligns the estimate with the Kabsch fit first (documented there).
"""

from __future__ import annotations

import warnings

import numpy as np

from faultlab.errors import ScenarioError, SlamOutputError

__all__ = ["earth_movers_distance"]

#: Network-simplex iteration cap (POT's default of 1e5 can stop large problems early).
_MAX_ITER = 100_000_000


def _xy(xy, *, what: str, error: type[Exception]) -> np.ndarray:
    arr = np.asarray(xy, dtype=float)
    if arr.size == 0:
        return arr.reshape(0, 2)
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise error(f"{what} landmarks must have shape (n, 2), got {arr.shape}")
    bad = ~np.all(np.isfinite(arr), axis=1)
    if np.any(bad):
        raise error(f"{what} landmark at row {int(np.flatnonzero(bad)[0])} has a non-finite position")
    return arr


def earth_movers_distance(truth_xy, est_xy) -> float:
    """Earth mover's distance between two point sets with uniform weights.

    Parameters
    ----------
    truth_xy : array_like, shape (n, 2)
        Ground-truth landmark positions, m.
    est_xy : array_like, shape (m, 2)
        Estimated landmark positions, m (``m`` may differ from ``n``).

    Returns
    -------
    float
        The optimal transport cost with Euclidean ground distance, m (the
        average distance travelled per unit of mass).  NaN if either set is
        empty (no transport problem).

    Raises
    ------
    ScenarioError, SlamOutputError
        Malformed or non-finite truth (resp. estimate) positions.

    Notes
    -----
    Computed exactly with POT's network simplex, ``ot.emd2(a, b, M)``, with
    ``a = 1/n``, ``b = 1/m`` and ``M = ot.dist(truth, est, metric="euclidean", backend="scipy")``.
    No alignment is applied (see the module docstring).

    Cost grows roughly cubically with the number of landmarks; measured on
    this machine: 0.04 s for 500, 0.5 s for 1500, 3.4 s for 3000 and 18 s
    (1.6 GB peak) for 6000 landmarks per map -- the largest Table I maps
    (400 m^2 at 15 lm/m^2).
    """
    p = _xy(truth_xy, what="ground-truth", error=ScenarioError)
    q = _xy(est_xy, what="estimated", error=SlamOutputError)
    n, m = p.shape[0], q.shape[0]
    if n == 0 or m == 0:
        return float("nan")
    a = np.full(n, 1.0 / n)
    b = np.full(m, 1.0 / m)
    # backend="scipy": exact pairwise differences (cdist); the default expansion
    # |x|^2 + |y|^2 - 2 x.y loses ~1e-8 m to cancellation near zero distance.
    import ot  # POT takes ~2 s to import; only jobs that compute an EMD pay for it

    cost = ot.dist(p, q, metric="euclidean", backend="scipy")
    value, log = ot.emd2(a, b, cost, numItermax=_MAX_ITER, log=True)
    if log.get("warning"):
        warnings.warn(f"earth_movers_distance: POT's solver stopped early ({log['warning']}); "
                      f"the value {float(value):.6g} m is an upper bound", RuntimeWarning, stacklevel=2)
    return float(value)
