"""faultlab.scenario: maps, sensor traces and observations (Sec. VI), test-case files."""

from faultlab.scenario.config import (
    DEFAULT_MIN_DISTANCE,
    DEFAULT_N_STEPS,
    DEFAULT_SENSOR_RANGE,
    ScenarioConfig,
)
from faultlab.scenario.files import SuiteFiles, cases_frame, write_suite
from faultlab.scenario.generator import GENERATOR_VERSION, fixed_case_scenario, generate_scenario
from faultlab.scenario.maps import generate_landmarks, n_symmetric_pairs
from faultlab.scenario.model import Scenario, load_scenario, save_scenario
from faultlab.scenario.suite import SuiteCase, draw_suite, generate_case
from faultlab.scenario.trace import (
    DEFAULT_PATH_TURN_STD,
    Drive,
    Measurements,
    drive,
    measure_controls,
    measure_observations,
    wrap_angle,
)

__all__ = [
    "Scenario",
    "save_scenario",
    "load_scenario",
    "ScenarioConfig",
    "DEFAULT_N_STEPS",
    "DEFAULT_SENSOR_RANGE",
    "DEFAULT_MIN_DISTANCE",
    "DEFAULT_PATH_TURN_STD",
    "GENERATOR_VERSION",
    "generate_scenario",
    "fixed_case_scenario",
    "generate_landmarks",
    "n_symmetric_pairs",
    "Drive",
    "Measurements",
    "drive",
    "measure_controls",
    "measure_observations",
    "wrap_angle",
    "SuiteFiles",
    "write_suite",
    "SuiteCase",
    "draw_suite",
    "generate_case",
    "cases_frame",
]
