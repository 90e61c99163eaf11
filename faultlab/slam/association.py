"""FastSLAM 1.0 and 2.0 with unknown data association, structured for fault injection.

The observations carry no landmark ids (the driver hides them: :mod:`faultlab.slam.protocol`,
"Data association"); every particle associates each observation itself by maximum likelihood
over its own landmarks and starts a new landmark when even the best one explains the observation
less well than the new-landmark likelihood ``p0`` (Montemerlo, Thrun, Koller & Wegbreit, FastSLAM,
AAAI 2002 and IJCAI 2003; Thrun, Burgard & Fox, *Probabilistic Robotics*, Sec. 13.6 and
Table 13.3).  Built by name with ``association = "unknown"`` in the ``[slam]`` table of ``fastslam``
or ``fastslam2`` (:mod:`faultlab.slam.registry`); the settings are
:class:`~faultlab.slam.FastSlamConfig`'s, with ``new_landmark_sigmas`` giving ``p0``
(:func:`~faultlab.slam.associationunits.new_landmark_log_likelihood`).

Association, for all ``N`` particles, ``k`` observations and the ``L`` landmark slots at once::

    z_hat, H = predict_measurement(x, mu)                      # (N, L, ...) every particle's landmarks
    S        = innovation_covariance(H, P, Q)                  # (N, L, 2, 2)
    nu       = innovation(z repeated, z_hat repeated, wrap=wrap_bearing)   # (N, k L, 2)
    ll       = log_likelihood(nu, S repeated)                  # (N, k L) -> (N, k, L)
    assoc    = associate(ll, valid, log_p0)                    # (N, k): slot or NEW_LANDMARK

Only the landmarks whose predicted range is within ``new_landmark_sigmas`` standard deviations of
an observed range take part (the others cannot beat ``p0``: an exact gate, see
:meth:`_UnknownAssociationSlam._candidates`), so L above is the number of candidates.
The per-particle maps differ in size, so they are stored padded (:class:`~faultlab.slam.associationunits.AssociationState`:
(N, cap) slots and the number of landmarks of each particle); padding slots take a placeholder
landmark 1 m ahead of the particle (finite arithmetic) and are masked out by ``associate``.  The
work is O(N k L) per step: meant for the small and medium maps of Table I.

FastSLAM 1.0 (:class:`FastSlamUnknown`) then runs, per step::

    u_i   = sample_controls(u, N, rng_sc, config)              # skipped for an empty update
    x     = motion_model(x, u_i, wrap=wrap_heading)
    assoc = the association above, at x
    logw  = combine_weights(logw, ll of assoc or log_p0 where new, all True)   # normalised
    mu, P = ekf_update(...) of the associated landmarks; init_landmarks(x, z) appended where new
    n_eff, idx = effective_sample_size(w), resample(w, n_eff, empty, rng_rs, config)
    state = resample_maps(state, idx) if idx is not None

FastSLAM 2.0 (:class:`FastSlam2Unknown`) associates at the noise-free prediction, draws the pose
from the proposal built from the associated landmarks (the known-association units of
:mod:`faultlab.slam.ekfunits`, with ``known`` = associated), weights by the proposal's normaliser
with ``log_p0`` for the new landmarks, and updates and creates landmarks from the sampled pose.
Variant: Table 13.3 computes one proposal per candidate landmark of one observation; here, as
in the known-association filter, the associated observations of a step enter one joint proposal.

The estimate is the highest-weight particle's map, labelled ``0 .. M - 1`` in order of creation
(:func:`~faultlab.slam.associationunits.extract_unlabelled_map`); it is scored by the earth mover's distance.
Randomness: one stream per random unit (``sample_controls`` or ``sample_proposal``, and
``resample``), as in the known-association filters.  Repetitions run one at a time
(``supports_batch = False``): the batched storage of :class:`~faultlab.slam.FastSlam` relies on
landmark columns that align across repetitions, which per-particle maps do not.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, make_dataclass
from typing import Callable, ClassVar

import numpy as np

from faultlab.slam import associationunits as _associationunits
from faultlab.slam import contract as _contract
from faultlab.slam import units as _units
from faultlab.slam.bookkeeping import (ParticleFilterSlam, UnitTable, grown_capacity, linearise, normalise_log_weights,
                                       sample_pose)
from faultlab.slam.fastslam import FastSlamConfig, FastSlamSteps
from faultlab.slam.fastslam2 import RANDOM_UNITS, FastSlam2Steps
from faultlab.slam.protocol import Observations
from faultlab.slam.associationunits import NEW_LANDMARK, AssociationState
from faultlab.vocabulary import UNKNOWN_ASSOCIATION

__all__ = ["FastSlamUnknownSteps", "FastSlam2UnknownSteps", "REFERENCE_STEPS", "REFERENCE_STEPS_2",
           "FastSlamUnknown", "FastSlam2Unknown"]


def _without_ids(known: type, name: str) -> type:
    """The units of the unknown-association variant of the steps table ``known``, as a new table ``name``.

    They are ``known``'s, in its order, except the three that need landmark ids: ``classify_new``
    goes (the association decides what is new), ``associate`` comes after ``log_likelihood``, and
    ``apply_resample`` and ``extract_map`` (the id-aligned :class:`~faultlab.slam.particles.ParticleState`)
    become ``resample_maps`` and ``extract_unlabelled_map`` (:class:`~faultlab.slam.associationunits.AssociationState`).
    """
    units = []
    for f in fields(known):
        if f.name == "classify_new":
            continue
        unit = _ID_UNITS.get(f.name, (f.name, f.default))
        units.append((unit[0], Callable, field(default=unit[1])))
        if f.name == "log_likelihood":
            units.append(("associate", Callable, field(default=_associationunits.associate)))
    doc = (f"The replaceable units of {known.__name__} with unknown data association: the same units without "
           f"``classify_new``, with ``associate``, ``resample_maps`` and ``extract_unlabelled_map`` (call order: "
           f"the module docstring).")
    return make_dataclass(name, units, bases=(UnitTable,), frozen=True, namespace={"__doc__": doc,
                                                                                  "__module__": __name__})


#: The units of the known-association tables that the unknown-association ones replace.
_ID_UNITS = {"apply_resample": ("resample_maps", _associationunits.resample_maps),
             "extract_map": ("extract_unlabelled_map", _associationunits.extract_unlabelled_map)}

#: The units of FastSLAM 1.0 with unknown data association.
FastSlamUnknownSteps = _without_ids(FastSlamSteps, "FastSlamUnknownSteps")
#: The units of FastSLAM 2.0 with unknown data association.
FastSlam2UnknownSteps = _without_ids(FastSlam2Steps, "FastSlam2UnknownSteps")


#: The reference units of :class:`FastSlamUnknown` and :class:`FastSlam2Unknown`.
REFERENCE_STEPS = FastSlamUnknownSteps()
REFERENCE_STEPS_2 = FastSlam2UnknownSteps()


@dataclass(frozen=True, eq=False)
class Association:
    """One step's association and the quantities of the associated pairs (all (N, k, ...)).

    ``assoc`` is the slot or :data:`~faultlab.slam.associationunits.NEW_LANDMARK`; the other arrays hold, for
    an associated pair, its landmark's mean, covariance, predicted measurement Jacobian,
    innovation covariance, innovation and log likelihood (for a new pair: those of slot 0 or of
    the placeholder 1 m ahead of the particle, meaningless and masked by the caller).
    """

    assoc: np.ndarray
    mu: np.ndarray
    P: np.ndarray
    H: np.ndarray
    S: np.ndarray
    nu: np.ndarray
    loglik: np.ndarray

    @property
    def known(self) -> np.ndarray:
        """Pairs associated with an existing landmark, (N, k) bool."""
        return self.assoc != NEW_LANDMARK


class _UnknownAssociationSlam(ParticleFilterSlam):
    """What both unknown-association filters share: storage, association, map update, resampling."""

    association: ClassVar[str] = UNKNOWN_ASSOCIATION
    supports_batch: ClassVar[bool] = False
    config_type = FastSlamConfig
    map_unit = "extract_unlabelled_map"
    apply_unit = "resample_maps"

    def __init__(self, config: FastSlamConfig | None = None, *, steps=None):
        if config is None:
            config = FastSlamConfig(association=UNKNOWN_ASSOCIATION)
        super().__init__(config, steps=steps)
        self._Q = self._config.Q
        self._log_p0 = self._config.log_p0

    def reset(self, pose: np.ndarray, *, rng: np.random.Generator) -> None:
        self._begin(AssociationState.initial(self._start_pose(pose, rng), self._config.particles), rng)

    def _associate(self, poses: np.ndarray, z: np.ndarray) -> Association:
        """Every particle's maximum-likelihood association of the observations ``z`` (k, 2) from ``poses``.

        A landmark on top of a particle gives non-finite likelihoods, which ``associate`` never picks.
        """
        with np.errstate(invalid="ignore", divide="ignore"):
            return self._associate_pairs(poses, z)

    def _associate_pairs(self, poses: np.ndarray, z: np.ndarray) -> Association:
        steps, st, Q = self._run_steps, self._state, self._Q
        n, k = poses.shape[0], z.shape[0]
        L = max(1, int(st.size.max()))  # slot 0 is padding while no particle has a landmark
        valid = st.valid[:, :L]
        # padding slots: a placeholder landmark 1 m ahead of the particle keeps the arithmetic finite
        ahead = poses[:, None, :2] + np.stack([np.cos(poses[:, 2]), np.sin(poses[:, 2])], axis=1)[:, None, :]
        mu = np.where(valid[..., None], st.mu[:, :L], ahead)
        P = np.where(valid[..., None, None], st.P[:, :L], np.eye(2))
        zhat, H = steps.predict_measurement(poses, mu)  # (N, L, 2), (N, L, 2, 2)
        zhat, H = np.asarray(zhat, dtype=float), np.asarray(H, dtype=float)
        S = np.asarray(steps.innovation_covariance(H, P, Q), dtype=float)
        slot = self._candidates(valid, zhat, S, z)  # (N, C)
        cvalid = np.take_along_axis(valid, slot, axis=1) & (slot >= 0)
        slot = np.maximum(slot, 0)
        rows = np.arange(n)[:, None]
        C = slot.shape[1]
        # all (observation, candidate) pairs, observation m and candidate c at m C + c, stored
        # component-major like the units' own outputs (the elementwise formulas run on contiguous blocks)
        zc = np.empty((2, k, C, n))
        zc[...] = zhat[rows, slot].transpose(2, 1, 0)[:, None]
        Sc = np.empty((2, 2, k, C, n))
        Sc[...] = S[rows, slot].transpose(2, 3, 1, 0)[:, :, None]
        zhat_all = zc.reshape(2, k * C, n).transpose(2, 1, 0)
        S_all = Sc.reshape(2, 2, k * C, n).transpose(3, 2, 0, 1)
        nu = steps.innovation(np.repeat(z, C, axis=0), zhat_all, wrap=steps.wrap_bearing)  # (N, k C, 2)
        ll = np.asarray(steps.log_likelihood(nu, S_all), dtype=float).reshape(n, k, C)
        chosen = np.asarray(steps.associate(ll, cvalid, self._log_p0), dtype=np.intp)  # candidate or NEW
        new = chosen == NEW_LANDMARK
        c = np.where(new, 0, chosen)
        j = slot[rows, c]
        assoc = np.where(new, NEW_LANDMARK, j)
        pair = np.arange(k)[None, :] * C + c
        # new pairs get the placeholder (finite values; the caller masks them out)
        return Association(assoc=assoc, mu=np.where(new[..., None], ahead, mu[rows, j]),
                           P=np.where(new[..., None, None], np.eye(2), P[rows, j]), H=H[rows, j], S=S[rows, j],
                           nu=np.asarray(nu, dtype=float)[rows, pair], loglik=ll[rows, np.arange(k)[None, :], c])

    def _candidates(self, valid: np.ndarray, zhat: np.ndarray, S: np.ndarray, z: np.ndarray) -> np.ndarray:
        """The landmark slots each particle compares the step's observations with, (N, C); -1 pads.

        A landmark whose predicted range differs from every observed range by more than
        ``new_landmark_sigmas * sqrt(S_rr)``, or whose predicted bearing differs from every
        observed bearing (wrapped) by more than ``new_landmark_sigmas * sqrt(S_bb)``, cannot
        explain any observation better than ``p0`` (the Mahalanobis distance is at least
        ``|nu_r| / sqrt(S_rr)`` and ``|nu_b| / sqrt(S_bb)``, and ``det S >= det Q``), so leaving it
        out changes no association of the reference units; it only saves work.
        """
        g = self._config.new_landmark_sigmas
        near_r = _nearest_gap(zhat[..., 0], z[:, 0], circular=False) <= g * np.sqrt(S[..., 0, 0])
        near_b = _nearest_gap(zhat[..., 1], z[:, 1], circular=True) <= g * np.sqrt(S[..., 1, 1])
        cand = valid & near_r & near_b  # NaN: not a candidate
        C = max(1, int(cand.sum(axis=1).max()))
        order = np.argsort(~cand, axis=1, kind="stable")[:, :C]
        return np.where(np.take_along_axis(cand, order, axis=1), order, -1)

    def _weights(self, logw: np.ndarray, a: Association) -> np.ndarray:
        """``combine_weights`` with the associated likelihood, or ``log_p0`` for a new landmark (unnormalised)."""
        loglik = np.where(a.known, a.loglik, self._log_p0)
        return np.asarray(self._run_steps.combine_weights(logw, loglik, np.ones(loglik.shape, dtype=bool)), dtype=float)

    def _update_maps(self, poses: np.ndarray, z: np.ndarray, known: np.ndarray, slots: np.ndarray,
                     mu: np.ndarray, P: np.ndarray, H: np.ndarray, S: np.ndarray, nu: np.ndarray) -> None:
        """EKF update of the associated landmarks, then the new landmarks appended (from ``poses``)."""
        steps = self._run_steps
        st = self._state
        new = ~known
        if known.any():
            mu_new, P_new = steps.ekf_update(mu, P, H, S, nu)
            r, m = np.nonzero(known)
            st.mu[r, slots[r, m]] = np.asarray(mu_new, dtype=float)[r, m]
            st.P[r, slots[r, m]] = np.asarray(P_new, dtype=float)[r, m]
        if new.any():
            c = np.flatnonzero(new.any(axis=0))
            mu0, P0 = steps.init_landmarks(poses, z[c], self._Q, wrap=steps.wrap_bearing)
            sel = new[:, c]
            place = st.size[:, None] + np.cumsum(sel, axis=1) - 1  # next free slots, in observation order
            st = self._grow(st, int((st.size + sel.sum(axis=1)).max()))
            r, m = np.nonzero(sel)
            st.mu[r, place[r, m]] = np.asarray(mu0, dtype=float)[r, m]
            st.P[r, place[r, m]] = np.asarray(P0, dtype=float)[r, m]
            st = st.replace(size=st.size + sel.sum(axis=1))
        self._state = st

    @staticmethod
    def _grow(st: AssociationState, needed: int) -> AssociationState:
        """``st`` with room for ``needed`` landmarks per particle (capacity doubles)."""
        cap = st.mu.shape[1]
        new_cap = grown_capacity(cap, needed)
        if new_cap is None:
            return st
        n = st.n_particles
        mu, P = np.zeros((n, new_cap, 2)), np.zeros((n, new_cap, 2, 2))
        mu[:, :cap], P[:, :cap] = st.mu, st.P
        return st.replace(mu=mu, P=P)

    @staticmethod
    def _observations(observations: Observations) -> np.ndarray:
        return np.column_stack([observations.ranges, observations.bearings])


class FastSlamUnknown(_UnknownAssociationSlam):
    """FastSLAM 1.0 with unknown data association: ``FastSlamUnknown(config, steps=...)`` with a
    :class:`FastSlamConfig` whose ``association`` is ``"unknown"`` (the default here) and a
    :class:`FastSlamUnknownSteps` table."""

    name = "fastslam1_unknown"
    steps_type = FastSlamUnknownSteps
    reference_steps = REFERENCE_STEPS
    random_units = _contract.STREAM_UNITS

    def update(self, control: np.ndarray, observations: Observations) -> None:
        st, u, u_n, k, empty = self._begin_step(control, observations)
        steps = self._run_steps
        u_i = u_n if empty else steps.sample_controls(u, st.n_particles, self._streams["sample_controls"], self._config)
        poses = np.asarray(steps.motion_model(st.poses, u_i, wrap=steps.wrap_heading), dtype=float)
        logw = st.logw
        if k:
            z = self._observations(observations)
            a = self._associate(poses, z)
            logw = normalise_log_weights(self._weights(logw, a), name=self.name, step=self._t)
            self._update_maps(poses, z, a.known, a.assoc, a.mu, a.P, a.H, a.S, a.nu)
        self._finish(self._state, poses, logw, empty)


class FastSlam2Unknown(_UnknownAssociationSlam):
    """FastSLAM 2.0 with unknown data association, set up like :class:`FastSlamUnknown` (units:
    :class:`FastSlam2UnknownSteps`; random streams: those of :class:`~faultlab.slam.FastSlam2`)."""

    name = "fastslam2_unknown"
    steps_type = FastSlam2UnknownSteps
    reference_steps = REFERENCE_STEPS_2
    random_units = RANDOM_UNITS

    def __init__(self, config: FastSlamConfig | None = None, *, steps: FastSlam2UnknownSteps | None = None):
        super().__init__(config, steps=steps)
        self._M = self._config.M

    def update(self, control: np.ndarray, observations: Observations) -> None:
        st, _, u_n, k, empty = self._begin_step(control, observations)
        steps = self._run_steps
        x_hat = np.asarray(steps.motion_model(st.poses, u_n, wrap=steps.wrap_heading), dtype=float)
        if empty:  # the noise-free prediction is the pose
            self._finish(st, x_hat, st.logw, empty)
            return
        Q, M, n, logw = self._Q, self._M, st.n_particles, st.logw
        if k:
            # association and proposal at the noise-free prediction (Table 13.3)
            z = self._observations(observations)
            a = self._associate(x_hat, z)
            known = a.known
            _, V = steps.motion_jacobians(st.poses, u_n)
            lam, eta = steps.proposal_information(steps.pose_jacobian(a.H), V, a.S, a.nu, known)
        else:
            lam, eta = np.zeros((n, 2, 2)), np.zeros((n, 2))
        poses, cov = sample_pose(steps, st.poses, u_n, lam, eta, M, self._streams["sample_proposal"])
        poses = np.asarray(poses, dtype=float)
        if k:
            logw = self._weights(logw, a) + np.asarray(steps.proposal_correction(lam, eta, cov, M), dtype=float)
            logw = normalise_log_weights(logw, name=self.name, step=self._t)
            # the associated landmarks are updated from the sampled pose
            with np.errstate(invalid="ignore", divide="ignore"):  # a landmark on top of a particle
                H, nu, S = linearise(steps, poses, a.mu, a.P, z, Q)
            self._update_maps(poses, z, known, a.assoc, a.mu, a.P, H, S, nu)
        self._finish(self._state, poses, logw, empty)


def _nearest_gap(x: np.ndarray, values: np.ndarray, *, circular: bool) -> np.ndarray:
    """Distance from every element of ``x`` to the nearest of ``values`` (k,) (angles: wrapped)."""
    if circular:
        x = _units.wrap_bearing(x)
        values = _units.wrap_bearing(values)
    v = np.sort(values)
    pos = np.searchsorted(v, x)
    near = [v[np.minimum(pos, v.size - 1)], v[np.maximum(pos - 1, 0)]]
    if circular:
        near += [v[0], v[-1]]  # across the +-pi seam
        return np.min([np.abs(_units.wrap_bearing(x - w)) for w in near], axis=0)
    return np.min([np.abs(x - w) for w in near], axis=0)
