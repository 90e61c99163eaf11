"""The built-in faults: the paper's three (Sec. V-3, VII-A) and realistic particle-filter SLAM mistakes.

Every fault replaces exactly one unit of :class:`faultlab.slam.FastSlamSteps`
(signatures in :mod:`faultlab.slam.fastslam` and :mod:`faultlab.slam.units`).
Replacements are module-level factories ``(original_unit) -> new_unit`` so that
faults pickle to worker processes; most wrap the original unit and change only
what the mistake changes.  Each fault carries :class:`UnitExample` inputs on
which the faulty unit's output differs from the reference unit's (a
unit-level "killed mutant" check, run by the tests).

Randomness: a fault that replaces a random unit (``sample_controls``,
``resample``: :data:`faultlab.slam.contract.STREAM_UNITS`) draws only from the
``rng`` it is given, which is that unit's own stream; its different use of
randomness (``naive_resampling`` draws N uniforms per update,
``shared_control_noise`` two normals per step) therefore leaves every other
unit's draws identical to the baseline's with the same seed.

References: Thrun, Burgard & Fox, *Probabilistic Robotics* (2005), Table 13.1
(FastSLAM 1.0, known correspondences) and Sec. 4.3 / Table 4.4 (particle
filter, low-variance sampler); PythonRobotics' ``SLAM/FastSLAM1/fast_slam1.py``
(the implementation the paper tests, Sec. VII-A).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from faultlab.faults.fault import Fault, UnitExample
from faultlab.slam.fastslam import REFERENCE_STEPS, FastSlamConfig
from faultlab.slam.noise import NoiseConfig
from faultlab.slam.paperunits import shallow_copy_ancestors
from faultlab.slam.particles import ParticleState

__all__ = ["BUILTIN_FAULTS", "PAPER_FAULTS", "in_place_ancestors", "PAPER_ALIASING",
           "MEASUREMENT_NOISE_FROM_STATE_COVARIANCE", "CONTROL_NOISE_FROM_COVARIANCE"]

_LOG_TWO_PI = math.log(2.0 * math.pi)


# --------------------------------------------------------------------------- example inputs

def _config():
    return FastSlamConfig()


def _reference(unit: str):
    return getattr(REFERENCE_STEPS, unit)


def _poses() -> np.ndarray:
    return np.array([[0.0, 0.0, 0.0], [1.0, -0.5, 2.5], [-2.0, 1.0, -3.0]])


def _ekf_inputs():
    poses = _poses()
    mu = np.array([[[2.0, 1.0]], [[1.5, 1.0]], [[-3.0, -0.5]]])
    P = np.tile(np.array([[0.04, 0.01], [0.01, 0.09]]), (3, 1, 1, 1))
    zhat, H = _reference("predict_measurement")(poses, mu)
    S = _reference("innovation_covariance")(H, P, _config().Q)
    nu = np.array([[[0.1, 0.05]], [[-0.2, 0.1]], [[0.05, -0.1]]])
    return mu, P, H, S, nu


def _resample_inputs(w: np.ndarray, *, empty: bool = False):
    """``resample`` arguments for normalised weights ``w``: their N_eff = 1 / sum(w^2), a fixed rng."""
    return (w, float(1.0 / np.dot(w, w)), empty, np.random.default_rng(0), _config()), {}


def _ex_resample_empty():
    return _resample_inputs(np.full(4, 0.25), empty=True)


def _ex_resample_degenerate():
    return _resample_inputs(np.array([0.97, 0.01, 0.01, 0.01]))


def _ex_resample_balanced():
    return _resample_inputs(np.array([0.3, 0.3, 0.2, 0.2]))


def _ex_wrap():
    return (np.array([1.5 * math.pi, -1.5 * math.pi, 0.1 + 2.0 * math.pi]),), {}


def _ex_motion():
    u = np.array([[1.0, 0.2], [0.5, -0.1], [0.08, 0.3]])
    return (_poses(), u), {"wrap": _reference("wrap_heading")}


def _ex_sample_controls():
    return (np.array([0.08, 0.1]), 5, np.random.default_rng(0), _config()), {}


def _ex_init():
    z = np.array([[2.0, 0.8], [1.0, -0.4]])
    return (_poses(), z, _config().Q), {"wrap": _reference("wrap_bearing")}


def _ex_classify():
    mu = np.array([[[0.004, 1.0], [2.0, 1.0]], [[0.5, 1.0], [-0.009, -2.0]]])
    return (np.array([True, True]), mu), {}


def _ex_predict():
    return (_poses(), np.array([[[2.0, 1.0]], [[1.5, 1.0]], [[-3.0, -0.5]]])), {}


def _ex_ekf():
    return _ekf_inputs(), {}


def _ex_loglik():
    _, _, _, S, nu = _ekf_inputs()
    return (nu, S), {}


def _ex_combine():
    logw = np.log(np.array([0.7, 0.3]))
    return (logw, np.array([[-1.0, -0.5], [-2.0, -0.1]]), np.ones((2, 2), dtype=bool)), {}


def _state_example():
    st = ParticleState.initial(np.zeros(3), 4)
    return dataclasses.replace(st, poses=np.arange(12.0).reshape(4, 3),
                               logw=np.log(np.array([0.1, 0.2, 0.3, 0.4])))


def _ex_apply_resample_chain():
    return (_state_example(), np.array([1, 0, 0, 3])), {}


def _ex_apply_resample():
    return (_state_example(), np.array([3, 3, 2, 1])), {}


# --------------------------------------------------------------------------- the paper's faults

def _naive_resampling(original):
    """Multinomial resampling at every update: no N_eff test, empty updates included."""

    def resample(w, n_eff, empty, rng, config):
        cdf = np.cumsum(w)
        idx = np.searchsorted(cdf, rng.random(w.shape[0]) * cdf[-1], side="right")
        return np.minimum(idx, w.shape[0] - 1).astype(np.intp)

    return resample


def _no_bearing_wrap(original):
    """Bearing angles are never normalised (identity)."""

    def wrap_bearing(a):
        return np.asarray(a, dtype=float)

    return wrap_bearing


def _motion_sign_error(original):
    """x' = F x - B(theta) u: the original model driven by -u."""

    def motion_model(poses, u, *, wrap):
        return original(poses, -np.asarray(u), wrap=wrap)

    return motion_model


