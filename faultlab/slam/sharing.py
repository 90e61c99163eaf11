"""The correction step for particles that share landmark storage and update it one after another.

A FastSLAM written as a loop over particle objects that resamples by shallow copies (the paper's
filter, PythonRobotics' ``fast_slam1.py``; :func:`faultlab.slam.paperunits.apply_resample_aliased`)
leaves several particles holding the *same* landmark arrays.  Its update loop then applies every
observation of a shared landmark once per sharer, in particle order, each sharer starting from the
previous sharer's result: the first sharer may initialise the landmark, the next ones update that
estimate with their own poses, and the covariance shrinks once per sharer.

:func:`correct_in_sharer_order` computes exactly that with the filter's own units.  Sharers of one
storage row form a *group*; the chain inside a group is sequential, the groups and the step's
observations are independent.  So the loop runs over the *rank* of a particle within its group
(rank ``t`` = the ``t``-th sharer in particle order) and every iteration processes the ``t``-th
sharers of all groups and all observations at once, calling the units on those particles.  The
number of iterations is the size of the largest group (up to N once every particle shares one map,
which the shallow copies lead to: on fixed-suite cases all 200 particles share one map after a few
dozen steps, in the replication package's own code as here); the reference path (no sharing) never
comes here.  The chains are inherently sequential, so the cost is N iterations per observed step;
taking several ranks at once would change the result, since every sharer starts from the previous
sharer's update through the nonlinear measurement model.  Here each iteration calls the units on
tiny arrays (about 0.5 ms of Python per rank at k ~ 30 observations); when the correction units are
the references, the filter runs the compiled twin of this function instead
(:func:`faultlab.slam.twins.correct_in_sharer_order`: one kernel call and one numpy ``arctan2`` per
rank, bit for bit the same).
"""

from __future__ import annotations

import numpy as np

__all__ = ["sharer_ranks", "correct_in_sharer_order"]


def sharer_ranks(owner: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Groups of particles that share a storage row and each particle's rank in its group.

    Parameters
    ----------
    owner : ndarray of int, shape (N,)
        Storage row of every particle.

    Returns
    -------
    group : ndarray of intp, shape (N,)
        Group of every particle (``0 .. G - 1``, in order of the rows).
    rank : ndarray of intp, shape (N,)
        Position of the particle among its group's members in increasing particle index.
    order : ndarray of intp, shape (N,)
        Particles sorted by (group, index).
    """
    owner = np.asarray(owner)
    _, group = np.unique(owner, return_inverse=True)
    group = group.reshape(-1).astype(np.intp)
    order = np.argsort(group, kind="stable")
    sizes = np.bincount(group)
    starts = np.cumsum(sizes) - sizes
    rank = np.empty(owner.shape[0], dtype=np.intp)
    rank[order] = np.arange(owner.shape[0]) - np.repeat(starts, sizes)
    return group, rank, order


def correct_in_sharer_order(steps, logw: np.ndarray, owner: np.ndarray, poses: np.ndarray, z: np.ndarray,
                            seen: np.ndarray, mu: np.ndarray, P: np.ndarray,
                            Q: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """One step's correction with sharers of a storage row updating it in particle order.

    For every group of sharers and every observation ``m`` the stored landmark
    passes through the group's members in increasing particle index; member
    ``i`` runs the units of the reference correction on it with its own pose:
    ``classify_new`` (an id counts as seen for every sharer after the first),
    ``init_landmarks`` where new, else ``predict_measurement``, ``innovation``,
    ``innovation_covariance``, ``log_likelihood`` (its weight factor) and
    ``ekf_update`` (the next member's starting point).  Finally
    ``combine_weights`` folds every particle's likelihoods into its weight.

    Parameters
    ----------
    steps : FastSlamSteps
        The units.
    logw : ndarray, shape (N,)
        Normalised log weights before the step.
    owner : ndarray of int, shape (N,)
        Storage row of every particle (equal rows = shared landmarks).
    poses : ndarray, shape (N, 3)
        Predicted poses.
    z : ndarray, shape (k, 2)
        Observations (range, bearing), one per observed id.
    seen : ndarray of bool, shape (k,)
        Whether each id was observed in an earlier step.
    mu : ndarray, shape (N, k, 2)
        Stored means of the observed landmarks as each particle reads them
        (sharers read equal values).
    P : ndarray, shape (N, k, 2, 2)
        Stored covariances.
    Q : ndarray, shape (2, 2)

    Returns
    -------
    logw : ndarray, shape (N,)
        Unnormalised log weights from ``steps.combine_weights``.
    mu : ndarray, shape (N, k, 2)
        The value every particle's storage row holds after the step (the last
        sharer's result, the same for all members of a group).
    P : ndarray, shape (N, k, 2, 2)
    """
    n, k = mu.shape[:2]
    group, rank, order = sharer_ranks(owner)
    first = order[np.flatnonzero(rank[order] == 0)]  # lowest-index member of each group, by group
    gmu = np.array(mu[first], dtype=float)  # (G, k, 2): the shared rows, updated member by member
    gP = np.array(P[first], dtype=float)
    loglik = np.zeros((n, k))
    known = np.zeros((n, k), dtype=bool)
    seen_now = np.asarray(seen, dtype=bool)
    all_seen = np.ones(k, dtype=bool)
    by_rank = order[np.argsort(rank[order], kind="stable")]
    bounds = np.searchsorted(rank[by_rank], np.arange(int(rank.max()) + 2))
    for t in range(bounds.size - 1):
        members = by_rank[bounds[t]:bounds[t + 1]]  # the t-th sharer of every group that has one
        g = group[members]
        x = poses[members]
        m = gmu[g]
        Pm = gP[g]
        new = np.asarray(steps.classify_new(seen_now, m), dtype=bool)
        if new.any():
            c = np.flatnonzero(new.any(axis=0))
            mu0, P0 = steps.init_landmarks(x, z[c], Q, wrap=steps.wrap_bearing)
            sel = new[:, c]
            m[:, c] = np.where(sel[..., None], np.asarray(mu0, dtype=float), m[:, c])
            Pm[:, c] = np.where(sel[..., None, None], np.asarray(P0, dtype=float), Pm[:, c])
        zhat, H = steps.predict_measurement(x, m)
        nu = steps.innovation(z, zhat, wrap=steps.wrap_bearing)
        S = steps.innovation_covariance(H, Pm, Q)
        loglik[members] = steps.log_likelihood(nu, S)
        known[members] = ~new
        m_new, P_new = steps.ekf_update(m, Pm, H, S, nu)
        gmu[g] = np.where(new[..., None], m, np.asarray(m_new, dtype=float))
        gP[g] = np.where(new[..., None, None], Pm, np.asarray(P_new, dtype=float))
        seen_now = all_seen  # the first sharer has processed every observed id
    logw = np.asarray(steps.combine_weights(logw, loglik, known), dtype=float)
    return logw, gmu[group], gP[group]
