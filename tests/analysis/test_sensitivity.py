"""The regression view of an effects study against statsmodels, and partial dependence on a planted slope."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import statsmodels.api as sm

from faultlab.analysis.sensitivity import partial_dependence, regression_view


def test_regression_view_equals_statsmodels_cluster_ols_on_standardised_columns():
    rng = np.random.default_rng(3)
    n, k = 40, 4
    cases = pd.DataFrame({"run": 1, "suite": "sobol", "case": np.arange(1, n + 1),
                          "map_size": rng.uniform(4, 400, n), "bias_distance": rng.uniform(-25, 25, n),
                          "directionality": rng.choice(["random", "loop"], n), "symmetry": 5.0})
    reps = cases.loc[cases.index.repeat(k), ["run", "suite", "case", "map_size", "bias_distance"]]
    reps["value"] = 0.01 * reps["map_size"] + rng.normal(0, 0.5, len(reps))
    t = regression_view(reps, cases, factors=["map_size", "bias", "directionality", "symmetry"]).set_index("parameter")
    z = (reps["map_size"] - cases["map_size"].mean()) / cases["map_size"].std(ddof=0)
    zb = (reps["bias_distance"] - cases["bias_distance"].mean()) / cases["bias_distance"].std(ddof=0)
    dd = cases.set_index("case").loc[reps["case"], "directionality"].eq("loop").astype(float).to_numpy()
    zd = (dd - dd.mean()) / dd.std()
    X = sm.add_constant(np.column_stack([z, zb, zd]))
    ref = sm.OLS(reps["value"].to_numpy(), X).fit(cov_type="cluster", cov_kwds={"groups": reps["case"].to_numpy()})
    assert t.loc["map_size", "coef"] == pytest.approx(ref.params[1])
    assert t.loc["map_size", "std_err"] == pytest.approx(ref.bse[1])
    assert np.isnan(t.loc["symmetry", "coef"])  # constant: not estimable


def test_partial_dependence_bins_follow_the_planted_slope():
    rng = np.random.default_rng(9)
    x = pd.Series(rng.uniform(0, 10, 2000))
    pd_ = partial_dependence(x, 2 * x + rng.normal(0, 0.1, 2000), bins=5)
    assert len(pd_) == 5
    np.testing.assert_allclose(pd_["mean"], 2 * pd_["x"], atol=0.05)