NAIVE_RESAMPLING = Fault(
    name="naive_resampling",
    step="resample",
    description="Multinomial resampling at every update, empty ones included, with no N_eff test.",
    rationale=(
        "A naive particle filter resamples after every update. During a phase of inactivity (empty "
        "updates: no motion, no observation) the weights stay uniform, yet every resampling draws the "
        "particle set with replacement and loses hypotheses, so the set collapses onto a few ancestors "
        "(particle deprivation) and the uncertainty built up before the pause is removed artificially; "
        "the error shows after the robot moves on. The paper injects exactly this fault and designs the "
        "inactivity parameter (2000 idle steps in the middle of the trace) to expose it."),
    origin="paper Sec. II-C, V-3 and VII-A (naive resampling); Probabilistic Robotics Sec. 4.3.4",
    replacement=_naive_resampling,
    examples=(UnitExample(_ex_resample_empty, "resamples on an empty update with uniform weights"),
              UnitExample(_ex_resample_balanced, "resamples although N_eff >= N / 1.5")),
)

MISSING_ANGLE_WRAP = Fault(
    name="missing_angle_wrap",
    step="wrap_bearing",
    description="No normalisation of the bearing innovation, nor of yaw + bearing at landmark initialisation.",
    rationale=(
        "Angles that differ by a multiple of 2 pi describe the same direction, but arithmetic on them "
        "does not know that. Without normalising the bearing innovation z - z_hat to [-pi, pi), a "
        "landmark seen across the +-pi cut (or a sensor that reports bearings offset by 2 pi) yields an "
        "innovation near 2 pi: the particle's weight collapses and the EKF drags the landmark around the "
        "robot. The paper's rotation-error parameter (bearings and turns offset by +-2 pi) targets this; "
        "the fault replaces the bearing wrap with the identity everywhere it is used."),
    origin="paper Sec. V-2 and VII-A (faulty rotation: missing treatment of angles beyond a full turn)",
    replacement=_no_bearing_wrap,
    examples=(UnitExample(_ex_wrap, "bearings beyond +-pi stay unwrapped"),),
)

