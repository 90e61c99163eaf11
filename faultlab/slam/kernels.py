"""Compiled loops behind the twins of the reference units (:mod:`faultlab.slam.twins`).

Each kernel is a plain loop over (observation, particle) pairs that performs, element by element,
*the same IEEE operations in the same order* as the numpy formulas of the reference unit it
serves (:mod:`faultlab.slam.units`), so its results are bit-identical to the unit's.  The kernels
contain only ``+ - * /``, ``sqrt`` and ``floor``, which IEEE 754 defines exactly; the
transcendental functions (``atan2``, ``log``, ``cos``, ``sin``) stay in numpy, outside the
kernels, because numba's (the C library's) and numpy's (SIMD) implementations may differ in the
last bit.  They are
compiled without ``fastmath`` (no reassociation, no fused multiply-add) and with numpy's error
model (a division by zero gives ``inf``/``nan`` as in numpy, never an exception).

Arrays of (particle, observation) values are passed *component by component* as 2-D arrays of
shape (k, M): observation-major, particle-fastest, the storage order of the filter (so the loops
read contiguous memory).  Compilation is cached on disk (``cache=True``) in the user's cache
directory (:func:`faultlab.cache.numba_cache_dir`; ``NUMBA_CACHE_DIR`` overrides it), never next
to the source: set in the environment before numba is imported (worker processes inherit it) and
in numba's configuration if numba was imported first.
"""

from __future__ import annotations

import math
import os

from faultlab.cache import numba_cache_dir

os.environ.setdefault("NUMBA_CACHE_DIR", str(numba_cache_dir()))

import numba  # noqa: E402  (after its cache directory is chosen)
import numpy as np  # noqa: E402
from numba import njit  # noqa: E402

if not numba.config.CACHE_DIR:  # numba was imported before the variable was set
    numba.config.CACHE_DIR = os.environ["NUMBA_CACHE_DIR"]

__all__ = ["noisy_controls", "motion", "offsets", "measurement", "innovation_pairs", "sandwich", "quadratic_form", "finish_log_likelihood",
           "ekf_correction", "fused_correction", "gather_pairs", "scatter_pairs",
           "take_rows", "systematic_indices", "sharer_rank"]

_TWO_PI = 2.0 * math.pi
_INV_TWO_PI = 1.0 / _TWO_PI
_PI = math.pi
_LOG_TWO_PI = math.log(_TWO_PI)

_jit = njit(cache=True, error_model="numpy", nogil=True)


@_jit
def offsets(x, mx, my, dx, dy):
    """``dx = mx - x[:, 0]``, ``dy = my - x[:, 1]`` for (k, M) landmark coordinates and poses x (M, 3)."""
    k, m = mx.shape
    for j in range(k):
        for i in range(m):
            dx[j, i] = mx[j, i] - x[i, 0]
            dy[j, i] = my[j, i] - x[i, 1]


@_jit
def _wrap(a):
    t = a + _PI
    t = t * _INV_TWO_PI
    t = np.floor(t)  # a float (math.floor would round to an int64 and overflow)
    t = t * _TWO_PI
    return a - t


@_jit
def noisy_controls(u, eps, std_v, std_omega, out):
    """``out = u + eps * (std_v, std_omega)`` for the control ``u`` (2,) and the draws ``eps`` (N, 2)
    (``sample_controls`` after its draw)."""
    for i in range(eps.shape[0]):
        out[i, 0] = u[0] + eps[i, 0] * std_v
        out[i, 1] = u[1] + eps[i, 1] * std_omega


@_jit
def motion(poses, u, cos_th, sin_th, out):
    """``motion_model`` with the reference heading wrap, after numpy's ``cos`` and ``sin`` of the
    headings: ``out = (x + v cos, y + v sin, wrap(theta + omega))`` for poses (N, 3), controls (N, 2)."""
    for i in range(poses.shape[0]):
        v = u[i, 0]
        out[i, 0] = poses[i, 0] + v * cos_th[i]
        out[i, 1] = poses[i, 1] + v * sin_th[i]
        out[i, 2] = _wrap(poses[i, 2] + u[i, 1])


@_jit
def measurement(x, dx, dy, bearing, z0, z1, h00, h01, h10, h11):
    """The rest of ``predict_measurement`` after numpy's ``arctan2``: ``z_hat`` and ``H``.

    ``bearing`` is ``arctan2(dy, dx)`` (k, M); writes ``z0 = sqrt(q)``, ``z1 = bearing - theta``
    and the four entries of ``H``.
    """
    k, m = dx.shape
    for j in range(k):
        for i in range(m):
            ddx = dx[j, i]
            ddy = dy[j, i]
            d = math.sqrt(ddx * ddx + ddy * ddy)
            z0[j, i] = d
            z1[j, i] = bearing[j, i] - x[i, 2]
            inv_d = 1.0 / d
            h00[j, i] = ddx * inv_d
            h01[j, i] = ddy * inv_d
            inv_q = inv_d * inv_d
            h10[j, i] = -(ddy * inv_q)
            h11[j, i] = ddx * inv_q


@_jit
def innovation_pairs(z, zh0, zh1, nu0, nu1):
    """``nu = z - z_hat`` with the bearing wrapped to [-pi, pi) (the reference wrap)."""
    k, m = zh0.shape
    for j in range(k):
        r = z[j, 0]
        b = z[j, 1]
        for i in range(m):
            nu0[j, i] = r - zh0[j, i]
            nu1[j, i] = _wrap(b - zh1[j, i])


