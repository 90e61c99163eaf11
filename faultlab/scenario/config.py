"""SI-unit generation settings of one scenario, derived from a :class:`CaseSpec`."""

from __future__ import annotations

import math
from dataclasses import dataclass

from faultlab.space.case import CaseSpec
from faultlab.vocabulary import PAPER_PROTOCOL

__all__ = ["ScenarioConfig", "DEFAULT_N_STEPS", "DEFAULT_SENSOR_RANGE", "DEFAULT_MIN_DISTANCE"]

DEFAULT_N_STEPS: int = PAPER_PROTOCOL["n_steps"]
DEFAULT_SENSOR_RANGE = 2.0  # m
DEFAULT_MIN_DISTANCE = 0.1  # m, Sec. VI-A: draws closer than this to another landmark are rejected


@dataclass(frozen=True)
class ScenarioConfig:
    """Everything the generator needs, in SI units (m, rad, fractions).

    Attributes
    ----------
    map_side : float
        Side of the square map centred on the origin, m (sqrt of map size).
    n_landmarks : int
        floor(map size x density).
    symmetry : float
        Share of landmarks placed in mirrored pairs, in [0, 1).
    step : float
        Forward distance per step, m.
    fov : float
        Full opening angle of the sensor, rad; visible iff |bearing| <= fov / 2.
    sensor_range : float
        Maximum range, m.
    std_distance, std_angle : float
        Gaussian noise std on range and forward motion (m), bearing and turn (rad).
    bias_distance, bias_angle : float
        Bias added to range and forward motion (m), bearing and turn (rad).
    outlier_probability : float
        Probability that an observation is an outlier, in [0, 1].
    rotation_error : float
        Offset (a multiple of 2 pi, rad) added to every bearing and every turn.
    inactivity : int
        Number of idle steps (zero control, no observation) inserted in the middle.
    loop : bool
        True for the *loop* directionality class (targets in polar-angle order).
    n_steps : int
        Active steps of the trace (inactivity comes on top).
    min_distance : float
        Minimum distance between two landmarks, m.
    fov_bug : bool
        Reproduce the replication package's field-of-view *defect*: every right-side
        (negative) bearing is visible whatever the opening (see :mod:`faultlab.scenario.trace`).
        False by default.
    """

    map_side: float
    n_landmarks: int
    symmetry: float
    step: float
    fov: float
    sensor_range: float
    std_distance: float
    std_angle: float
    bias_distance: float
    bias_angle: float
    outlier_probability: float
    rotation_error: float
    inactivity: int
    loop: bool
    n_steps: int = DEFAULT_N_STEPS
    min_distance: float = DEFAULT_MIN_DISTANCE
    fov_bug: bool = False

    @classmethod
    def from_case(
        cls,
        case: CaseSpec,
        *,
        n_steps: int = DEFAULT_N_STEPS,
        sensor_range: float = DEFAULT_SENSOR_RANGE,
        min_distance: float = DEFAULT_MIN_DISTANCE,
        fov_bug: bool = False,
    ) -> "ScenarioConfig":
        """Convert Table I units (m², lm/m², cm, %, mm, rad) to SI."""
        v = case.values
        size = float(v["map_size"])
        return cls(
            map_side=math.sqrt(size),
            n_landmarks=int(math.floor(size * float(v["landmark_density"]) + 1e-9)),
            symmetry=float(v["symmetry"]) / 100.0,
            step=float(v["step_size"]) / 100.0,
            fov=float(v["field_of_view"]),
            sensor_range=float(sensor_range),
            std_distance=float(v["variance_distance"]) / 1000.0,
            std_angle=float(v["variance_angle"]),
            bias_distance=float(v["bias_distance"]) / 1000.0,
            bias_angle=float(v["bias_angle"]),
            outlier_probability=float(v["outlier_probability"]) / 100.0,
            rotation_error=float(v["rotation_error"]),
            inactivity=int(v["inactivity"]),
            loop=str(v["directionality"]) == "loop",
            n_steps=int(n_steps),
            min_distance=float(min_distance),
            fov_bug=bool(fov_bug),
        )
