"""FastSLAM 2.0 with known correspondences, structured for fault injection like FastSLAM 1.0.

FastSLAM 2.0 (Montemerlo, Thrun, Koller & Wegbreit, IJCAI 2003; Thrun, Burgard & Fox,
*Probabilistic Robotics*, Sec. 13.4 and Table 13.2) differs from FastSLAM 1.0
(:class:`faultlab.slam.FastSlam`) in the prediction: each particle's new pose is sampled from a
proposal that incorporates the step's observations of landmarks the particle already knows, not
from the motion model alone, and the importance weight is that proposal's normaliser (the
likelihood of the observations with the pose uncertainty of the motion included).  Landmarks are
initialised and updated exactly as in FastSLAM 1.0, from the sampled pose.  Settings
(:class:`faultlab.slam.FastSlamConfig`), storage (:class:`faultlab.slam.ParticleState`, copy-on-write
landmark storage), resampling, the estimate (the highest-weight particle) and the conventions are
FastSLAM 1.0's: drive ``v`` along the heading, then turn ``omega``; an *empty update* (control
exactly (0, 0) and no observation) samples no control noise and never resamples.

One update (:meth:`FastSlam2.update`) runs, for all ``N`` particles and ``k`` observations at once::

    x_hat = motion_model(x, u, wrap=wrap_heading)                 # noise-free prediction
    # if the step has observations z (k, 2); mu, P: the particles' stored landmarks
    new   = classify_new(seen, mu)
    mu, P = init_landmarks(x_hat, z, Q, wrap=wrap_bearing) where new   # keeps the arithmetic finite
    z_hat, H = predict_measurement(x_hat, mu)
    nu    = innovation(z, z_hat, wrap=wrap_bearing)
    Z     = innovation_covariance(H, P, Q)                         # H P H^T + Q
    ll    = log_likelihood(nu, Z)
    G, V  = motion_jacobians(x, u)
    Lam, eta = proposal_information(pose_jacobian(H), V, Z, nu, ~new)
    # always (Lam = 0, eta = 0 without observations) except in an empty update:
    mean, cov = proposal(Lam, eta, M)                              # over the control noise
    du    = sample_proposal(mean, cov, rng['sample_proposal'])
    x     = motion_model(x, u + du, wrap=wrap_heading)             # the sampled pose
    # with observations:
    logw  = combine_weights(logw, ll, ~new) + proposal_correction(Lam, eta, cov, M)   # normalised
    mu0, P0 = init_landmarks(x, z, Q, wrap=wrap_bearing)           # the new pairs
    z_hat, H = predict_measurement(x, mu); nu = innovation(...); Z = innovation_covariance(H, P, Q)
    mu, P = ekf_update(mu, P, H, Z, nu), but mu0, P0 where new     -> written back to storage
    # always:
    n_eff = effective_sample_size(exp(logw))
    idx   = resample(exp(logw), n_eff, empty, rng['resample'], config)
    state = apply_resample(state, idx) if idx is not None

Variant: the proposal is computed in control space (the pose is linear in the control noise, so
this is Table 13.2's pose-space Gaussian exactly, and it stays defined although the motion noise
has rank 2; see :mod:`faultlab.slam.ekfunits`), and a step's observations of known landmarks enter
it *jointly*, linearised at the noise-free prediction, with the joint likelihood as the weight
(Montemerlo's sequential variant re-linearises after each observation).  Without known landmarks
the proposal is FastSLAM 1.0's motion noise, draw for draw.

Randomness: ``reset`` derives one stream per randomness-consuming unit (``sample_proposal``,
``resample``) with :func:`faultlab.slam.streams.unit_streams`, so a fault in one unit never
changes the draws of the other.

Units: the fields of :class:`FastSlam2Steps`; those shared with FastSLAM 1.0 are documented in
:mod:`faultlab.slam.units`, the others in :mod:`faultlab.slam.ekfunits`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from faultlab.slam import particles as _particles
from faultlab.slam import units as _units
from faultlab.slam import ekfunits as _ekfunits
from faultlab.slam.bookkeeping import (LandmarkIndex, ParticleFilterSlam, UnitTable, grown_capacity, linearise,
                                       normalise_log_weights, sample_pose)
from faultlab.slam.fastslam import FastSlamConfig, Particles, materialise_particles
from faultlab.slam.protocol import Observations
from faultlab.slam.particles import ParticleState

__all__ = ["FastSlam2Steps", "REFERENCE_STEPS", "RANDOM_UNITS", "FastSlam2"]


@dataclass(frozen=True)
class FastSlam2Steps(UnitTable):
    """The replaceable units of FastSLAM 2.0 (see the module docstring for the call order).

    Replace one unit with ``dataclasses.replace(steps, unit=new_function)``.
    """

    motion_model: Callable = _units.motion_model
    wrap_heading: Callable = _units.wrap_heading
    wrap_bearing: Callable = _units.wrap_bearing
    motion_jacobians: Callable = _ekfunits.motion_jacobians
    classify_new: Callable = _units.classify_new
    init_landmarks: Callable = _units.init_landmarks
    predict_measurement: Callable = _units.predict_measurement
    pose_jacobian: Callable = _ekfunits.pose_jacobian
    innovation: Callable = _units.innovation
    innovation_covariance: Callable = _units.innovation_covariance
    log_likelihood: Callable = _units.log_likelihood
    proposal_information: Callable = _ekfunits.proposal_information
    proposal: Callable = _ekfunits.proposal
    sample_proposal: Callable = _ekfunits.sample_proposal
    combine_weights: Callable = _units.combine_weights
    proposal_correction: Callable = _ekfunits.proposal_correction
    ekf_update: Callable = _units.ekf_update
    effective_sample_size: Callable = _units.effective_sample_size
    resample: Callable = _units.resample
    apply_resample: Callable = _units.apply_resample
    extract_map: Callable = _units.extract_map


#: The reference FastSLAM 2.0 units.
REFERENCE_STEPS = FastSlam2Steps()

#: The units that draw random numbers; each gets its own stream (common random numbers by unit).
RANDOM_UNITS: tuple[str, ...] = ("sample_proposal", "resample")


class FastSlam2(ParticleFilterSlam):
    """FastSLAM 2.0 (known correspondences) as a :class:`SlamAdapter`.

    Parameters
    ----------
    config : FastSlamConfig
        The same settings as FastSLAM 1.0 (particles, noise, resampling threshold).
    steps : FastSlam2Steps
        The units; :data:`REFERENCE_STEPS` or a copy with one unit replaced (a fault).
    """

    name = "fastslam2"
    config_type = FastSlamConfig
    steps_type = FastSlam2Steps
    reference_steps = REFERENCE_STEPS
    random_units = RANDOM_UNITS
    map_unit = "extract_map"
    apply_unit = "apply_resample"

    def __init__(self, config: FastSlamConfig | None = None, *, steps: FastSlam2Steps | None = None):
        super().__init__(config, steps=steps)
        self._Q = self._config.Q
        self._M = np.diag([self._config.std_v ** 2, self._config.std_omega ** 2])

    # -- SlamAdapter -----------------------------------------------------------------------------

    def reset(self, pose: np.ndarray, *, rng: np.random.Generator) -> None:
        p = self._start_pose(pose, rng)
        self._begin(ParticleState.initial(p, self._config.particles), rng)
        self._ident = self._state.owner  # arange(N); lineage starts as this very object
        self._index = LandmarkIndex()

    def update(self, control: np.ndarray, observations: Observations) -> None:
        st, _, u_n, k, empty = self._begin_step(control, observations)
        steps, Q, M = self._run_steps, self._Q, self._M
        n = st.n_particles
        logw = st.logw
        if empty:
            poses = steps.motion_model(st.poses, u_n, wrap=steps.wrap_heading)
        else:
            if k:
                st, cols, seen = self._columns(st, observations.ids)
                z = np.column_stack([observations.ranges, observations.bearings])
                st, mu, P = self._gather(st, cols)
                new = np.asarray(steps.classify_new(seen, mu), dtype=bool)
                known = ~new
                # the proposal, linearised at the noise-free prediction (Table 13.2, lines 4-15)
                x_hat = np.asarray(steps.motion_model(st.poses, u_n, wrap=steps.wrap_heading), dtype=float)
                mu_p, P_p = self._initialise_new(mu, P, new, x_hat, z)
                H, nu, Z = linearise(steps, x_hat, mu_p, P_p, z, Q)
                loglik = steps.log_likelihood(nu, Z)
                _, V = steps.motion_jacobians(st.poses, u_n)
                lam, eta = steps.proposal_information(steps.pose_jacobian(H), V, Z, nu, known)
            else:
                lam, eta = np.zeros((n, 2, 2)), np.zeros((n, 2))
            poses, cov = sample_pose(steps, st.poses, u_n, lam, eta, M, self._streams["sample_proposal"])
            if k:
                # importance weight: the proposal's normaliser (Table 13.2, lines 21-22)
                logw = np.asarray(steps.combine_weights(st.logw, loglik, known), dtype=float)
                logw = logw + np.asarray(steps.proposal_correction(lam, eta, cov, M), dtype=float)
                logw = normalise_log_weights(logw, name=self.name, step=self._t)
                # landmarks from the sampled pose, as in FastSLAM 1.0 (Table 13.2, lines 17-20)
                mu_s, P_s = self._initialise_new(mu, P, new, poses, z)
                H, nu, Z = linearise(steps, poses, mu_s, P_s, z, Q)
                mu_new, P_new = steps.ekf_update(mu_s, P_s, H, Z, nu)
                mu_new, P_new = np.asarray(mu_new, dtype=float), np.asarray(P_new, dtype=float)
                if new.any():  # new pairs keep their initial values
                    mu_new, P_new = np.copy(mu_new, order="K"), np.copy(P_new, order="K")
                    mu_new[new], P_new[new] = mu_s[new], P_s[new]
                self._write(st, cols, mu_new, P_new)
        self._finish(st, poses, logw, empty)

    # -- diagnostics -----------------------------------------------------------------------------

    def particles(self) -> Particles:
        """A materialised copy of all particles (means and covariances in column order)."""
        return materialise_particles(self._require_state())

    # -- internals -------------------------------------------------------------------------------

    def _columns(self, st: ParticleState, ids: np.ndarray) -> tuple[ParticleState, np.ndarray, np.ndarray]:
        """Storage columns of ``ids`` (k,), adding columns for unseen ids; returns (state, cols, seen)."""
        cols, seen = self._index.lookup(ids)
        if not seen.all():
            new_ids = ids[~seen]
            cols = cols.copy()
            cols[~seen] = self._index.add(new_ids)
            st = self._grow(st, len(self._index)).replace(ids=np.concatenate([st.ids, new_ids]))
        return st, cols, seen

    @staticmethod
    def _grow(st: ParticleState, needed: int) -> ParticleState:
        """``st`` with landmark storage for at least ``needed`` columns (capacity doubles)."""
        new_cap = grown_capacity(st.mu.shape[1], needed)
        if new_cap is None:
            return st
        n, C = st.n_particles, st.n_landmarks
        mu, P = _particles.empty_means(n, new_cap), _particles.empty_covariances(n, new_cap)
        anc = _particles.initial_ancestry(n, new_cap)
        mu[:, :C], P[:, :C], anc[:, :C] = st.mu[:, :C], st.P[:, :C], st.anc[:, :C]
        return st.replace(mu=mu, P=P, anc=anc)

    def _gather(self, st: ParticleState, cols: np.ndarray) -> tuple[ParticleState, np.ndarray, np.ndarray]:
        """The state and the particles' means (N, k, 2) and covariances (N, k, 2, 2) of ``cols`` (copies).

        First applies any pending resampling to the ancestry (``anc = anc[lineage]``), so that
        particle ``i`` reads and later rewrites ancestry row ``i``.  With the reference storage
        layout (component-major, particle-fastest: :func:`faultlab.slam.particles.empty_means`) the
        gather reads contiguous runs and returns views of (2, k, N) / (2, 2, k, N) buffers, the
        layout of the reference units' outputs; any other layout is gathered element by element.
        """
        if st.lineage is not self._ident:
            C = st.n_landmarks
            st.anc[:, :C] = st.anc[st.lineage, :C]
            st = st.replace(lineage=self._ident)
        rows = st.anc[:, cols]  # (N, k)
        n, cap = st.mu.shape[:2]
        mb, pb = st.mu.transpose(2, 1, 0), st.P.transpose(2, 3, 1, 0)
        if mb.flags.c_contiguous and pb.flags.c_contiguous:
            flat = rows.T + (cols * n)[:, None]  # (k, N) positions in a component's (cap * N) block
            k = cols.size
            mu = np.take(mb.reshape(2, cap * n), flat, axis=1)  # (2, k, N)
            P = np.take(pb.reshape(4, cap * n), flat, axis=1).reshape(2, 2, k, n)
            return st, mu.transpose(2, 1, 0), P.transpose(3, 2, 0, 1)
        return st, st.mu[rows, cols[None, :]], st.P[rows, cols[None, :]]

    def _write(self, st: ParticleState, cols: np.ndarray, mu: np.ndarray, P: np.ndarray) -> None:
        """Every particle ``i`` writes its estimates of ``cols`` into its storage row ``owner[i]``."""
        owner = st.owner
        n, cap = st.mu.shape[:2]
        k = cols.size
        mb, pb = st.mu.transpose(2, 1, 0), st.P.transpose(2, 3, 1, 0)
        if (mb.flags.c_contiguous and pb.flags.c_contiguous
                and (owner is self._ident or np.array_equal(owner, self._ident))):
            # particle i owns row i: whole (component, column) rows of N values are copied
            rows = cols + (cap * np.arange(4))[:, None]  # (4, k) rows of the (4 cap, N) view
            mb.reshape(2 * cap, n)[rows[:2].ravel()] = mu.transpose(2, 1, 0).reshape(2 * k, n)
            pb.reshape(4 * cap, n)[rows.ravel()] = P.transpose(2, 3, 1, 0).reshape(4 * k, n)
        else:
            st.mu[owner[:, None], cols[None, :]] = mu
            st.P[owner[:, None], cols[None, :]] = P
        st.anc[:, cols] = owner[:, None]

    def _initialise_new(self, mu: np.ndarray, P: np.ndarray, new: np.ndarray, poses: np.ndarray,
                        z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``mu``, ``P`` with the new pairs set to ``init_landmarks`` from ``poses``."""
        if not new.any():
            return mu, P
        steps = self._run_steps
        c = np.flatnonzero(new.any(axis=0))
        mu0, P0 = steps.init_landmarks(poses, z[c], self._Q, wrap=steps.wrap_bearing)
        mu, P = np.copy(mu, order="K"), np.copy(P, order="K")
        m = new[:, c]
        mu[:, c] = np.where(m[..., None], np.asarray(mu0, dtype=float), mu[:, c])
        P[:, c] = np.where(m[..., None, None], np.asarray(P0, dtype=float), P[:, c])
        return mu, P