@_jit
def sandwich(a, b, c, e, p00, p01, p11, q00, q01, q11, add_q01, o00, o01, o11):
    """``A P A^T + Q`` for A = [[a, b], [c, e]] and symmetric P, Q (the covariance sandwich).

    ``q01`` is added to the off-diagonal entry only when ``add_q01`` (the reference adds nothing
    when ``Q[0, 1] == 0``, which keeps the sign of a zero).
    """
    k, m = a.shape
    for j in range(k):
        for i in range(m):
            aa = a[j, i]
            bb = b[j, i]
            cc = c[j, i]
            ee = e[j, i]
            s00 = p00[j, i]
            s01 = p01[j, i]
            s11 = p11[j, i]
            t00 = aa * s00 + bb * s01
            t01 = aa * s01 + bb * s11
            t10 = cc * s00 + ee * s01
            t11 = cc * s01 + ee * s11
            o00[j, i] = (t00 * aa + t01 * bb) + q00
            off = t00 * cc + t01 * ee
            if add_q01:
                off = off + q01
            o01[j, i] = off
            o11[j, i] = (t10 * cc + t11 * ee) + q11


@_jit
def quadratic_form(n0, n1, s00, s01, s11, t, det):
    """``t = nu^T S^-1 nu`` and ``det = det S`` in the reference's order of operations."""
    k, m = n0.shape
    for j in range(k):
        for i in range(m):
            a = s00[j, i]
            b = s01[j, i]
            c = s11[j, i]
            d = a * c - b * b
            u = n0[j, i]
            v = n1[j, i]
            q = u * c
            q = q - 2.0 * (v * b)
            q = q * u
            q = q + v * v * a
            t[j, i] = q / d
            det[j, i] = d


@_jit
def finish_log_likelihood(t, log_det):
    """``t = (t + log det) * -0.5 - log(2 pi)`` in place (``log_det`` from numpy's ``log``)."""
    k, m = t.shape
    for j in range(k):
        for i in range(m):
            t[j, i] = (t[j, i] + log_det[j, i]) * -0.5 - _LOG_TWO_PI


@_jit
def _ekf_pair(mu0, mu1, p00, p01, p11, h00, h01, h10, h11, s00, s01, s11, n0, n1):
    m00 = p00 * h00 + p01 * h01
    m01 = p00 * h10 + p01 * h11
    m10 = p01 * h00 + p11 * h01
    m11 = p01 * h10 + p11 * h11
    inv_det = 1.0 / (s00 * s11 - s01 * s01)
    k00 = (m00 * s11 - m01 * s01) * inv_det
    k01 = (m01 * s00 - m00 * s01) * inv_det
    k10 = (m10 * s11 - m11 * s01) * inv_det
    k11 = (m11 * s00 - m10 * s01) * inv_det
    return (mu0 + (k00 * n0 + k01 * n1), mu1 + (k10 * n0 + k11 * n1),
            p00 - (k00 * m00 + k01 * m01), p01 - (k00 * m10 + k01 * m11), p11 - (k10 * m10 + k11 * m11))


@_jit
def ekf_correction(mu0, mu1, p00, p01, p11, h00, h01, h10, h11, s00, s01, s11, n0, n1,
                   o_mu0, o_mu1, o00, o01, o11):
    """``ekf_update``: ``K = P H^T S^-1``, ``mu + K nu``, ``P - K (P H^T)^T`` per pair."""
    k, m = mu0.shape
    for j in range(k):
        for i in range(m):
            a, b, c, d, e = _ekf_pair(mu0[j, i], mu1[j, i], p00[j, i], p01[j, i], p11[j, i],
                                      h00[j, i], h01[j, i], h10[j, i], h11[j, i],
                                      s00[j, i], s01[j, i], s11[j, i], n0[j, i], n1[j, i])
            o_mu0[j, i] = a
            o_mu1[j, i] = b
            o00[j, i] = c
            o01[j, i] = d
            o11[j, i] = e


@_jit
def _pair_terms(ddx, ddy, bearing, theta, r, b, p00, p01, p11, q00, q01, q11, add_q01):
    """One particle-observation pair through ``predict_measurement`` (after ``arctan2``),
    ``innovation``, ``innovation_covariance`` and the quadratic form of ``log_likelihood``, by the
    unit-by-unit kernels' operations in their order.

    Returns ``(h00, h01, h10, h11, n0, n1, s00, s01, s11, q / det, det)``.
    """
    # predict_measurement
    d = math.sqrt(ddx * ddx + ddy * ddy)
    zb = bearing - theta
    inv_d = 1.0 / d
    h00 = ddx * inv_d
    h01 = ddy * inv_d
    inv_q = inv_d * inv_d
    h10 = -(ddy * inv_q)
    h11 = ddx * inv_q
    # innovation
    n0 = r - d
    n1 = _wrap(b - zb)
    # innovation_covariance
    t00 = h00 * p00 + h01 * p01
    t01 = h00 * p01 + h01 * p11
    t10 = h10 * p00 + h11 * p01
    t11 = h10 * p01 + h11 * p11
    s00 = (t00 * h00 + t01 * h01) + q00
    s01 = t00 * h10 + t01 * h11
    if add_q01:
        s01 = s01 + q01
    s11 = (t10 * h10 + t11 * h11) + q11
    # log_likelihood, up to numpy's log(det)
    dd = s00 * s11 - s01 * s01
    q = n0 * s11
    q = q - 2.0 * (n1 * s01)
    q = q * n0
    q = q + n1 * n1 * s00
    return h00, h01, h10, h11, n0, n1, s00, s01, s11, q / dd, dd


