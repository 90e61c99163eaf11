import math

import pytest

from faultlab.scenario import ScenarioConfig
from faultlab.space import FIXED_VALUES, CaseSpec


def test_from_case_converts_table1_units_to_si():
    v = dict(FIXED_VALUES, map_size=50.0, landmark_density=2.5, step_size=125.0, symmetry=40.0,
             outlier_probability=7.5, variance_distance=30.0, variance_angle=0.05, bias_distance=-12.0,
             bias_angle=0.03, rotation_error=-2 * math.pi, inactivity=2000, directionality="loop")
    c = ScenarioConfig.from_case(CaseSpec(v), n_steps=300, sensor_range=3.0, min_distance=0.2)
    assert c.map_side == pytest.approx(math.sqrt(50.0))
    assert c.n_landmarks == 125
    assert c.step == pytest.approx(1.25) and c.symmetry == pytest.approx(0.4)
    assert c.outlier_probability == pytest.approx(0.075)
    assert c.std_distance == pytest.approx(0.03) and c.std_angle == 0.05
    assert c.bias_distance == pytest.approx(-0.012) and c.bias_angle == 0.03
    assert c.rotation_error == -2 * math.pi and c.inactivity == 2000 and c.loop
    assert (c.n_steps, c.sensor_range, c.min_distance) == (300, 3.0, 0.2)


def test_landmark_count_rounds_down():
    c = ScenarioConfig.from_case(CaseSpec(dict(FIXED_VALUES, map_size=10.0, landmark_density=2.99)))
    assert c.n_landmarks == 29
    c = ScenarioConfig.from_case(CaseSpec(dict(FIXED_VALUES, map_size=0.3, landmark_density=10.0)))
    assert c.n_landmarks == 3  # 0.3 x 10 = 2.9999999999999996 in floating point; the tolerance keeps 3
