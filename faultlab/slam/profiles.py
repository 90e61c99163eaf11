"""Profiles of the reference FastSLAM 1.0: a configuration plus a choice of units, as data.

``reference`` is faultlab's FastSLAM 1.0 (Probabilistic Robotics, Table 13.1; see
:mod:`faultlab.slam.fastslam`).  ``paper`` is the FastSLAM 1.0 the paper tested (Sec. VII-A):
PythonRobotics' ``SLAM/FastSLAM1/fast_slam1.py`` as modified in the paper's replication package
(``slam/slam_correct.py``, ``slam/fastslam.py``), reproduced point by point as far as each point
is meaningful in faultlab's architecture, so that fault magnitudes can be compared with the paper's
Table II.  ``paper_no_aliasing`` is ``paper`` with deep copies at resampling: the paper's baseline
shares landmark arrays between resampled particles, a defect every faulty variant inherits.

``paper`` runs the shallow-copy aliasing exactly (:mod:`faultlab.slam.sharing`), which loops over the
particles that share a map: about 40 times slower than ``reference`` on a fixed-suite case;
``paper_no_aliasing`` runs at the reference's speed.

Every profile carries its ``differences`` from the paper's filter, one :class:`Difference` row per
point (the table of ``docs/explanation/paper-fidelity.md`` is generated from them with
:func:`differences_markdown`).

>>> from faultlab.slam.profiles import get_profile
>>> slam = get_profile("paper").slam()          # a FastSlam; faults apply to it as to the reference
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import partial
from typing import NamedTuple

from faultlab.errors import ConfigError
from faultlab.slam import paperunits
from faultlab.slam import units as U
from faultlab.slam.fastslam import REFERENCE_STEPS, FastSlam, FastSlamConfig, FastSlamSteps
from faultlab.vocabulary import PAPER_PROTOCOL

__all__ = ["DEFAULT_PROFILE", "Difference", "Profile", "PROFILES", "get_profile", "profile_names", "differences_markdown",
           "PAPER_LENGTH_UNIT", "PAPER_CONFIG", "PAPER_STEPS", "PAPER_NO_ALIASING_STEPS", "Ablation", "Arm",
           "ABLATIONS", "ABLATION_PROFILES", "ablation_arms"]


class Difference(NamedTuple):
    """One point where a profile and the paper's filter are compared.

    Attributes
    ----------
    point : str
        What is compared.
    paper : str
        The paper's choice (replication package, commit 8c0a75d).
    faultlab : str
        This profile's choice (unit or setting), or why it is not reproduced.
    why : str
        Why it matters for map errors and fault magnitudes.
    """

    point: str
    paper: str
    faultlab: str
    why: str


@dataclass(frozen=True)
class Profile:
    """A named FastSLAM configuration with its units.

    Attributes
    ----------
    name : str
    config : FastSlamConfig
    steps : FastSlamSteps
    description : str
        One line.
    differences : tuple of Difference
        Point-by-point comparison with the paper's filter.
    """

    name: str
    config: FastSlamConfig
    steps: FastSlamSteps
    description: str
    differences: tuple[Difference, ...] = field(default=(), repr=False)

    def slam(self) -> FastSlam:
        """A new FastSlam with this profile's configuration and units."""
        return FastSlam(self.config, steps=self.steps)


#: The length unit the paper's filter computes in, m.  The replication package's maps, ranges and
#: drives are integer millimetres (generate_testcase.py: map bounds map_size * +-500, SENSOR_RANGE = 2000,
#: 800 per step for Table I's 80 cm) and its adapter (slam/fastslam.py) divides them by 100, so one filter
#: unit is 0.1 m; its output map (x 100, rounded) is whole millimetres again.
PAPER_LENGTH_UNIT = 0.1

#: The paper's filter settings in SI: 200 particles; Q = diag(3.0, 10 deg)^2 and R = diag(1.0, 20 deg)^2 in
#: filter units are diag(0.3 m, 10 deg)^2 and diag(0.1 m, 20 deg)^2; resampling when N_eff < N / 1.5.
PAPER_CONFIG = FastSlamConfig(particles=PAPER_PROTOCOL["particles"], std_v=1.0 * PAPER_LENGTH_UNIT, std_omega=math.radians(20.0),
                              std_range=3.0 * PAPER_LENGTH_UNIT, std_bearing=math.radians(10.0),
                              resample_ratio=1.5)