@_jit
def fused_correction(x, z, mb, pb, dx, dy, bearing, q00, q01, q11, add_q01, mu_new, P_new, t, det):
    """``predict_measurement`` (after ``arctan2``), ``innovation``, ``innovation_covariance``, the
    quadratic form of ``log_likelihood`` and ``ekf_update`` in one pass, without intermediates.

    ``mb`` (2, k, M) and ``pb`` (2, 2, k, M) are the gathered means and covariances, ``bearing``
    is ``arctan2(dy, dx)``.  Writes ``mu_new`` (2, k, M), ``P_new`` (2, 2, k, M), ``t`` (k, M) as
    :func:`quadratic_form` and ``det`` (k, M) (``det S``); :func:`finish_log_likelihood` with
    numpy's ``log(det)`` completes the log likelihood.  Each value is computed by the same
    operations as the unit-by-unit kernels.
    """
    k, m = dx.shape
    for j in range(k):
        r = z[j, 0]
        b = z[j, 1]
        for i in range(m):
            p00 = pb[0, 0, j, i]
            p01 = pb[0, 1, j, i]
            p11 = pb[1, 1, j, i]
            h00, h01, h10, h11, n0, n1, s00, s01, s11, tq, dd = _pair_terms(
                dx[j, i], dy[j, i], bearing[j, i], x[i, 2], r, b, p00, p01, p11, q00, q01, q11, add_q01)
            t[j, i] = tq
            det[j, i] = dd
            # ekf_update
            a, bb, c, e, f = _ekf_pair(mb[0, j, i], mb[1, j, i], p00, p01, p11, h00, h01, h10, h11,
                                       s00, s01, s11, n0, n1)
            mu_new[0, j, i] = a
            mu_new[1, j, i] = bb
            P_new[0, 0, j, i] = c
            P_new[0, 1, j, i] = e
            P_new[1, 0, j, i] = e
            P_new[1, 1, j, i] = f