MOTION_SIGN_ERROR = Fault(
    name="motion_sign_error",
    step="motion_model",
    description="The motion model subtracts B(theta) u instead of adding it (x' = F x - B u).",
    rationale=(
        "A sign error in the prediction: every particle drives backwards and turns the wrong way while the "
        "observations come from the true path, so the sampled poses contradict the measurements at every "
        "step. The filter can only partly compensate through resampling and the EKF corrections, and the "
        "map is distorted. The paper uses it as a fault no parameter was designed for, to test whether the "
        "suites catch unanticipated errors."),
    origin="paper Sec. VII-A (sign error in the motion model of PythonRobotics' FastSLAM 1.0)",
    replacement=_motion_sign_error,
    examples=(UnitExample(_ex_motion, "particles move by -u"),),
)


# --------------------------------------------------------------------------- realistic faults

#: Ancestors that an in-place resampling loop over a shallow list copy really copies (see
#: :func:`faultlab.slam.paperunits.shallow_copy_ancestors`).
in_place_ancestors = shallow_copy_ancestors


def _shared_storage_resampling(original, *, sequential: bool):
    """Resampling as an in-place loop over a shallow list copy: copies share their ancestor's storage.

    With ``sequential`` the sharers then update their common landmarks one after another
    (``ParticleState.sequential_sharers``); otherwise in parallel, the last write winning.
    """

    def apply_resample(state, indices):
        eff = in_place_ancestors(indices)
        out = original(state, eff)
        # duplicates keep writing into the storage row of their ancestor: shared landmark arrays
        sharing = {"sequential_sharers": True} if sequential else {}
        return dataclasses.replace(out, owner=np.asarray(state.owner)[eff], **sharing)

    return apply_resample


def _shallow_copy_resampling(original):
    return _shared_storage_resampling(original, sequential=False)


def _gain_from_wrong_covariance(original):
    """The gain sees S + H P H^T: the innovation covariance passed where the measurement noise belongs."""

    def ekf_update(mu, P, H, S, nu):
        S = np.asarray(S, dtype=float)
        return original(mu, P, H, S + H @ P @ np.swapaxes(H, -1, -2), nu)

    return ekf_update


def _weight_overwritten(original):
    """Each known observation overwrites the weight: only the last one of the step counts."""

    def combine_weights(logw, loglik, known):
        logw = np.asarray(logw, dtype=float)
        known = np.asarray(known, dtype=bool)
        k = known.shape[1]
        last = k - 1 - np.argmax(known[:, ::-1], axis=1)
        lik = np.asarray(loglik, dtype=float)[np.arange(known.shape[0]), last]
        return np.where(known.any(axis=1), lik, logw)

    return combine_weights


def _landmark_jacobian(poses, mu):
    dx = mu[..., 0] - poses[:, 0:1]
    dy = mu[..., 1] - poses[:, 1:2]
    q = dx * dx + dy * dy
    d = np.sqrt(q)
    H = np.zeros(dx.shape + (2, 2))
    H[..., 0, 0], H[..., 0, 1] = dx / d, dy / d
    H[..., 1, 0], H[..., 1, 1] = -dy / q, dx / q
    return H


def _init_cov_not_inverted(original):
    """Sigma = G Q G^T instead of G^-1 Q G^-T."""

    def init_landmarks(poses, z, Q, *, wrap):
        mu, _ = original(poses, z, Q, wrap=wrap)
        G = _landmark_jacobian(poses, mu)
        return mu, G @ np.asarray(Q, dtype=float) @ np.swapaxes(G, -1, -2)

    return init_landmarks


def _bearing_in_degrees(original):
    def init_landmarks(poses, z, Q, *, wrap):
        z = np.array(z, dtype=float)
        z[:, 1] = np.deg2rad(z[:, 1])  # the bearing is already in radians
        return original(poses, z, Q, wrap=wrap)

    return init_landmarks


def _jacobian_sign_error(original):
    def predict_measurement(poses, mu):
        zhat, H = original(poses, mu)
        H = np.array(H, dtype=float)
        H[..., 1, :] *= -1.0  # d bearing / d landmark written as (dy/q, -dx/q)
        return zhat, H

    return predict_measurement