#: The paper's units, deep copies at resampling (every particle keeps its own landmarks).
PAPER_NO_ALIASING_STEPS = FastSlamSteps(
    classify_new=partial(paperunits.classify_new_near_zero_x, tolerance=0.01 * PAPER_LENGTH_UNIT),
    predict_measurement=paperunits.predict_measurement_wrapped,
    log_likelihood=paperunits.log_likelihood_wrapped,
    combine_weights=partial(paperunits.combine_weights_linear, length_unit=PAPER_LENGTH_UNIT),
    resample=paperunits.resample_stratified,
    extract_map=partial(paperunits.extract_map_closest_to_mean, resolution=0.001),
)

#: The paper's units as it ran them: resampled particles share landmark arrays.
PAPER_STEPS = FastSlamSteps(**{**{name: getattr(PAPER_NO_ALIASING_STEPS, name)
                                  for name in FastSlamSteps.unit_names()},
                               "apply_resample": paperunits.apply_resample_aliased})


def _rows(*rows: tuple[str, str, str, str]) -> tuple[Difference, ...]:
    return tuple(Difference(*r) for r in rows)


_FILTER_NOISE_WHY = ("sets how far the particles spread per step and how sharply observations weigh them; "
                     "read in metres the paper's numbers would be 10 times too large")
_PARTICLES = ("particles, resampling threshold", "N_PARTICLE = 200; resample when n_eff < N / 1.5",
              "particles = 200, resample_ratio = 1.5", "same")
_LENGTH_UNIT = ("length unit", "0.1 m: maps, ranges and drives are integer mm, the adapter divides them by 100",
                "SI (m); the unit-dependent constants are converted (noise, new-landmark tolerance, weight "
                "underflow, output rounding)", "a constant read in the wrong unit is off by a factor of 10")
_IDLE = ("idle steps", "u == 0 gets no motion noise; no resampling when u == 0 and there is no observation",
         "an empty update (u == 0 and no observation) gets no motion noise and never resamples; a zero control "
         "with observations would get noise, which generated scenarios never contain",
         "the same in generated scenarios: an inactivity phase changes nothing in the correct filter")
_RANDOMNESS = ("random numbers", "numpy's global generator (np.random.randn, np.random.rand); naive "
               "resampling uses Python's random.random()",
               "numpy Generators derived from the job's SeedSequence",
               "same distributions, different draws: single runs are not comparable draw by draw")
_ALGEBRA = ("2 x 2 algebra", "np.linalg.inv / det for S, a Cholesky-based Kalman update",
            "closed-form 2 x 2 formulas (faultlab.slam.units)", "equal up to rounding")
_UNOBSERVED = ("unobserved landmarks", "stay at (0, 0) in the output map and enter the RMS",
               "not reproduced: the adapter protocol returns only mapped landmarks and the metric drops "
               "unmapped ones (MapErrors.n_unmapped counts them)",
               "a case that leaves landmarks unobserved gets a larger RMS in the paper")
_FOV = ("field of view (scenario)", "min(angle, 2 pi - angle) < sensor_fov with angle in [-pi, pi) and "
        "sensor_fov the half opening: every right-side (negative) bearing passes, the left side is limited "
        "to the half opening",
        "the scenario option fov_bug = True reproduces it (generate_scenario(..., fov_bug=True)); off by "
        "default: |bearing| <= opening / 2",
        "with the defect three quarters of the circle are visible at the fixed suite's opening pi; bearings "
        "near +-pi, where a missing wrap bites, become common")
_BEARING_NOISE = ("noisy bearing (scenario)", "wrapped to [-pi, pi) after the noise, then the rotation "
                  "error k 2 pi is added",
                  "not reproduced: noise and rotation error are added to the wrapped true bearing, the sum "
                  "is not wrapped",
                  "a bearing near +-pi can leave [-pi, pi) by its noise in faultlab; in the paper it "
                  "flips to the other end instead: the same direction, a different unwrapped innovation")
_FIRST_STEP = ("first step (scenario)",
               "an observation from the start pose with zero odometry before the first move",
               "none: the first step moves, then observes", "the map starts from one more sighting")
_ODOMETRY = ("odometry noise (scenario)", "the measured odometry is the commanded motion; the true motion is the "
             "command plus noise", "the true motion is the command plus a small path perturbation; the measured "
             "control is the true one plus noise", "the same error model up to which side carries the noise")