@_jit
def gather_pairs(mu_store, P_store, anc, cols, p0, n, mb, pb):
    """The stored landmarks of columns ``cols`` (k,) for particles ``p0 .. p0 + M - 1``.

    ``mu_store`` (2, cap, B N) and ``P_store`` (2, 2, cap, B N) are the filter's storage buffers,
    ``anc`` (B N, cap) the ancestry (rows numbered within each filter of ``n`` particles).  Writes
    ``mb[c, j, i] = mu_store[c, cols[j], r]`` and ``pb[a, b, j, i] = P_store[a, b, cols[j], r]``
    with ``r = anc[p, cols[j]] + (p // n) n``, ``p = p0 + i``: a copy (no arithmetic).
    """
    k = cols.shape[0]
    m = mb.shape[2]
    rows = np.empty((k, m), dtype=np.intp)
    for i in range(m):  # particle-major: one row of anc at a time
        p = p0 + i
        off = (p // n) * n
        for j in range(k):
            rows[j, i] = anc[p, cols[j]] + off
    for j in range(k):
        c = cols[j]
        for i in range(m):
            r = rows[j, i]
            mb[0, j, i] = mu_store[0, c, r]
            mb[1, j, i] = mu_store[1, c, r]
            pb[0, 0, j, i] = P_store[0, 0, c, r]
            pb[0, 1, j, i] = P_store[0, 1, c, r]
            pb[1, 0, j, i] = P_store[1, 0, c, r]
            pb[1, 1, j, i] = P_store[1, 1, c, r]


@_jit
def scatter_pairs(mu_new, P_new, cols, p0, owner, mu_store, P_store, anc):
    """Write every particle's new landmarks of ``cols`` into its own storage row (a copy).

    Particle ``p = p0 + i`` writes row ``p`` of the storage and points ``anc[p, cols[j]]`` at
    ``owner[i]`` (its row numbered within its filter).
    """
    k = cols.shape[0]
    m = mu_new.shape[2]
    for j in range(k):
        c = cols[j]
        for i in range(m):
            p = p0 + i
            mu_store[0, c, p] = mu_new[0, j, i]
            mu_store[1, c, p] = mu_new[1, j, i]
            P_store[0, 0, c, p] = P_new[0, 0, j, i]
            P_store[0, 1, c, p] = P_new[0, 1, j, i]
            P_store[1, 0, c, p] = P_new[1, 0, j, i]
            P_store[1, 1, c, p] = P_new[1, 1, j, i]
    for i in range(m):
        o = owner[i]
        for j in range(k):
            anc[p0 + i, cols[j]] = o


@_jit
def take_rows(src, rows, dst, width):
    """``dst[i, :width] = src[rows[i], :width]`` for every row ``i`` of ``dst`` (a copy)."""
    for i in range(rows.shape[0]):
        r = rows[i]
        for c in range(width):
            dst[i, c] = src[r, c]


@_jit
def systematic_indices(w, r, out):
    """Low-variance resampling indices: ``out[m]`` = the first ``i`` with ``cumsum(w)[i] >= r + m / N``,
    at most ``N - 1``.

    The cumulative sum is accumulated in order (as numpy's ``cumsum``); the thresholds increase
    with ``m``, so one merge-like scan finds the same leftmost positions as a binary search
    (``searchsorted(..., side="left")``) for weights without NaN.
    """
    n = w.shape[0]
    cs = np.empty(n)
    acc = 0.0
    for i in range(n):
        acc = acc + w[i] if i > 0 else w[0]
        cs[i] = acc
    i = 0
    for m in range(n):
        u = r + m / n
        while i < n and cs[i] < u:
            i += 1
        out[m] = i if i < n else n - 1


# ---------------------------------------------------------------------------------------------
# the reference step: the kernels of a filter whose every unit is the reference
# ---------------------------------------------------------------------------------------------


@_jit
def predict_poses(poses, u, eps, noisy, std_v, std_omega, cos_th, sin_th, out):
    """``sample_controls`` (after its draw ``eps`` (N, 2), when ``noisy``; else the control ``u``
    itself, an empty update) and ``motion_model`` with the reference heading wrap, in one pass."""
    for i in range(poses.shape[0]):
        if noisy:
            v = u[0] + eps[i, 0] * std_v
            w = u[1] + eps[i, 1] * std_omega
        else:
            v = u[0]
            w = u[1]
        out[i, 0] = poses[i, 0] + v * cos_th[i]
        out[i, 1] = poses[i, 1] + v * sin_th[i]
        out[i, 2] = _wrap(poses[i, 2] + w)


@_jit
def gather_observed(mu_store, anc, cols, seen, mu_init, x, n, rows, mb, dx, dy):
    """The gather of the means of :func:`gather_pairs` for all ``M`` particles, with the
    observations that start a landmark (``not seen[j]``, the ``s``-th such) taking
    ``mu_init[:, s]`` (2, k_new, M) instead (``init_landmarks`` of the unseen observations in
    order), and the offsets of ``predict_measurement``: ``dx = mb[0] - x[:, 0]``,
    ``dy = mb[1] - x[:, 1]`` (k, M).  ``rows`` (k, M) receives each pair's storage row
    ``anc[i, cols[j]] + (i // n) n`` (read by :func:`correct_observed` for the covariances)."""
    k = cols.shape[0]
    m = x.shape[0]
    for i in range(m):  # particle-major: one row of anc at a time
        off = (i // n) * n
        for j in range(k):
            rows[j, i] = anc[i, cols[j]] + off
    s = -1
    for j in range(k):
        c = cols[j]
        if seen[j]:
            for i in range(m):
                r = rows[j, i]
                _put_mean(mb, dx, dy, x, j, i, mu_store[0, c, r], mu_store[1, c, r])
        else:
            s += 1
            for i in range(m):
                _put_mean(mb, dx, dy, x, j, i, mu_init[0, s, i], mu_init[1, s, i])


@_jit
def _put_mean(mb, dx, dy, x, j, i, m0, m1):
    """Pair (j, i)'s landmark mean and its offset from the particle's position."""
    mb[0, j, i] = m0
    mb[1, j, i] = m1
    dx[j, i] = m0 - x[i, 0]
    dy[j, i] = m1 - x[i, 1]


#: Rows of :func:`correct_observed`'s column buffers: inputs (offsets, bearing, heading, mean,
#: covariance) and outputs (quadratic form, determinant, updated mean and covariance).
_DX, _DY, _BEARING, _THETA, _MU0, _MU1, _P00, _P01, _P11 = range(9)
_T, _DET, _NMU0, _NMU1, _N00, _N01, _N11 = range(7)


@_jit
def _correct_column(cin, cout, r, b, q00, q01, q11, add_q01, known):
    """One observation's pairs through :func:`_pair_terms` (and :func:`_ekf_pair` if ``known``):
    ``cin`` (9, M) holds the pairs' inputs, ``cout`` (7, M) receives their outputs.

    The loop reads one buffer and writes the other, with no branch that depends on the pair, so
    that the compiler can run it on several pairs at once (SIMD): the operations are those of the
    scalar kernels, each correctly rounded, so every value is the same bit for bit.
    """
    m = cin.shape[1]
    if known:
        for i in range(m):
            p00 = cin[_P00, i]
            p01 = cin[_P01, i]
            p11 = cin[_P11, i]
            h00, h01, h10, h11, n0, n1, s00, s01, s11, tq, dd = _pair_terms(
                cin[_DX, i], cin[_DY, i], cin[_BEARING, i], cin[_THETA, i], r, b, p00, p01, p11,
                q00, q01, q11, add_q01)
            a, bb, cc, e, f = _ekf_pair(cin[_MU0, i], cin[_MU1, i], p00, p01, p11, h00, h01, h10, h11,
                                        s00, s01, s11, n0, n1)
            cout[_T, i] = tq
            cout[_DET, i] = dd
            cout[_NMU0, i] = a
            cout[_NMU1, i] = bb
            cout[_N00, i] = cc
            cout[_N01, i] = e
            cout[_N11, i] = f
    else:
        for i in range(m):
            h00, h01, h10, h11, n0, n1, s00, s01, s11, tq, dd = _pair_terms(
                cin[_DX, i], cin[_DY, i], cin[_BEARING, i], cin[_THETA, i], r, b, cin[_P00, i], cin[_P01, i],
                cin[_P11, i], q00, q01, q11, add_q01)
            cout[_T, i] = tq
            cout[_DET, i] = dd


@_jit
def correct_observed(x, z, seen, mb, rows, P_init, dx, dy, bearing, q00, q01, q11, add_q01, cols, n,
                     mu_store, P_store, anc, t, det):
    """:func:`fused_correction` followed by the write-back of :func:`scatter_pairs` (owner: every
    particle its own row), without intermediate arrays beyond one column's buffers.

    ``mb`` (2, k, M) are the means of :func:`gather_observed`; the covariances are read from the
    storage rows ``rows`` (k, M) of the known landmarks (``seen[j]``), a whole column before any
    of it is written (the columns ``cols`` are distinct), and from ``P_init`` (2, 2, k_new, M)
    (``init_landmarks``, the unseen observations in order) for the others.  Particle ``i`` (of all
    ``M``, filters of ``n``) writes row ``i`` of the storage: its EKF update of the known
    landmarks and the initial values of the others, and points ``anc[i, cols[j]]`` at its row
    within its filter.  ``t`` and ``det`` are written for every pair as by :func:`fused_correction`
    (they may share memory with ``bearing`` and ``dy``: a column is read before it is written).
    Each column's pairs are computed by :func:`_correct_column` from a buffer of their inputs.
    """
    k, m = dx.shape
    cin = np.empty((9, m))
    cout = np.empty((7, m))
    for i in range(m):
        cin[_THETA, i] = x[i, 2]
    s = -1
    for j in range(k):
        c = cols[j]
        known = seen[j]
        for i in range(m):
            cin[_DX, i] = dx[j, i]
            cin[_DY, i] = dy[j, i]
            cin[_BEARING, i] = bearing[j, i]
        if known:
            for i in range(m):
                w = rows[j, i]
                cin[_MU0, i] = mb[0, j, i]
                cin[_MU1, i] = mb[1, j, i]
                cin[_P00, i] = P_store[0, 0, c, w]
                cin[_P01, i] = P_store[0, 1, c, w]
                cin[_P11, i] = P_store[1, 1, c, w]
        else:
            s += 1
            for i in range(m):
                cin[_P00, i] = P_init[0, 0, s, i]
                cin[_P01, i] = P_init[0, 1, s, i]
                cin[_P11, i] = P_init[1, 1, s, i]
        _correct_column(cin, cout, z[j, 0], z[j, 1], q00, q01, q11, add_q01, known)
        for i in range(m):
            t[j, i] = cout[_T, i]
            det[j, i] = cout[_DET, i]
        if known:
            for i in range(m):
                mu_store[0, c, i] = cout[_NMU0, i]
                mu_store[1, c, i] = cout[_NMU1, i]
                e = cout[_N01, i]
                P_store[0, 0, c, i] = cout[_N00, i]
                P_store[0, 1, c, i] = e
                P_store[1, 0, c, i] = e
                P_store[1, 1, c, i] = cout[_N11, i]
        else:
            for i in range(m):
                mu_store[0, c, i] = mb[0, j, i]
                mu_store[1, c, i] = mb[1, j, i]
                P_store[0, 0, c, i] = P_init[0, 0, s, i]
                P_store[0, 1, c, i] = P_init[0, 1, s, i]
                P_store[1, 0, c, i] = P_init[1, 0, s, i]
                P_store[1, 1, c, i] = P_init[1, 1, s, i]
    for i in range(m):
        o = i - (i // n) * n
        for j in range(k):
            anc[i, cols[j]] = o


@_jit
def _pairwise_block(a, lo, n):
    """numpy's pairwise summation of ``a[lo:lo + n]`` for ``n <= 128`` (one block: eight
    accumulators, then the rest in order; below 8 values, a plain sum from -0.0)."""
    if n < 8:
        res = -0.0
        for i in range(lo, lo + n):
            res += a[i]
        return res
    r0 = a[lo]
    r1 = a[lo + 1]
    r2 = a[lo + 2]
    r3 = a[lo + 3]
    r4 = a[lo + 4]
    r5 = a[lo + 5]
    r6 = a[lo + 6]
    r7 = a[lo + 7]
    i = 8
    while i < n - (n % 8):
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@_jit
def _pairwise_block_columns(a, out):
    """``out[i] = _pairwise_block(a[:, i], 0, k)`` for every column of ``a`` (k, m), ``k <= 128``:
    the same additions in the same order for each column, done for all columns side by side."""
    k, m = a.shape
    if k < 8:
        for i in range(m):
            out[i] = -0.0
        for j in range(k):
            for i in range(m):
                out[i] += a[j, i]
        return
    acc = np.empty((8, m))
    for q in range(8):
        for i in range(m):
            acc[q, i] = a[q, i]
    j = 8
    while j < k - (k % 8):
        for q in range(8):
            for i in range(m):
                acc[q, i] += a[j + q, i]
        j += 8
    for i in range(m):
        out[i] = ((acc[0, i] + acc[1, i]) + (acc[2, i] + acc[3, i])) + ((acc[4, i] + acc[5, i]) + (acc[6, i] + acc[7, i]))
    while j < k:
        for i in range(m):
            out[i] += a[j, i]
        j += 1


@_jit
def _pairwise_sum(a, lo, n):
    """numpy's pairwise summation of ``a[lo:lo + n]`` (the order of ``np.add.reduce`` along a
    contiguous axis): blocks of at most 128 (:func:`_pairwise_block`), above that the sum of the
    two halves (the first a multiple of 8 long).  The halving is walked with an explicit stack
    (a recursive kernel would not survive numba's on-disk cache)."""
    if n <= 128:
        return _pairwise_block(a, lo, n)
    f_lo = np.empty(64, dtype=np.intp)
    f_n = np.empty(64, dtype=np.intp)
    f_left = np.empty(64)
    f_state = np.zeros(64, dtype=np.intp)  # 0: not split, 1: left half pending, 2: right half pending
    sp = 0
    f_lo[0] = lo
    f_n[0] = n
    while True:
        cn = f_n[sp]
        if cn > 128:
            f_state[sp] = 1
            half = cn // 2
            half -= half % 8
            sp += 1
            f_lo[sp] = f_lo[sp - 1]
            f_n[sp] = half
            f_state[sp] = 0
            continue
        v = _pairwise_block(a, f_lo[sp], cn)
        sp -= 1
        while True:  # hand the value to the frames waiting for it
            if sp < 0:
                return v
            if f_state[sp] == 1:  # the left half: now the right half
                f_left[sp] = v
                f_state[sp] = 2
                half = f_n[sp] // 2
                half -= half % 8
                sp += 1
                f_lo[sp] = f_lo[sp - 1] + half
                f_n[sp] = f_n[sp - 1] - half
                f_state[sp] = 0
                break
            v = f_left[sp] + v
            sp -= 1


@_jit
def combine_observed(t, log_det, seen, logw, n, out, tops):
    """``log_likelihood``'s last operations, ``combine_weights`` and the first half of the weight
    normalisation, for all ``M`` particles (filters of ``n``).

    ``out[i] = logw[i] + sum_j known * loglik[i, j]`` with ``loglik = (t + log_det) * -0.5 -
    log(2 pi)`` (k, M) and ``known[i, j] = seen[j]``, summed as numpy sums the rows of
    ``where(known, loglik, 0)`` (0 + the pairwise sum); ``tops[f]`` is the maximum of filter
    ``f``'s ``out`` (NaN if any is NaN, as ``ndarray.max``), and where it is finite the filter's
    ``out`` is shifted by it (``out - top``).
    """
    k, m = t.shape
    if k <= 128:  # one pairwise block per particle: summed for all particles at once (SIMD)
        ll = np.empty((k, m))
        for j in range(k):
            if seen[j]:
                for i in range(m):
                    ll[j, i] = (t[j, i] + log_det[j, i]) * -0.5 - _LOG_TWO_PI
            else:
                for i in range(m):
                    ll[j, i] = 0.0
        sums = np.empty(m)
        _pairwise_block_columns(ll, sums)
        for i in range(m):
            s = 0.0
            s += sums[i]
            out[i] = logw[i] + s
    else:
        row = np.empty(k)
        for i in range(m):
            for j in range(k):
                if seen[j]:
                    row[j] = (t[j, i] + log_det[j, i]) * -0.5 - _LOG_TWO_PI
                else:
                    row[j] = 0.0
            s = 0.0
            s += _pairwise_sum(row, 0, k)
            out[i] = logw[i] + s
    for f in range(m // n):
        top = out[f * n]
        for i in range(f * n + 1, (f + 1) * n):
            v = out[i]
            if v > top or math.isnan(v):
                top = v
                if math.isnan(v):
                    break
        tops[f] = top
        if math.isfinite(top):
            for i in range(f * n, (f + 1) * n):
                out[i] = out[i] - top


# ---------------------------------------------------------------------------------------------
# the sharer-order correction: particles that share storage rows update them one after another
# ---------------------------------------------------------------------------------------------

#: Rows of :func:`sharer_rank`'s per-group landmark buffer ``g`` (6, k, G): mean and covariance.
_G_MU0, _G_MU1, _G_P00, _G_P01, _G_P10, _G_P11 = range(6)


@_jit
def sharer_rank(t, ints, consts, g, work, out):
    """Rank ``t`` of :func:`faultlab.slam.sharing.correct_in_sharer_order` with the reference units,
    then the offsets of rank ``t + 1``.

    ``work`` (3, N, k) and ``out`` (2, N, k) give the sizes.  ``ints`` packs ``bounds`` (R + 1),
    ``by_rank`` (N), ``group`` (N) and ``seen`` (k, 0 or 1), ``consts`` the poses ``x`` (N, 3),
    the observations ``z`` (k, 2) and ``(Q[0, 0], Q[0, 1], Q[1, 1], Q[0, 1] != 0)``, each flattened
    (few arguments: this kernel is called once per rank).  The members of rank ``t`` are
    ``by_rank[bounds[t]:bounds[t + 1]]`` (one per group, ``group`` of each particle); ``g``
    (6, k, G) holds every group's current landmarks (the shared rows).  ``work`` holds the
    ``p``-th member's offsets ``dx``, ``dy`` and numpy's ``arctan2(dy, dx)`` in row ``p``.  For
    every member ``i`` and observation ``j`` the pair goes through ``predict_measurement`` (after
    ``arctan2``), ``innovation``, ``innovation_covariance`` and the quadratic form of
    ``log_likelihood`` (:func:`_pair_terms`), writing ``out[0, i, j]`` (the form) and
    ``out[1, i, j]`` (``det S``), and, where the pair is known (``seen[j]`` or ``t > 0``: the first
    sharer has initialised every new landmark), through ``ekf_update``, whose result replaces the
    group's landmark (the next sharer's starting point); a new pair leaves the group's landmark (its
    initial value) as it is.  ``t < 0`` computes only the offsets of rank 0.
    """
    n = work.shape[1]
    k = work.shape[2]
    nb = ints.shape[0] - 2 * n - k
    bounds = ints[:nb]
    by_rank = ints[nb:nb + n]
    group = ints[nb + n:nb + 2 * n]
    seen = ints[nb + 2 * n:]
    x = consts[:3 * n]
    z = consts[3 * n:3 * n + 2 * k]
    q = consts[3 * n + 2 * k:]
    q00 = q[0]
    q01 = q[1]
    q11 = q[2]
    add_q01 = q[3] != 0.0
    if t >= 0:
        lo = bounds[t]
        for p in range(bounds[t + 1] - lo):
            i = by_rank[lo + p]
            c = group[i]
            theta = x[3 * i + 2]
            for j in range(k):
                p00 = g[_G_P00, j, c]
                p01 = g[_G_P01, j, c]
                p11 = g[_G_P11, j, c]
                h00, h01, h10, h11, n0, n1, s00, s01, s11, tq, dd = _pair_terms(
                    work[0, p, j], work[1, p, j], work[2, p, j], theta, z[2 * j], z[2 * j + 1], p00, p01, p11,
                    q00, q01, q11, add_q01)
                out[0, i, j] = tq
                out[1, i, j] = dd
                if t > 0 or seen[j] != 0:
                    a, bb, cc, e, f = _ekf_pair(g[_G_MU0, j, c], g[_G_MU1, j, c], p00, p01, p11,
                                                h00, h01, h10, h11, s00, s01, s11, n0, n1)
                    g[_G_MU0, j, c] = a
                    g[_G_MU1, j, c] = bb
                    g[_G_P00, j, c] = cc
                    g[_G_P01, j, c] = e
                    g[_G_P10, j, c] = e
                    g[_G_P11, j, c] = f
    if t + 2 < nb:
        lo = bounds[t + 1]
        for p in range(bounds[t + 2] - lo):
            i = by_rank[lo + p]
            c = group[i]
            for j in range(k):
                work[0, p, j] = g[_G_MU0, j, c] - x[3 * i]
                work[1, p, j] = g[_G_MU1, j, c] - x[3 * i + 1]


# ---------------------------------------------------------------------------------------------
# the staged correction: one correction unit replaced, every other one compiled around it
# ---------------------------------------------------------------------------------------------

#: The stages of the correction, in order; :func:`finish_staged`'s ``stage`` is the replaced one.
STAGE_MEASUREMENT, STAGE_INNOVATION, STAGE_COVARIANCE, STAGE_LIKELIHOOD, STAGE_EKF = range(5)


@_jit
def gather_landmarks(mu_store, P_store, anc, cols, seen, mu_init, P_init, x, n, mb, pb, dx, dy):
    """:func:`gather_observed` with the covariances too: ``mb`` (2, k, M) and ``pb`` (2, 2, k, M)
    receive every pair's stored landmark (storage row ``anc[i, cols[j]]`` within particle ``i``'s
    filter of ``n``), or for the observations that start a landmark (``not seen[j]``, the ``s``-th
    such) the initial values ``mu_init[:, s]`` (2, k_new, M) and ``P_init[:, :, s]``
    (2, 2, k_new, M); ``dx``, ``dy`` (k, M) the offsets of ``predict_measurement``.  A copy:
    no arithmetic beyond the offsets' subtraction."""
    k = cols.shape[0]
    m = x.shape[0]
    rows = np.empty((k, m), dtype=np.intp)
    for i in range(m):  # particle-major: one row of anc at a time
        off = (i // n) * n
        for j in range(k):
            rows[j, i] = anc[i, cols[j]] + off
    s = -1
    for j in range(k):
        c = cols[j]
        if seen[j]:
            for i in range(m):
                r = rows[j, i]
                _put_mean(mb, dx, dy, x, j, i, mu_store[0, c, r], mu_store[1, c, r])
                pb[0, 0, j, i] = P_store[0, 0, c, r]
                pb[0, 1, j, i] = P_store[0, 1, c, r]
                pb[1, 0, j, i] = P_store[1, 0, c, r]
                pb[1, 1, j, i] = P_store[1, 1, c, r]
        else:
            s += 1
            for i in range(m):
                _put_mean(mb, dx, dy, x, j, i, mu_init[0, s, i], mu_init[1, s, i])
                pb[0, 0, j, i] = P_init[0, 0, s, i]
                pb[0, 1, j, i] = P_init[0, 1, s, i]
                pb[1, 0, j, i] = P_init[1, 0, s, i]
                pb[1, 1, j, i] = P_init[1, 1, s, i]


@_jit
def _covariance(h00, h01, h10, h11, p00, p01, p11, q00, q01, q11, add_q01):
    """``innovation_covariance`` of one pair, by :func:`sandwich`'s operations: (s00, s01, s11)."""
    t00 = h00 * p00 + h01 * p01
    t01 = h00 * p01 + h01 * p11
    t10 = h10 * p00 + h11 * p01
    t11 = h10 * p01 + h11 * p11
    s00 = (t00 * h00 + t01 * h01) + q00
    s01 = t00 * h10 + t01 * h11
    if add_q01:
        s01 = s01 + q01
    s11 = (t10 * h10 + t11 * h11) + q11
    return s00, s01, s11


@_jit
def _quadratic(n0, n1, s00, s01, s11):
    """The quadratic form and determinant of ``log_likelihood`` of one pair (:func:`quadratic_form`)."""
    dd = s00 * s11 - s01 * s01
    q = n0 * s11
    q = q - 2.0 * (n1 * s01)
    q = q * n0
    q = q + n1 * n1 * s00
    return q / dd, dd


@_jit
def finish_staged(stage, z, seen, mb, pb, h00, h01, h10, h11, a0, a1, b0, b1, s00, s01, s11, e00, e01, e10, e11,
                  q00, q01, q11, add_q01, cols, n, mu_store, P_store, anc, t, det):
    """The correction's stages after the replaced one (``stage``, a ``STAGE_*``), then the write-back
    of :func:`correct_observed`, for the M particles x k observations of a step.

    Inputs, all (k, M) component arrays (any strides) unless said otherwise; those a stage does not
    read may be any 2-D float arrays:

    * ``mb`` (2, k, M), ``pb`` (2, 2, k, M): the means and covariances the units saw (initial
      values where new);
    * ``h00 .. h11``: ``H`` (the replaced ``predict_measurement``'s, or the compiled one's);
    * ``a0, a1``: ``z_hat`` of the replaced ``predict_measurement`` (read at ``STAGE_MEASUREMENT``);
    * ``b0, b1``: ``nu`` (read from ``STAGE_INNOVATION`` on);
    * ``s00, s01, s11``: ``S`` (read from ``STAGE_COVARIANCE`` on; ``S[1, 0]`` is not read, as by
      the reference units);
    * at ``STAGE_EKF``: ``a0, a1`` the new means and ``e00, e01, e10, e11`` the new covariances of the
      replaced ``ekf_update``.

    The stages after the replaced one are computed by the unit-by-unit kernels' operations
    (``innovation``, ``innovation_covariance``, the quadratic form of ``log_likelihood``,
    ``ekf_update``); before ``STAGE_LIKELIHOOD`` the form and ``det S`` of every pair go to ``t``
    and ``det`` (k, M).  Particle ``i`` writes storage row ``i``: the updated landmarks of the
    known observations (``seen[j]``), the initial ones (``mb``, ``pb``) of the others, and points
    ``anc[i, cols[j]]`` at its row within its filter of ``n``.
    """
    k = cols.shape[0]
    m = mb.shape[2]
    for j in range(k):
        c = cols[j]
        known = seen[j]
        r = z[j, 0]
        b = z[j, 1]
        for i in range(m):
            p00 = pb[0, 0, j, i]
            p01 = pb[0, 1, j, i]
            p11 = pb[1, 1, j, i]
            if stage == STAGE_EKF:
                nm0 = a0[j, i]
                nm1 = a1[j, i]
                np00 = e00[j, i]
                np01 = e01[j, i]
                np10 = e10[j, i]
                np11 = e11[j, i]
            else:
                g00 = h00[j, i]
                g01 = h01[j, i]
                g10 = h10[j, i]
                g11 = h11[j, i]
                if stage == STAGE_MEASUREMENT:
                    n0 = r - a0[j, i]
                    n1 = _wrap(b - a1[j, i])
                else:
                    n0 = b0[j, i]
                    n1 = b1[j, i]
                if stage <= STAGE_INNOVATION:
                    c00, c01, c11 = _covariance(g00, g01, g10, g11, p00, p01, p11, q00, q01, q11, add_q01)
                else:
                    c00 = s00[j, i]
                    c01 = s01[j, i]
                    c11 = s11[j, i]
                if stage < STAGE_LIKELIHOOD:
                    tq, dd = _quadratic(n0, n1, c00, c01, c11)
                    t[j, i] = tq
                    det[j, i] = dd
                nm0, nm1, np00, np01, np11 = _ekf_pair(mb[0, j, i], mb[1, j, i], p00, p01, p11, g00, g01, g10, g11,
                                                       c00, c01, c11, n0, n1)
                np10 = np01
            if known:
                mu_store[0, c, i] = nm0
                mu_store[1, c, i] = nm1
                P_store[0, 0, c, i] = np00
                P_store[0, 1, c, i] = np01
                P_store[1, 0, c, i] = np10
                P_store[1, 1, c, i] = np11
            else:
                mu_store[0, c, i] = mb[0, j, i]
                mu_store[1, c, i] = mb[1, j, i]
                P_store[0, 0, c, i] = p00
                P_store[0, 1, c, i] = p01
                P_store[1, 0, c, i] = pb[1, 0, j, i]
                P_store[1, 1, c, i] = p11
    for i in range(m):
        o = i - (i // n) * n
        for j in range(k):
            anc[i, cols[j]] = o
