import json
import math

import pytest

from faultlab.errors import ScenarioError
from faultlab.space import FIXED_VALUES, PARAMETER_NAMES, VALUE_KEYS, CaseSpec


def test_names_and_keys():
    assert len(PARAMETER_NAMES) == 11 and len(VALUE_KEYS) == 13
    assert set(FIXED_VALUES) == set(VALUE_KEYS)
    # the replication package's defaults: 8 m side, 5 lm/m^2, 80 cm, FoV pi, 10 mm / 0.02 rad, 2 % outliers
    assert math.sqrt(FIXED_VALUES["map_size"]) == 8.0 and FIXED_VALUES["field_of_view"] == math.pi
    assert (FIXED_VALUES["variance_distance"], FIXED_VALUES["variance_angle"]) == (10.0, 0.02)


def test_case_round_trips_through_json():
    c = CaseSpec(dict(FIXED_VALUES), {"map_size": 1, "bias": 2})
    back = CaseSpec.from_dict(json.loads(json.dumps(c.to_dict())))
    assert back.values == c.values and back.classes == {"map_size": 1, "bias": 2}


def test_missing_values_are_rejected():
    v = dict(FIXED_VALUES)
    del v["bias_angle"]
    with pytest.raises(ScenarioError, match="bias_angle"):
        CaseSpec(v)