_RANGE_NOISE = ("range noise (scenario)", "Gaussian redrawn while negative; a negative biased mean becomes "
                "dist / 2", "max(0, dist + bias + noise)", "only matters for ranges near 0")
_MOTION_INPUT = ("motion input", "odometry (turn1, drive, turn2) passed as [drive, pi_2_pi(turn2)]",
                 "the control (v, omega), omega with the rotation error, unwrapped",
                 "none: the motion model wraps the heading and sin/cos see the old heading")
_ROTATION_FAULT = ("faulty rotation fault", "removes the innovation wrap in update_landmark (and the wrap of "
                   "yaw + bearing before sin/cos at initialisation)",
                   "missing_angle_wrap replaces wrap_bearing: the innovation (EKF and weights alike, unless "
                   "the weight unit wraps on its own) and yaw + bearing at initialisation",
                   "the initialisation wrap changes nothing (sin and cos are periodic)")

#: The last rows of every profile's table: differences that do not depend on the profile's units.
_COMMON_TAIL = (_ALGEBRA, _RANDOMNESS, _MOTION_INPUT, _ROTATION_FAULT, _FOV, _BEARING_NOISE, _RANGE_NOISE,
                _FIRST_STEP, _ODOMETRY)


_PAPER_ROWS = _rows(
    _PARTICLES,
    _LENGTH_UNIT,
    ("filter noise", "Q = diag(3.0, 10 deg)^2 (measurement), R = diag(1.0, 20 deg)^2 (motion), in 0.1 m units",
     "std_range = 0.3 m, std_bearing = 10 deg, std_v = 0.1 m, std_omega = 20 deg", _FILTER_NOISE_WHY),
    _IDLE,
    ("predicted bearing", "wrapped: pi_2_pi(atan2(dy, dx) - yaw) in compute_jacobians",
     "predict_measurement_wrapped (its own wrap to [-pi, pi), not wrap_bearing)",
     "with the innovation wrap removed the prediction stays in [-pi, pi): only innovations across the "
     "+-pi cut or with a rotation error of 2 pi go wrong"),
    ("innovation wraps", "in update_landmark (EKF) and again in compute_weight (weights)",
     "innovation (EKF, via wrap_bearing) and log_likelihood_wrapped (weights, its own wrap)",
     "missing_angle_wrap then removes the EKF wrap only and the weights keep theirs, as in the paper"),
    ("new landmark", "new while abs(lm[id, 0]) <= 0.01 (1 mm)", "classify_new_near_zero_x, tolerance 1 mm",
     "a landmark estimated within 1 mm of x = 0 is initialised again at every sighting (rare)"),
    ("weights", "linear: exp(-0.5 dx' S^-1 dx) / (2 pi sqrt|S|) multiplied per observation; a zero sum "
     "resets every weight to 1 / N", "combine_weights_linear (the product in observation order, in the "
     "linear domain, densities per 0.1 m; all zero -> uniform)",
     "large innovations underflow to 0 and reset the weights, which damps a fault"),
    ("resampling draws", "base + rand(N) / N: stratified (its docstring says low variance)",
     "resample_stratified", "slightly more resampling noise than one shared uniform"),
    ("resampling copies", "tmp = particles[:] and views lm[:, :]: copies read already overwritten slots and "
     "share landmark arrays for good; later updates of a shared landmark run once per sharer, one after "
     "another", "apply_resample_aliased with sequential sharers (faultlab.slam.sharing); the profile "
     "paper_no_aliasing uses deep copies",
     "the paper's correct variant has this defect and all its faulty variants inherit it: every sharer "
     "re-applies the observation and the landmark covariance shrinks once per sharer"),
    ("map output", "the map of the particle minimising distance_to_mean * weight, rounded to whole mm",
     "extract_map_closest_to_mean, resolution 1 mm", "not the best particle; rounding adds up to 0.7 mm"),
    _UNOBSERVED,
    ("estimated pose", "the weighted mean of the particles (not used by the metric)",
     "the highest-weight particle's pose (FastSlam.estimate)", "none for map errors"),
    *_COMMON_TAIL,
)


def _without_aliasing(rows: tuple[Difference, ...]) -> tuple[Difference, ...]:
    out = []
    for r in rows:
        if r.point == "resampling copies":
            r = r._replace(faultlab="deep copies (the reference apply_resample); the profile paper has the "
                                    "aliasing", why="this profile removes a defect of the paper's baseline: "
                                                    "its map errors are those of a repaired filter")
        out.append(r)
    return tuple(out)