def _shared_control_noise(original):
    def sample_controls(u, n, rng, config):
        one = original(u, 1, rng, config)  # one noise draw ...
        return np.repeat(np.asarray(one, dtype=float).reshape(1, 2), n, axis=0)  # ... for every particle

    return sample_controls


def _inverted_threshold(original):
    """Resample when N_eff > N / ratio: feed the original the N_eff mirrored at the threshold."""

    def resample(w, n_eff, empty, rng, config):
        threshold = w.shape[0] / config.resample_ratio
        return original(w, 2.0 * threshold - n_eff, empty, rng, config)

    return resample


def _frozen_covariance(original):
    def ekf_update(mu, P, H, S, nu):
        mu_new, _ = original(mu, P, H, S, nu)
        return mu_new, np.array(P, dtype=float)

    return ekf_update


def _new_if_x_near_zero(original):
    def classify_new(seen, mu):
        return np.abs(np.asarray(mu)[..., 0]) <= 0.01

    return classify_new


def _likelihood_without_normaliser(original):
    """Only the exponent -0.5 nu^T S^-1 nu: the per-particle |2 pi S|^-1/2 factor is dropped."""

    def log_likelihood(nu, S):
        det = S[..., 0, 0] * S[..., 1, 1] - S[..., 0, 1] * S[..., 1, 0]
        return original(nu, S) + _LOG_TWO_PI + 0.5 * np.log(det)

    return log_likelihood


def _turn_before_drive(original):
    """x' = x + v cos(theta + omega): turn first, then drive."""

    def motion_model(poses, u, *, wrap):
        poses = np.array(poses, dtype=float)
        u = np.array(u, dtype=float)
        poses[:, 2] = poses[:, 2] + u[:, 1]
        u[:, 1] = 0.0
        return original(poses, u, wrap=wrap)

    return motion_model


def _resample_keeps_weights(original):
    def apply_resample(state, indices):
        out = original(state, indices)
        logw = np.asarray(state.logw, dtype=float)[np.asarray(indices)]
        top = np.max(logw)
        logw = logw - (top + math.log(np.sum(np.exp(logw - top))))
        return dataclasses.replace(out, logw=logw)

    return apply_resample


SHALLOW_COPY_RESAMPLING = Fault(
    name="shallow_copy_resampling",
    step="apply_resample",
    description="Resampling copies particles through a shallow list copy: duplicates share one landmark storage.",
    rationale=(
        "Resampling must deep-copy each drawn particle. PythonRobotics' FastSLAM 1.0 example copies the "
        "particle list shallowly (tmp = particles[:]) and then overwrites particles in place, assigning "
        "array views (lm[:, :]) of the landmark arrays: a particle drawn after its source slot was already "
        "overwritten receives the wrong ancestor, and all duplicates of an ancestor keep writing into the "
        "same landmark storage, so one duplicate's EKF update silently changes the map of the others. "
        "Here the copy follows the in-place loop's ancestry and duplicates share their ancestor's storage "
        "row (the vectorised filter writes all duplicates' updates into that row, last one wins)."),
    origin=("public code: PythonRobotics SLAM/FastSLAM1/fast_slam1.py, resampling() "
            "(shallow list copy particles[:], array views lm[:, :])"),
    replacement=_shallow_copy_resampling,
    examples=(UnitExample(_ex_apply_resample_chain, "particle 1 reads slot 0 after it was overwritten"),),
)

GAIN_FROM_WRONG_COVARIANCE = Fault(
    name="gain_from_wrong_covariance",
    step="ekf_update",
    description="The Kalman gain uses S + H P H^T (innovation covariance passed where Q belongs) instead of S.",
    rationale=(
        "FastSLAM code juggles two similar matrices: the measurement noise Q and the innovation "
        "covariance S = H P H^T + Q (Sf in PythonRobotics). PythonRobotics' EKF helper takes Q and forms "
        "S itself; passing Sf in Q's place (the S/Sf confusion reported for that example) makes the gain "
        "K = P H^T (2 H P H^T + Q)^-1 too small. The update stays stable, but landmarks converge slowly "
        "and keep too large a covariance, which in turn flattens the importance weights."),
    origin=("public bug report: PythonRobotics issue #138 'S here seems incorrect' (which innovation "
            "covariance, S or Sf, the FastSLAM 1.0 landmark update uses; Table 13.1)"),
    replacement=_gain_from_wrong_covariance,
    examples=(UnitExample(_ex_ekf, "smaller gain"),),
)

