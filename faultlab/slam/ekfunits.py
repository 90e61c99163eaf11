"""The reference units of EKF-SLAM and FastSLAM 2.0 that FastSLAM 1.0 does not have.

EKF-SLAM (:mod:`faultlab.slam.ekf`) and FastSLAM 2.0 (:mod:`faultlab.slam.fastslam2`) reuse the
FastSLAM 1.0 units of :mod:`faultlab.slam.units` wherever the mathematics is the same (motion
model, angle wraps, landmark initialisation, measurement prediction, innovation, per-landmark EKF,
resampling, ...).  This module holds the units they add.  A unit name means one signature and one
meaning in every SLAM that has it, so a fault written for a unit applies to every SLAM with that
unit.

Motion and measurement model (shared by all three SLAMs)
--------------------------------------------------------
Motion (dt = 1): drive ``v`` along the old heading, then turn by ``omega``::

    x' = x + v cos(theta),  y' = y + v sin(theta),  theta' = theta + omega

The motion is *linear in the control* for a fixed old pose: ``g(x, u + du) = g(x, u) + V du``
exactly (up to the heading wrap), with ``V`` of :func:`motion_jacobians`.  Measurement of landmark ``m``: ``z = (|m - (x, y)|,
atan2(m_y - y, m_x - x) - theta)``.

EKF-SLAM units (state ``(x, y, theta, m_1, ..., m_L)`` of dimension ``D = 3 + 2L``)
------------------------------------------------------------------------------------
=========================== ===================================================================================
unit                        signature (shapes)
=========================== ===================================================================================
motion_jacobians            ``(poses (N,3), u (N,2)) -> G (N,3,3), V (N,3,2)`` (shared with FastSLAM 2.0)
predict_covariance          ``(Sxx (3,3), Sxm (3,D-3), G (3,3), V (3,2), M (2,2)) -> Sxx, Sxm``
pose_jacobian               ``(H (...,2,2)) -> Hx (...,2,3)`` (shared with FastSLAM 2.0)
cross_covariance            ``(Sigma (D,D), idx (k,), Hx (k,2,3), Hm (k,2,2)) -> PHt (D,2k)``
joint_innovation_covariance ``(PHt (D,2k), idx (k,), Hx (k,2,3), Hm (k,2,2), Q (2,2)) -> S (2k,2k)``
kalman_update               ``(mu (D,), Sigma (D,D), PHt (D,2k), S (2k,2k), nu (2k,)) -> mu, Sigma``
augment_state               ``(mu (D,), Sigma (D,D), lm (k,2), P (k,2,2)) -> mu (D+2k,), Sigma (D+2k,D+2k)``
=========================== ===================================================================================

FastSLAM 2.0 units (``N`` particles, ``k`` observations; the proposal lives in *control space*)
------------------------------------------------------------------------------------------------
=========================== ===================================================================================
unit                        signature (shapes)
=========================== ===================================================================================
proposal_information        ``(Hx (N,k,2,3), V (N,3,2), Z (N,k,2,2), nu (N,k,2), known (N,k)) -> Lam, eta``
proposal                    ``(Lam (N,2,2), eta (N,2), M (2,2)) -> mean (N,2), cov (N,2,2)``
sample_proposal             ``(mean (N,2), cov (N,2,2), rng) -> du (N,2)``
proposal_correction         ``(Lam (N,2,2), eta (N,2), cov (N,2,2), M (2,2)) -> (N,)``
=========================== ===================================================================================

Why control space: FastSLAM 2.0 samples the pose from ``N(mu_x, Sigma_x)`` with
``Sigma_x = [Hx^T Z^-1 Hx + R^-1]^-1`` (Probabilistic Robotics, Table 13.2), where
``R = V M V^T`` is the motion noise in pose space.  Here ``R`` has rank 2 (the control has two
components), so ``R^-1`` does not exist.  Because the pose is linear in the control noise
(``pose = pose_hat + V du``), the same Gaussian is obtained exactly by sampling
``du ~ N(mean, cov)`` with ``cov = [M^-1 + Hu^T Z^-1 Hu]^-1 = (I + M Lam)^-1 M``,
``Hu = Hx V``, and driving the motion model with ``u + du``: the pose-space proposal is its
image, ``Sigma_x = V cov V^T``, ``mu_x = pose_hat + V mean``.  The form ``(I + M Lam)^-1 M``
also holds when a noise std is 0 (``M`` singular).
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import solve_triangular

__all__ = [
    "motion_jacobians",
    "predict_covariance",
    "pose_jacobian",
    "cross_covariance",
    "joint_innovation_covariance",
    "kalman_update",
    "augment_state",
    "proposal_information",
    "proposal",
    "sample_proposal",
    "proposal_correction",
]


def _component_major(shape: tuple[int, ...], tail: tuple[int, ...]) -> np.ndarray:
    """A zero-filled array of shape ``shape + tail`` stored as ``tail + shape[::-1]``.

    The layout of the FastSLAM 1.0 units' outputs (see :mod:`faultlab.slam.units`): for
    ``shape = (N, k)`` each matrix entry is one contiguous (k, N) block, so elementwise formulas
    over entries run over contiguous memory.
    """
    nd, nt = len(shape), len(tail)
    buf = np.zeros(tuple(tail) + tuple(shape)[::-1])
    return buf.transpose(tuple(range(nt + nd - 1, nt - 1, -1)) + tuple(range(nt)))


# ---------------------------------------------------------------------------------------------
# shared: Jacobians of the motion and measurement models
# ---------------------------------------------------------------------------------------------


def motion_jacobians(poses: np.ndarray, u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Jacobians of the motion model at the old poses (Probabilistic Robotics, Table 10.1, lines 3-4).

    ``G = d pose' / d pose = [[1, 0, -v sin(theta)], [0, 1, v cos(theta)], [0, 0, 1]]`` and
    ``V = d pose' / d u = [[cos(theta), 0], [sin(theta), 0], [0, 1]]``.

    Parameters
    ----------
    poses : ndarray, shape (N, 3)
        Poses before the motion.
    u : ndarray, shape (N, 2)
        Controls (v, omega).

    Returns
    -------
    G : ndarray, shape (N, 3, 3)
    V : ndarray, shape (N, 3, 2)
    """
    th = poses[:, 2]
    c, s = np.cos(th), np.sin(th)
    v = u[:, 0]
    n = poses.shape[0]
    G = np.zeros((n, 3, 3))
    G[:, 0, 0] = G[:, 1, 1] = G[:, 2, 2] = 1.0
    G[:, 0, 2] = -v * s
    G[:, 1, 2] = v * c
    V = np.zeros((n, 3, 2))
    V[:, 0, 0] = c
    V[:, 1, 0] = s
    V[:, 2, 1] = 1.0
    return G, V