_REFERENCE_ROWS = _rows(
    _PARTICLES,
    _LENGTH_UNIT,
    ("filter noise", "Q = diag(3.0, 10 deg)^2 (measurement), R = diag(1.0, 20 deg)^2 (motion), in 0.1 m units",
     "std_range = 0.3 m, std_bearing = 10 deg, std_v = 0.1 m, std_omega = 20 deg: the same",
     _FILTER_NOISE_WHY),
    _IDLE,
    ("predicted bearing", "wrapped: pi_2_pi(atan2(dy, dx) - yaw)", "not wrapped (predict_measurement)",
     "without the innovation wrap every update whose predicted bearing leaves [-pi, pi) goes wrong, not only "
     "those near +-pi"),
    ("innovation wraps", "in update_landmark (EKF) and again in compute_weight (weights)",
     "once (innovation, via wrap_bearing), shared by the EKF update and the weights",
     "missing_angle_wrap removes both: the weights see 2 pi innovations too"),
    ("new landmark", "new while abs(lm[id, 0]) <= 0.01 (1 mm)", "new if the id was never observed (classify_new)",
     "no re-initialisation near x = 0"),
    ("weights", "linear, multiplied per observation; a zero sum resets every weight to 1 / N",
     "normalised log weights (combine_weights), no reset",
     "no underflow: a fault with huge innovations keeps steering the weights"),
    ("resampling draws", "stratified (N uniforms)", "low variance (one uniform, low_variance_indices)",
     "slightly less resampling noise"),
    ("resampling copies", "shallow copies that share landmark arrays (see the paper profile)",
     "deep copies (copy-on-write storage)", "the reference is a repaired filter"),
    ("map output", "the particle minimising distance_to_mean * weight, rounded to whole mm",
     "the highest-weight particle, not rounded (extract_map)", "another particle's map"),
    _UNOBSERVED,
    *_COMMON_TAIL,
)

#: The profile a ``[slam] name = "fastslam"`` table without ``profile`` gets.
DEFAULT_PROFILE = "reference"

#: The profiles by name.
PROFILES: dict[str, Profile] = {
    "reference": Profile(
        name="reference", config=FastSlamConfig(), steps=REFERENCE_STEPS,
        description="faultlab's FastSLAM 1.0 (Probabilistic Robotics Table 13.1), repaired and vectorised",
        differences=_REFERENCE_ROWS),
    "paper": Profile(
        name="paper", config=PAPER_CONFIG, steps=PAPER_STEPS,
        description="the paper's FastSLAM 1.0 (PythonRobotics, replication package) as it ran, shallow-copy "
                    "aliasing included",
        differences=_PAPER_ROWS),
    "paper_no_aliasing": Profile(
        name="paper_no_aliasing", config=PAPER_CONFIG, steps=PAPER_NO_ALIASING_STEPS,
        description="the paper's FastSLAM 1.0 with deep copies at resampling (its aliasing defect repaired)",
        differences=_without_aliasing(_PAPER_ROWS)),
}


def _one_change(name: str, description: str, **units) -> Profile:
    """``paper_no_aliasing`` with some units replaced (an arm of :data:`ABLATIONS`)."""
    base = PROFILES["paper_no_aliasing"]
    return Profile(name=name, config=base.config, steps=replace(base.steps, **units), description=description,
                   differences=base.differences)


#: Profiles that differ from ``paper_no_aliasing`` in one point only, for :data:`ABLATIONS`.  They are
#: resolved by :func:`get_profile` (so an experiment can name them) but are not listed by
#: :func:`profile_names`: they exist to isolate one row of the paper profile's differences.
ABLATION_PROFILES: dict[str, Profile] = {p.name: p for p in (
    _one_change("paper_no_aliasing_log_weights",
                "paper_no_aliasing with the reference's normalised log weights (no underflow, no reset)",
                combine_weights=U.combine_weights),
    _one_change("paper_no_aliasing_low_variance",
                "paper_no_aliasing with the reference's low-variance resampling (one uniform)",
                resample=U.resample),
    _one_change("paper_no_aliasing_best_particle_map",
                "paper_no_aliasing returning the highest-weight particle's map, not rounded",
                extract_map=U.extract_map),
    _one_change("paper_no_aliasing_new_by_id",
                "paper_no_aliasing classifying a landmark as new only at its first sighting",
                classify_new=U.classify_new),
    _one_change("paper_no_aliasing_unwrapped_prediction",
                "paper_no_aliasing without the wrap of the predicted bearing",
                predict_measurement=U.predict_measurement),
    _one_change("paper_no_aliasing_single_wrap",
                "paper_no_aliasing whose weights use the (fault-replaceable) innovation wrap only",
                log_likelihood=U.log_likelihood),
)}


