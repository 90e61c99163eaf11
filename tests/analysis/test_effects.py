"""Effect-guided class weights from an effects study, on a planted study whose answer is known."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from faultlab.analysis.effects import EffectsAnalysis, study_weights
from faultlab.errors import ResultsError
from faultlab.space import table1_space
from faultlab.space.settings import weights_from_effects


def _study() -> EffectsAnalysis:
    """map_size matters for fault f (ratio 1, 2, 4 by class), bias does not (ST interval reaches 0)."""
    rng = np.random.default_rng(0)
    n = 90
    cls_map = np.repeat([0, 1, 2], n // 3)
    cases = pd.DataFrame({"stage": "sobol", "run": 1, "suite": "sobol", "case": np.arange(1, n + 1),
                          "class_map_size": cls_map, "class_bias": rng.integers(0, 5, n),
                          "effect:f": np.log([1.0, 2.0, 4.0])[cls_map] + rng.normal(0, 0.01, n)})
    sobol = pd.DataFrame({"response": "effect:f", "parameter": ["map_size", "bias"], "ST": [0.9, 0.01],
                          "ST_low": [0.7, -0.02], "ST_high": [1.1, 0.04]})
    return EffectsAnalysis(responses=("effect:f",), morris=pd.DataFrame(), sobol=sobol, regression=pd.DataFrame(),
                           cases=cases, partial=pd.DataFrame())


def test_weights_follow_the_planted_class_ratios_of_influential_parameters_only():
    w = study_weights(_study(), "effect:f", floor=0.05)
    assert set(w["parameter"]) == {"map_size"}  # bias is not clear of 0: equal weights (unlisted)
    ref = weights_from_effects(pd.DataFrame({"parameter": "map_size", "class": ["small", "medium", "large"],
                                             "odds_ratio": [1.0, 2.0, 4.0]}), floor=0.05)
    np.testing.assert_allclose(w["weight"], ref["weight"], atol=2e-3)
    # the weights plug into an effect-guided suite
    table1_space().with_weights({p: dict(zip(g["class"], g["weight"])) for p, g in w.groupby("parameter")})


def test_unknown_response_is_one_clear_error():
    with pytest.raises(ResultsError, match="no response 'effect:g'"):
        study_weights(_study(), "effect:g")