WEIGHT_OVERWRITTEN = Fault(
    name="weight_overwritten",
    step="combine_weights",
    description="Each observation's likelihood overwrites the importance weight instead of multiplying it.",
    rationale=(
        "A particle's weight must accumulate the likelihoods of all observations (w *= p(z | x), as in "
        "PythonRobotics' loop over observations). Writing w = p(z | x) inside that loop keeps only the "
        "last observation of the step (and forgets earlier steps' evidence where no resampling "
        "happened), so the filter resamples on a fraction of the evidence and keeps hypotheses that the "
        "other landmarks had ruled out. It only matters when a step has several known landmarks."),
    origin=("textbook pitfall: Probabilistic Robotics Table 13.1 / Sec. 4.3 (importance weights multiply; "
            "PythonRobotics writes particles[ip].w *= w per observation)"),
    replacement=_weight_overwritten,
    examples=(UnitExample(_ex_combine, "only the last observation counts"),),
)

INIT_COVARIANCE_NOT_INVERTED = Fault(
    name="init_covariance_not_inverted",
    step="init_landmarks",
    description="A new landmark's covariance is G Q G^T instead of G^-1 Q G^-T (Jacobian not inverted).",
    rationale=(
        "The inverse measurement model maps the measurement noise Q into landmark coordinates through the "
        "inverse of the measurement Jacobian, Sigma = G^-1 Q G^-T. Forgetting the inversion gives a matrix "
        "with the wrong units and scale (range noise divided by the range instead of multiplied, metres "
        "mixed with radians), so new landmarks start far too certain (or too uncertain); the first "
        "observations then barely correct them and the weights are miscalibrated."),
    origin=("textbook pitfall: Probabilistic Robotics Table 13.1 (Sigma = H^-1 Q H^-T); public report "
            "PythonRobotics issue #323 / PR #334 on the initial landmark covariance of FastSLAM 1.0 and 2.0"),
    replacement=_init_cov_not_inverted,
    examples=(UnitExample(_ex_init, "covariance G Q G^T"),),
)

BEARING_IN_DEGREES = Fault(
    name="bearing_in_degrees",
    step="init_landmarks",
    description="Landmark initialisation treats the bearing as degrees (np.deg2rad on a value already in radians).",
    rationale=(
        "Mixing degrees and radians is a classic interface error: sensor drivers and configuration files "
        "often use degrees while the filter works in radians. Converting an already-radian bearing with "
        "deg2rad shrinks it by a factor of 57, so every landmark is initialised almost straight ahead of "
        "the robot; the EKF corrections must then drag it to its true bearing, against a covariance that "
        "claims the wrong position is known to within the bearing noise."),
    origin="textbook pitfall: unit mix-up degrees/radians (ROS REP 103 fixes radians for angles)",
    replacement=_bearing_in_degrees,
    examples=(UnitExample(_ex_init, "landmarks initialised near bearing 0"),),
)

JACOBIAN_SIGN_ERROR = Fault(
    name="jacobian_sign_error",
    step="predict_measurement",
    description="The bearing row of the measurement Jacobian has the wrong sign (the robot-position derivative).",
    rationale=(
        "The bearing atan2(dy, dx) - theta has derivative (-dy/q, dx/q) with respect to the landmark but "
        "(dy/q, -dx/q) with respect to the robot position; FastSLAM needs the former, EKF-SLAM code nearby "
        "uses both (Hf and Hv in PythonRobotics), and the signs are easily swapped. With the wrong sign "
        "the EKF moves the landmark the wrong way for every bearing error, so landmark estimates drift "
        "sideways while their covariance still shrinks."),
    origin="textbook pitfall: Probabilistic Robotics Table 13.1 (H = h'(mu, x) is the derivative w.r.t. the landmark)",
    replacement=_jacobian_sign_error,
    examples=(UnitExample(_ex_predict, "bearing row negated"),),
)