def pose_jacobian(H: np.ndarray) -> np.ndarray:
    """Jacobian of the range-bearing measurement w.r.t. the pose, from the one w.r.t. the landmark.

    The measurement depends on ``(x, y)`` only through ``m - (x, y)`` and on ``theta`` only
    through ``-theta`` in the bearing, so ``Hx = [-H | (0, -1)^T]``.

    Parameters
    ----------
    H : ndarray, shape (..., 2, 2)
        Jacobian w.r.t. the landmark (from ``predict_measurement``).

    Returns
    -------
    ndarray, shape (..., 2, 3)
    """
    H = np.asarray(H, dtype=float)
    Hx = _component_major(H.shape[:-2], (2, 3))
    np.negative(H, out=Hx[..., :2])
    Hx[..., 0, 2] = 0.0
    Hx[..., 1, 2] = -1.0
    return Hx


# ---------------------------------------------------------------------------------------------
# EKF-SLAM (Probabilistic Robotics, Tables 10.1/10.2; joint correction of a step's observations)
# ---------------------------------------------------------------------------------------------


def predict_covariance(Sxx: np.ndarray, Sxm: np.ndarray, G: np.ndarray, V: np.ndarray,
                       M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """EKF-SLAM covariance prediction in sparse form (Table 10.1, line 5).

    The motion changes the pose only, so of ``G_full Sigma G_full^T + F^T R F`` only the pose
    rows change: ``Sxx' = G Sxx G^T + V M V^T`` and ``Sxm' = G Sxm`` (``Smx' = Sxm'^T``); the
    map block is unchanged.  O(L) instead of O(L^2).

    Parameters
    ----------
    Sxx : ndarray, shape (3, 3)
        Pose covariance (symmetric).
    Sxm : ndarray, shape (3, D - 3)
        Pose-map cross covariance (may have 0 columns).
    G : ndarray, shape (3, 3)
    V : ndarray, shape (3, 2)
        Motion Jacobians (:func:`motion_jacobians`).
    M : ndarray, shape (2, 2)
        Control noise covariance (zeros for an empty update).

    Returns
    -------
    Sxx : ndarray, shape (3, 3)
        Exactly symmetric.
    Sxm : ndarray, shape (3, D - 3)
        New arrays.
    """
    A = G @ Sxx @ G.T + V @ M @ V.T
    return 0.5 * (A + A.T), G @ Sxm


def _pair_columns(idx: np.ndarray) -> np.ndarray:
    """State indices ``(idx[i], idx[i] + 1)`` of each landmark, shape (k, 2)."""
    return np.asarray(idx, dtype=np.intp)[:, None] + np.arange(2)


def cross_covariance(Sigma: np.ndarray, idx: np.ndarray, Hx: np.ndarray, Hm: np.ndarray) -> np.ndarray:
    """``Sigma H^T`` for the stacked measurement Jacobian of a step's re-observed landmarks.

    Row pair ``i`` of ``H`` (2k, D) is nonzero only in the pose columns 0:3 (``Hx[i]``) and the
    columns ``idx[i]:idx[i]+2`` of landmark ``i`` (``Hm[i]``), so
    ``PHt[:, 2i:2i+2] = Sigma[:, 0:3] Hx[i]^T + Sigma[:, idx[i]:idx[i]+2] Hm[i]^T``: O(D k).

    Parameters
    ----------
    Sigma : ndarray, shape (D, D)
        State covariance.
    idx : ndarray of int, shape (k,)
        State index of each landmark's x coordinate (``3 + 2 * column``).
    Hx : ndarray, shape (k, 2, 3)
        Measurement Jacobians w.r.t. the pose.
    Hm : ndarray, shape (k, 2, 2)
        Measurement Jacobians w.r.t. the landmarks.

    Returns
    -------
    ndarray, shape (D, 2k)
    """
    D = Sigma.shape[0]
    k = Hx.shape[0]
    out = Sigma[:, :3] @ Hx.reshape(2 * k, 3).T
    cols = Sigma[:, _pair_columns(idx)]  # (D, k, 2)
    out += np.einsum("dkj,kij->dki", cols, Hm).reshape(D, 2 * k)
    return out


def joint_innovation_covariance(PHt: np.ndarray, idx: np.ndarray, Hx: np.ndarray, Hm: np.ndarray,
                                Q: np.ndarray) -> np.ndarray:
    """``S = H Sigma H^T + diag(Q, ..., Q)`` of the stacked measurement, from ``PHt = Sigma H^T``.

    Uses the sparsity of ``H``: ``(H PHt)[2i:2i+2] = Hx[i] PHt[0:3] + Hm[i] PHt[idx[i]:idx[i]+2]``.

    Parameters
    ----------
    PHt : ndarray, shape (D, 2k)
        :func:`cross_covariance`.
    idx : ndarray of int, shape (k,)
    Hx : ndarray, shape (k, 2, 3)
    Hm : ndarray, shape (k, 2, 2)
    Q : ndarray, shape (2, 2)
        Measurement noise covariance of one observation.

    Returns
    -------
    ndarray, shape (2k, 2k)
        Exactly symmetric.
    """
    k = Hx.shape[0]
    S = Hx.reshape(2 * k, 3) @ PHt[:3]
    rows = PHt[_pair_columns(idx)]  # (k, 2, 2k)
    S += np.einsum("kij,kjc->kic", Hm, rows).reshape(2 * k, 2 * k)
    S = 0.5 * (S + S.T)
    blocks = S.reshape(k, 2, k, 2)
    d = np.arange(k)
    blocks[d, :, d, :] += Q
    return S


def kalman_update(mu: np.ndarray, Sigma: np.ndarray, PHt: np.ndarray, S: np.ndarray,
                  nu: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Joint EKF correction (Table 10.1, lines 17-19, for all of a step's observations at once).

    ``K = PHt S^-1``, ``mu' = mu + K nu``, ``Sigma' = (I - K H) Sigma = Sigma - K PHt^T``.
    Evaluated with the Cholesky factor ``S = L L^T``: ``W = PHt L^-T``,
    ``mu' = mu + W (L^-1 nu)``, ``Sigma' = Sigma - W W^T`` (exactly symmetric, O(D^2 k)).

    Parameters
    ----------
    mu : ndarray, shape (D,)
    Sigma : ndarray, shape (D, D)
    PHt : ndarray, shape (D, 2k)
    S : ndarray, shape (2k, 2k)
        Symmetric positive definite (``numpy.linalg.LinAlgError`` otherwise).
    nu : ndarray, shape (2k,)
        Stacked innovations (range, bearing, range, bearing, ...).

    Returns
    -------
    mu : ndarray, shape (D,)
    Sigma : ndarray, shape (D, D)
        New arrays.
    """
    L = np.linalg.cholesky(S)
    W = solve_triangular(L, PHt.T, lower=True, check_finite=False).T
    a = solve_triangular(L, nu, lower=True, check_finite=False)
    return mu + W @ a, Sigma - W @ W.T


def augment_state(mu: np.ndarray, Sigma: np.ndarray, lm: np.ndarray,
                  P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Append landmarks initialised by the inverse measurement model to the EKF state.

    A new landmark is ``m = (x, y) + r (cos a, sin a)``, ``a = theta + bearing`` (computed by
    ``init_landmarks``), a function of the pose and the measurement.  Its Jacobian w.r.t. the
    pose is ``Gx = [[1, 0, -(m_y - y)], [0, 1, m_x - x]]``; ``P = Gz Q Gz^T`` is the part due to
    the measurement.  With ``A`` the (2k, 3) stack of the ``Gx``:
    ``Sigma_new,old = A Sigma[0:3, :]`` and ``Sigma_new,new = A Sigma_xx A^T + diag(P_1, ..., P_k)``.

    Parameters
    ----------
    mu : ndarray, shape (D,)
        State mean; ``mu[0:3]`` is the pose the landmarks were initialised from.
    Sigma : ndarray, shape (D, D)
    lm : ndarray, shape (k, 2)
        New landmark means.
    P : ndarray, shape (k, 2, 2)
        Their covariances given the pose.

    Returns
    -------
    mu : ndarray, shape (D + 2k,)
    Sigma : ndarray, shape (D + 2k, D + 2k)
        New arrays; the new diagonal block is exactly symmetric.
    """
    D = mu.shape[0]
    k = lm.shape[0]
    A = np.zeros((k, 2, 3))
    A[:, 0, 0] = A[:, 1, 1] = 1.0
    A[:, 0, 2] = -(lm[:, 1] - mu[1])
    A[:, 1, 2] = lm[:, 0] - mu[0]
    A = A.reshape(2 * k, 3)
    cross = A @ Sigma[:3]  # (2k, D)
    new = cross[:, :3] @ A.T
    new = 0.5 * (new + new.T)
    blocks = new.reshape(k, 2, k, 2)
    d = np.arange(k)
    blocks[d, :, d, :] += P
    out = np.zeros((D + 2 * k, D + 2 * k))
    out[:D, :D] = Sigma
    out[D:, :D] = cross
    out[:D, D:] = cross.T
    out[D:, D:] = new
    return np.concatenate([mu, lm.reshape(-1)]), out


# ---------------------------------------------------------------------------------------------
# FastSLAM 2.0: the proposal of Probabilistic Robotics Table 13.2 / Montemerlo et al. (2003)
# ---------------------------------------------------------------------------------------------


def proposal_information(Hx: np.ndarray, V: np.ndarray, Z: np.ndarray, nu: np.ndarray,
                         known: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """What a step's observations of known landmarks say about the control noise.

    With ``Hu = Hx V`` (measurement Jacobian w.r.t. the control) per (particle, observation):
    ``Lam = sum_j Hu_j^T Z_j^-1 Hu_j`` and ``eta = sum_j Hu_j^T Z_j^-1 nu_j`` over the known pairs
    (the observations are conditionally independent given the pose, so their information adds).

    Parameters
    ----------
    Hx : ndarray, shape (N, k, 2, 3)
        Measurement Jacobians w.r.t. the pose, at the predicted pose.
    V : ndarray, shape (N, 3, 2)
        Motion Jacobians w.r.t. the control (:func:`motion_jacobians`).
    Z : ndarray, shape (N, k, 2, 2)
        Innovation covariances ``Hm P Hm^T + Q`` (symmetric positive definite where known).
    nu : ndarray, shape (N, k, 2)
        Innovations at the predicted pose.
    known : ndarray of bool, shape (N, k)
        Pairs that update a known landmark (the others contribute nothing).

    Returns
    -------
    Lam : ndarray, shape (N, 2, 2)
        Symmetric.
    eta : ndarray, shape (N, 2)
    """
    known = np.asarray(known, dtype=bool)
    # Hu = Hx V, entry by entry (V is per particle: broadcast over the observations)
    Vb = [[V[:, None, j, c] for c in range(2)] for j in range(3)]
    h00, h01, h10, h11 = ((Hx[..., a, 0] * Vb[0][c] + Hx[..., a, 1] * Vb[1][c] + Hx[..., a, 2] * Vb[2][c])
                          for a, c in ((0, 0), (0, 1), (1, 0), (1, 1)))
    z00, z01, z11 = Z[..., 0, 0], Z[..., 0, 1], Z[..., 1, 1]
    inv_det = np.where(known, z00 * z11 - z01 * z01, 1.0)
    np.divide(1.0, inv_det, out=inv_det)
    # A = Z^-1 Hu, with Z^-1 = [[z11, -z01], [-z01, z00]] / det
    a00 = (z11 * h00 - z01 * h10) * inv_det
    a10 = (z00 * h10 - z01 * h00) * inv_det
    a01 = (z11 * h01 - z01 * h11) * inv_det
    a11 = (z00 * h11 - z01 * h01) * inv_det
    n0, n1 = nu[..., 0], nu[..., 1]

    def total(x):
        return np.where(known, x, 0.0).sum(axis=1)

    lam = np.zeros(Hx.shape[:1] + (2, 2))
    lam[:, 0, 0] = total(h00 * a00 + h10 * a10)
    lam[:, 0, 1] = lam[:, 1, 0] = total(h00 * a01 + h10 * a11)
    lam[:, 1, 1] = total(h01 * a01 + h11 * a11)
    eta = np.zeros(Hx.shape[:1] + (2,))
    eta[:, 0] = total(a00 * n0 + a10 * n1)
    eta[:, 1] = total(a01 * n0 + a11 * n1)
    return lam, eta


def _det2(A: np.ndarray) -> np.ndarray:
    return A[..., 0, 0] * A[..., 1, 1] - A[..., 0, 1] * A[..., 1, 0]


def proposal(Lam: np.ndarray, eta: np.ndarray, M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The Gaussian proposal over the control noise (Table 13.2, lines 13-15, in control space).

    ``cov = (I + M Lam)^-1 M`` (``= [M^-1 + Lam]^-1`` for invertible ``M``) and
    ``mean = cov eta``.  Without known landmarks (``Lam = 0``, ``eta = 0``) this is the motion
    noise ``N(0, M)`` of FastSLAM 1.0.

    Parameters
    ----------
    Lam : ndarray, shape (N, 2, 2)
        Symmetric positive semi-definite (:func:`proposal_information`).
    eta : ndarray, shape (N, 2)
    M : ndarray, shape (2, 2)
        Control noise covariance diag(std_v^2, std_omega^2).

    Returns
    -------
    mean : ndarray, shape (N, 2)
    cov : ndarray, shape (N, 2, 2)
        Exactly symmetric.
    """
    A = np.eye(2) + M @ Lam  # (N, 2, 2)
    a00, a01, a10, a11 = A[:, 0, 0], A[:, 0, 1], A[:, 1, 0], A[:, 1, 1]
    inv_det = 1.0 / (a00 * a11 - a01 * a10)
    # A^-1 M with A^-1 = [[a11, -a01], [-a10, a00]] / det; the two off-diagonal entries agree
    # mathematically and are averaged so that cov is exactly symmetric
    cov = np.zeros_like(A)
    cov[:, 0, 0] = (a11 * M[0, 0] - a01 * M[1, 0]) * inv_det
    cov[:, 1, 1] = (a00 * M[1, 1] - a10 * M[0, 1]) * inv_det
    c01 = (a11 * M[0, 1] - a01 * M[1, 1]) * inv_det
    c10 = (a00 * M[1, 0] - a10 * M[0, 0]) * inv_det
    cov[:, 0, 1] = cov[:, 1, 0] = 0.5 * (c01 + c10)
    mean = np.einsum("nij,nj->ni", cov, eta)
    return mean, cov


def sample_proposal(mean: np.ndarray, cov: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Draw one control-noise sample per particle from the proposal (Table 13.2, line 16).

    ``du = mean + L eps`` with ``eps = rng.standard_normal((N, 2))`` and ``L`` the lower Cholesky
    factor of ``cov`` (``L L^T = cov``; a zero pivot of a singular ``cov`` gives a zero column).
    With ``mean = 0`` and ``cov = M`` the draw equals FastSLAM 1.0's ``sample_controls`` noise.

    Parameters
    ----------
    mean : ndarray, shape (N, 2)
    cov : ndarray, shape (N, 2, 2)
        Symmetric positive semi-definite.
    rng : numpy.random.Generator
        Consumed as exactly one call ``rng.standard_normal((N, 2))``.

    Returns
    -------
    ndarray, shape (N, 2)
    """
    eps = rng.standard_normal(mean.shape)
    c00, c01, c11 = cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 1]
    l00 = np.sqrt(np.maximum(c00, 0.0))
    l10 = np.divide(c01, l00, out=np.zeros_like(c01), where=l00 > 0)
    l11 = np.sqrt(np.maximum(c11 - l10 * l10, 0.0))
    du = np.zeros_like(mean)
    du[:, 0] = mean[:, 0] + l00 * eps[:, 0]
    du[:, 1] = mean[:, 1] + l10 * eps[:, 0] + l11 * eps[:, 1]
    return du


_LOG_TWO_PI = math.log(2.0 * math.pi)


def proposal_correction(Lam: np.ndarray, eta: np.ndarray, cov: np.ndarray, M: np.ndarray) -> np.ndarray:
    """Log importance-weight term of the proposal beyond the per-landmark likelihoods.

    The FastSLAM 2.0 weight is the proposal's normaliser, the joint likelihood of the step's
    known-landmark innovations ``nu`` (2m,) with the pose uncertainty of the motion included:
    ``N(nu; 0, Hu M Hu^T + diag(Z_1, ..., Z_m))`` (Table 13.2, lines 21-22, for all observations
    jointly).  By the matrix determinant lemma and the Woodbury identity its log equals
    ``sum_j log N(nu_j; 0, Z_j)`` (``log_likelihood``) plus this correction::

        0.5 eta^T cov eta - 0.5 log det(I + M Lam)

    Parameters
    ----------
    Lam : ndarray, shape (N, 2, 2)
    eta : ndarray, shape (N, 2)
    cov : ndarray, shape (N, 2, 2)
        :func:`proposal` covariance.
    M : ndarray, shape (2, 2)

    Returns
    -------
    ndarray, shape (N,)
        0 where ``Lam = 0`` and ``eta = 0``.
    """
    quad = np.einsum("ni,nij,nj->n", eta, cov, eta)
    return 0.5 * quad - 0.5 * np.log(_det2(np.eye(2) + M @ Lam))