class Arm(NamedTuple):
    """One configuration an ablation runs: a profile and the scenarios' field-of-view defect."""

    profile: str
    fov_bug: bool = True

    @property
    def name(self) -> str:
        """A name for files and tables: the profile, ``-fov-off`` appended without the defect."""
        return self.profile + ("" if self.fov_bug else "-fov-off")


@dataclass(frozen=True)
class Ablation:
    """One row of the paper profile's differences isolated: the paper's choice against one alternative.

    Both arms run the same cases with the same seeds; they differ in ``point`` only.

    Attributes
    ----------
    point : str
        The :class:`Difference` row (its ``point``) whose effect is shown.
    paper : Arm
        The arm with the paper's choice.
    alternative : Arm
        The arm with faultlab's reference choice instead.
    change : str
        What the alternative changes, one line.
    """

    point: str
    paper: Arm
    alternative: Arm
    change: str


_BASE = Arm("paper_no_aliasing")

#: The rows of the ``paper`` profile's differences whose effect one change can isolate.  Every other row
#: is either not reproduced, not a choice of the filter (units, algebra, random streams) or part of the
#: scenario generator with no switch.
ABLATIONS: tuple[Ablation, ...] = (
    Ablation("resampling copies", Arm("paper"), _BASE,
             "deep copies at resampling (paper_no_aliasing) instead of the shallow-copy aliasing"),
    Ablation("weights", _BASE, Arm("paper_no_aliasing_log_weights"),
             "normalised log weights instead of the linear product with its reset to uniform"),
    Ablation("resampling draws", _BASE, Arm("paper_no_aliasing_low_variance"),
             "low-variance (one uniform) instead of stratified resampling"),
    Ablation("map output", _BASE, Arm("paper_no_aliasing_best_particle_map"),
             "the highest-weight particle's map, unrounded, instead of the particle closest to the mean "
             "rounded to mm"),
    Ablation("new landmark", _BASE, Arm("paper_no_aliasing_new_by_id"),
             "new at the first sighting only instead of while |x| <= 1 mm"),
    Ablation("predicted bearing", _BASE, Arm("paper_no_aliasing_unwrapped_prediction"),
             "the predicted bearing left unwrapped"),
    Ablation("innovation wraps", _BASE, Arm("paper_no_aliasing_single_wrap"),
             "one innovation wrap shared by the EKF update and the weights (missing_angle_wrap removes both)"),
    Ablation("field of view (scenario)", _BASE, Arm("paper_no_aliasing", fov_bug=False),
             "scenarios without the field-of-view defect (|bearing| <= opening / 2)"),
)


def ablation_arms(ablations: tuple[Ablation, ...] = ABLATIONS) -> tuple[Arm, ...]:
    """Every arm the ablations need, once each, in order of first use."""
    arms: dict[Arm, None] = {}
    for a in ablations:
        arms.setdefault(a.paper)
        arms.setdefault(a.alternative)
    return tuple(arms)


def profile_names() -> tuple[str, ...]:
    """The names of the profiles, in registration order."""
    return tuple(PROFILES)


def get_profile(name: str) -> Profile:
    """The profile called ``name``.

    Raises
    ------
    ConfigError
        For an unknown name; the message lists the known names.
    """
    if isinstance(name, str) and name in PROFILES:
        return PROFILES[name]
    if isinstance(name, str) and name in ABLATION_PROFILES:
        return ABLATION_PROFILES[name]
    raise ConfigError(f"unknown FastSLAM profile {name!r}; known profiles: {', '.join(PROFILES)}")


def differences_markdown(profile: Profile | str) -> str:
    """The profile's differences from the paper's filter as a Markdown table."""
    p = get_profile(profile) if isinstance(profile, str) else profile

    def esc(text: str) -> str:
        return text.replace("|", "\\|")

    lines = [f"| point | the paper's filter | faultlab `{p.name}` | why it matters |", "|---|---|---|---|"]
    lines += [f"| {esc(r.point)} | {esc(r.paper)} | {esc(r.faultlab)} | {esc(r.why)} |" for r in p.differences]
    return "\n".join(lines)