SHARED_CONTROL_NOISE = Fault(
    name="shared_control_noise",
    step="sample_controls",
    description="One control-noise sample is drawn per step and shared by all particles.",
    rationale=(
        "The prediction must sample the motion model independently for every particle "
        "(x_t^k ~ p(x_t | u_t, x_{t-1}^k)). Drawing the noise once per step (size 2 instead of (N, 2)) "
        "moves all particles identically: the particle set never spreads, cannot represent the pose "
        "uncertainty, and the filter degenerates into dead reckoning with an extra random walk."),
    origin="textbook pitfall: Probabilistic Robotics Table 13.1 / Table 4.3 (sample the motion model per particle)",
    replacement=_shared_control_noise,
    examples=(UnitExample(_ex_sample_controls, "identical rows"),),
)

INVERTED_RESAMPLING_THRESHOLD = Fault(
    name="inverted_resampling_threshold",
    step="resample",
    description="Resamples when N_eff > N / 1.5 instead of N_eff < N / 1.5 (comparison inverted).",
    rationale=(
        "Selective resampling resamples only when the effective sample size drops below a threshold. "
        "With the comparison inverted the filter resamples while the weights are balanced (needlessly "
        "losing diversity) and never when they have degenerated, so a few particles carry all the weight "
        "and the others waste their updates."),
    origin=("textbook pitfall: Probabilistic Robotics Sec. 4.3.4 and Grisetti et al. 2005 (selective "
            "resampling only when N_eff is low); paper Sec. II-C"),
    replacement=_inverted_threshold,
    examples=(UnitExample(_ex_resample_degenerate, "does not resample degenerate weights"),
              UnitExample(_ex_resample_balanced, "resamples balanced weights")),
)

FROZEN_LANDMARK_COVARIANCE = Fault(
    name="frozen_landmark_covariance",
    step="ekf_update",
    description="The landmark covariance is never updated (P' = P instead of (I - K H) P).",
    rationale=(
        "Forgetting to store the updated covariance (or updating a copy) leaves every landmark at its "
        "initial uncertainty: the gain never decreases, so each new observation moves the landmark as "
        "much as the first one did, the map estimate keeps jittering with the measurement noise, and the "
        "weights undervalue well-observed landmarks."),
    origin="textbook pitfall: Probabilistic Robotics Table 13.1 (Sigma = (I - K H) Sigma)",
    replacement=_frozen_covariance,
    examples=(UnitExample(_ex_ekf, "covariance unchanged"),),
)

NEW_LANDMARK_NEAR_ZERO = Fault(
    name="new_landmark_near_zero",
    step="classify_new",
    description="A landmark counts as new when its stored x is within 1 cm of 0 (zero-initialised storage test).",
    rationale=(
        "Instead of remembering which landmarks were seen, PythonRobotics' FastSLAM 1.0 example "
        "pre-allocates the landmark array with zeros and treats a landmark as new while "
        "abs(lm[id, 0]) <= 0.01. Any landmark whose estimated x lies within 1 cm of the y axis is "
        "re-initialised from the current observation at every sighting, discarding its estimate and "
        "skipping its weight update. It only bites for landmarks near x = 0, which few test maps contain."),
    origin=("public code: PythonRobotics SLAM/FastSLAM1/fast_slam1.py, update_with_observation() "
            "(new landmark if abs(particle.lm[lm_id, 0]) <= 0.01)"),
    replacement=_new_if_x_near_zero,
    examples=(UnitExample(_ex_classify, "seen landmarks near x = 0 re-initialised"),),
)

LIKELIHOOD_WITHOUT_NORMALISER = Fault(
    name="likelihood_without_normaliser",
    step="log_likelihood",
    description="The importance weight omits the |2 pi S|^-1/2 factor of the Gaussian likelihood.",
    rationale=(
        "Dropping the normalisation constant of a Gaussian is harmless only when it is the same for all "
        "particles. In FastSLAM each particle has its own landmark covariance and hence its own S, so the "
        "determinant factor matters: without it particles with uncertain landmark estimates are not "
        "penalised and the weights favour the wrong hypotheses."),
    origin="textbook pitfall: Probabilistic Robotics Table 13.1 (w = |2 pi Q|^-1/2 exp(...))",
    replacement=_likelihood_without_normaliser,
    examples=(UnitExample(_ex_loglik, "no log-determinant term"),),
)

