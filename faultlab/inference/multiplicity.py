"""Holm's step-down adjustment, as statsmodels computes it, without the full garbage collection it forces.

statsmodels' ``multipletests(method="holm")`` ends its Holm branch with ``gc.collect()`` (statsmodels
0.14 and 0.15). A full collection walks every object the process holds: 0.04-0.1 s per call in a
report or a test process, about a tenth of rendering a report, for nothing it could free there. This
module is the one place faultlab asks for Holm: the values are statsmodels', computed with the
collection turned into a no-op for the duration of the call.
"""

from __future__ import annotations

import gc
import threading

import numpy as np
from statsmodels.stats.multitest import multipletests

__all__ = ["holm"]

_SWAP = threading.Lock()  # one swap of gc.collect at a time, so that every swap is undone in order


def _no_collection(generation: int = 2) -> int:
    return 0


def holm(p, *, alpha: float = 0.05) -> tuple[np.ndarray, np.ndarray]:
    """Holm's step-down procedure over a family of p values.

    Parameters
    ----------
    p : array_like, shape (n,)
        The family's p values, none NaN.
    alpha : float
        Family-wise error rate.

    Returns
    -------
    reject : ndarray of bool, shape (n,)
        Whether Holm rejects each hypothesis at ``alpha``.
    p_adjusted : ndarray of float, shape (n,)
        Holm-adjusted p values (capped at 1).

    Both are ``statsmodels.stats.multitest.multipletests(p, alpha=alpha, method="holm")[:2]``, bit for
    bit; only its forced ``gc.collect()`` is skipped (another thread calling ``gc.collect`` during
    the call gets the no-op too, which frees nothing that the next automatic collection would not).
    """
    p = np.asarray(p, dtype=float)
    with _SWAP:
        collect, gc.collect = gc.collect, _no_collection
        try:
            reject, adjusted, _, _ = multipletests(p, alpha=alpha, method="holm")
        finally:
            gc.collect = collect
    return reject, adjusted
