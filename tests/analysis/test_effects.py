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


def test_a_response_the_sobol_stage_did_not_estimate_gets_no_weights_even_with_morris_rows():
    study = _study()
    cases = study.cases.assign(**{"effect:g": study.cases["effect:f"]})
    # Morris mu* of g is clear of 0 for map_size, but the Sobol stage (run: it has rows for f) has none for g
    morris = pd.DataFrame({"response": "effect:g", "parameter": ["map_size"], "mu_star": [0.5],
                           "mu_star_low": [0.3], "mu_star_high": [0.7]})
    both = EffectsAnalysis(responses=("effect:f", "effect:g"), morris=morris, sobol=study.sobol,
                           regression=pd.DataFrame(), cases=cases, partial=pd.DataFrame())
    assert study_weights(both, "effect:g").empty
    # without a Sobol stage the Morris screening decides
    screening_only = EffectsAnalysis(responses=("effect:f", "effect:g"), morris=morris, sobol=pd.DataFrame(),
                                     regression=pd.DataFrame(), cases=cases, partial=pd.DataFrame())
    assert set(study_weights(screening_only, "effect:g")["parameter"]) == {"map_size"}


def test_unknown_response_is_one_clear_error():
    with pytest.raises(ResultsError, match="no response 'effect:g'"):
        study_weights(_study(), "effect:g")


def test_campaign_effects_mean_over_cases_is_the_t_interval_of_the_per_case_log_ratios():
    from scipy import stats

    from faultlab.analysis.effects import campaign_effects

    rng = np.random.default_rng(4)
    rows = []
    n_cases, k = 8, 3
    ratios = np.exp(rng.normal(0.5, 0.3, (n_cases, k)))
    for c in range(n_cases):
        values = {"directionality": "random", "rotation_error": 0.0, "inactivity": 0, "map_size": 10.0 + c,
                  "landmark_density": 5.0, "step_size": 80.0, "symmetry": 0.0, "outlier_probability": 2.0,
                  "field_of_view": 3.0, "variance_distance": 10.0, "variance_angle": 0.02,
                  "bias_distance": 0.0, "bias_angle": 0.0}
        for r in range(k):
            base = 100.0 + 10 * r
            for variant, err in (("baseline", base), ("f", base * ratios[c, r])):
                rows.append({"run": 1, "suite": "random", "case": c + 1, "variant": variant, "rep": r,
                             "status": "ok", "rms_mm": err, **values})
    t = campaign_effects(pd.DataFrame(rows))
    mean = t[(t["response"] == "effect:f") & (t["term"] == "(mean over cases)")].iloc[0]
    per_case = np.log(ratios).mean(axis=1)
    lo, hi = stats.t.interval(0.95, n_cases - 1, loc=per_case.mean(), scale=stats.sem(per_case))
    assert mean["estimate"] == pytest.approx(per_case.mean())
    assert (mean["low"], mean["high"]) == pytest.approx((lo, hi))
    # one varying parameter: 2 coefficients, 8 cases: not fitted, the size it needs is stated (20)
    size = t[(t["response"] == "effect:f") & (t["term"] == "(size)")].iloc[0]
    assert np.isnan(size["estimate"]) and "needs about 20 cases" in size["note"]
    assert "map_size" not in set(t["term"])


def test_sobol_estimates_that_cannot_be_variance_shares_are_marked_as_noise():
    import pandas as pd

    from faultlab.analysis.effects import incoherent_indices

    t = pd.DataFrame({"S1": [0.2, 3.48, 0.1, 0.5, 0.0, float("nan")], "ST": [0.3, 0.32, -1.48, 0.4, 0.0, 0.2]})
    # coherent; S1 above 1; ST negative; S1 > ST; both zero (coherent); S1 not estimated (nothing to mark)
    assert list(incoherent_indices(t)) == ["", "yes", "yes", "yes", "", ""]