TURN_BEFORE_DRIVE = Fault(
    name="turn_before_drive",
    step="motion_model",
    description="The motion model turns first and then drives (x' = x + v cos(theta + omega)).",
    rationale=(
        "Odometry and velocity models differ in whether the rotation is applied before or after the "
        "translation; the scenario (and PythonRobotics, x' = F x + B(theta) u with the old heading) drive "
        "along the old heading and turn afterwards. Applying the turn first rotates every step's "
        "displacement by omega, a systematic error that grows with the turn rate and the step size."),
    origin="textbook pitfall: Probabilistic Robotics Ch. 5 (motion models; order of rotation and translation)",
    replacement=_turn_before_drive,
    examples=(UnitExample(_ex_motion, "displacement along theta + omega"),),
)

RESAMPLE_KEEPS_WEIGHTS = Fault(
    name="resample_keeps_weights",
    step="apply_resample",
    description="After resampling the copies keep their ancestors' weights instead of 1/N.",
    rationale=(
        "Resampling replaces weights by multiplicity: after drawing proportionally to the weights, every "
        "copy must get weight 1/N. Keeping the old weights counts the same evidence twice (once in the "
        "number of copies, once in the weight), so the particle set degenerates much faster than it "
        "should and the map of a lucky particle wins too early."),
    origin="textbook pitfall: Probabilistic Robotics Table 4.3 / Sec. 4.3.4 (resampled particles are unweighted)",
    replacement=_resample_keeps_weights,
    examples=(UnitExample(_ex_apply_resample, "weights not reset to uniform"),),
)

def _paper_aliasing(original):
    """Shallow-copy resampling whose sharers then update their common landmarks one after another."""
    return _shared_storage_resampling(original, sequential=True)


def _ex_apply_resample_aliased():
    return (_state_example(), np.array([2, 0, 0, 3])), {}


PAPER_ALIASING = Fault(
    name="paper_aliasing",
    step="apply_resample",
    description=("Resampling by shallow copies as in the paper's filter: copies share landmark arrays and every "
                 "sharer re-applies each later update of them, one after another."),
    rationale=(
        "PythonRobotics' FastSLAM 1.0 resamples with tmp = particles[:] (a shallow list copy) and assigns "
        "views lm[:, :] and lmP[:, :] of the drawn particle's landmark arrays, overwriting the particles in "
        "place. A copy drawn from a slot that was already overwritten gets that slot's new content, and all "
        "copies of an ancestor keep the very same arrays, for good: no particle ever gets fresh arrays again, "
        "so the number of distinct maps only shrinks, typically to one. The update loop then runs over the "
        "particles one by one: the first sharer initialises or updates a shared landmark with its pose, the "
        "next one updates that result with its own pose, and so on, so each observation is applied once per "
        "sharer, the landmark covariance shrinks once per sharer and the weights of later sharers are "
        "computed against estimates their own update has not produced. The paper's correct variant has this "
        "defect, so all its faulty variants inherit it. Unlike shallow_copy_resampling (duplicates update "
        "in parallel, the last write wins), this reproduces the sequential updates exactly "
        "(faultlab.slam.sharing; a loop over sharer ranks, slower than the reference path)."),
    origin=("public code: PythonRobotics SLAM/FastSLAM1/fast_slam1.py, resampling() (shallow list copy "
            "particles[:], array views lm[:, :], lmP[:, :]) and update_with_observation() (per-particle loop); "
            "unrepaired in the paper's replication package EmbSys-WWU/SLAMtesting slam/slam_correct.py"),
    replacement=_paper_aliasing,
    examples=(UnitExample(_ex_apply_resample_aliased,
                          "particles 1 and 2 share slot 0's landmarks, which slot 0 took from particle 2"),),
)


# --------------------------------------------------------------------------- faults from real bugs
# (their provenance: faultlab.faults.real)

def _state_block_as_measurement_noise(original):
    """S = H P H^T + Q' with Q' the pose-noise block: the filter's motion noise where the sensor's belongs."""
    M = NoiseConfig().M

    def innovation_covariance(H, P, Q):
        return original(H, P, M)

    return innovation_covariance


def _ex_innovation():
    H = np.tile(np.array([[0.8, 0.6], [-0.12, 0.16]]), (2, 1, 1, 1))
    P = np.tile(np.array([[0.04, 0.01], [0.01, 0.09]]), (2, 1, 1, 1))
    return (H, P, NoiseConfig().Q), {}


MEASUREMENT_NOISE_FROM_STATE_COVARIANCE = Fault(
    name="measurement_noise_from_state_covariance",
    step="innovation_covariance",
    description="The innovation covariance adds the motion-noise matrix instead of the measurement noise Q.",
    rationale=(
        "EKF-based SLAM code keeps several 2x2 and 3x3 noise matrices side by side; PythonRobotics' EKF-SLAM "
        "example forms S = H P H^T + Cx[0:2, 0:2], the top-left (x, y) block of its state noise Cx, where "
        "the range-bearing noise belongs. The unit cannot see the filter's own motion noise, so here the "
        "default control-noise matrix M = diag(std_v^2, std_omega^2) of faultlab.slam.noise stands in for "
        "Q: range gets 0.1 m instead of 0.3 m and bearing 20 deg instead of 10 deg of assumed noise, so the filter trusts ranges too much and bearings too little."),
    origin=("public code: PythonRobotics SLAM/EKFSLAM/ekf_slam.py, calc_innovation() "
            "(S = H @ PEst @ H.T + Cx[0:2, 0:2])"),
    replacement=_state_block_as_measurement_noise,
    examples=(UnitExample(_ex_innovation, "range and bearing noise swapped for the control noise"),),
)


def _variance_as_standard_deviation(original):
    """Control noise scaled by the variances std_v^2, std_omega^2 where the deviations belong."""

    def sample_controls(u, n, rng, config):
        squared = dataclasses.replace(config, std_v=config.std_v ** 2, std_omega=config.std_omega ** 2)
        return original(u, n, rng, squared)

    return sample_controls


CONTROL_NOISE_FROM_COVARIANCE = Fault(
    name="control_noise_from_covariance",
    step="sample_controls",
    description="Control noise is scaled by the variances (the covariance's diagonal) instead of the deviations.",
    rationale=(
        "Noise matrices are written as covariances, diag(sigma)^2, and sampling needs their square root. "
        "PythonRobotics' FastSLAM 1.0 example perturbs each particle's control with randn(1, 2) @ R where R "
        "is the covariance diag(1.0, 20 deg)^2: the spread is sigma^2 instead of sigma. With faultlab's "
        "noise (0.1 m, 20 deg per step) the particles spread by 1 cm and 7 deg, a tenth and a third of "
        "what they should, so the filter is over-confident in its motion; for a deviation of 0 or 1 the "
        "mistake is invisible."),
    origin=("public code: PythonRobotics SLAM/FastSLAM1/fast_slam1.py, predict_particles() "
            "(ud = u + (np.random.randn(1, 2) @ R).T with R a covariance)"),
    replacement=_variance_as_standard_deviation,
    examples=(UnitExample(_ex_sample_controls, "the spread of each control shrinks to its square"),),
)


#: The paper's three faults (Sec. VII-A), in Table II order.
PAPER_FAULTS: tuple[Fault, ...] = (NAIVE_RESAMPLING, MISSING_ANGLE_WRAP, MOTION_SIGN_ERROR)

#: Every built-in fault, the paper's three first.
BUILTIN_FAULTS: tuple[Fault, ...] = PAPER_FAULTS + (
    SHALLOW_COPY_RESAMPLING,
    GAIN_FROM_WRONG_COVARIANCE,
    WEIGHT_OVERWRITTEN,
    INIT_COVARIANCE_NOT_INVERTED,
    BEARING_IN_DEGREES,
    JACOBIAN_SIGN_ERROR,
    SHARED_CONTROL_NOISE,
    INVERTED_RESAMPLING_THRESHOLD,
    FROZEN_LANDMARK_COVARIANCE,
    NEW_LANDMARK_NEAR_ZERO,
    LIKELIHOOD_WITHOUT_NORMALISER,
    TURN_BEFORE_DRIVE,
    RESAMPLE_KEEPS_WEIGHTS,
    PAPER_ALIASING,
    MEASUREMENT_NOISE_FROM_STATE_COVARIANCE,
    CONTROL_NOISE_FROM_COVARIANCE,
)
