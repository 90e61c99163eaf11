import numpy as np
import pandas as pd
import pytest
from scipy.optimize import minimize

from faultlab.errors import ResultsError
from faultlab.stats import format_effects, parameter_effects
from tests.stats.synthetic import frame, job


def logistic_results(n=300, seed=0):
    """Detection odds grow with map_size, fall with landmark_density; loop traversal helps."""
    rng = np.random.default_rng(seed)
    size = rng.uniform(16, 400, n)
    density = rng.uniform(0.5, 10, n)
    loop = rng.random(n) < 0.5
    zs, zd = (size - size.mean()) / size.std(), (density - density.mean()) / density.std()
    logit = -0.3 + 1.2 * zs - 0.8 * zd + 1.0 * loop
    hit = rng.random(n) < 1 / (1 + np.exp(-logit))
    rows = []
    for i in range(n):
        vals = {"map_size": size[i], "landmark_density": density[i],
                "directionality": "loop" if loop[i] else "random"}
        rows.append(job(1, "random", i + 1, "baseline", 0, 100.0, **vals))
        rows.append(job(1, "random", i + 1, "naive_resampling", 0, 2000.0 if hit[i] else 100.0, **vals))
    return frame(rows), np.c_[zs, zd, loop.astype(float)], hit.astype(float)


def test_odds_ratios_match_maximum_likelihood_by_scipy():
    res, X, y = logistic_results()
    table = parameter_effects(res)
    fitted = table[table["coef"].notna()].set_index("term")
    assert list(fitted.index) == ["map_size", "landmark_density", "directionality[loop]"]
    # Independent reference: minimise the logistic negative log-likelihood directly.
    A = np.c_[np.ones(len(y)), X]

    def nll(beta):
        eta = A @ beta
        return np.sum(np.logaddexp(0, eta) - y * eta)

    beta = minimize(nll, np.zeros(4), method="BFGS", options={"gtol": 1e-10}).x
    np.testing.assert_allclose(fitted["coef"].to_numpy(), beta[1:], rtol=1e-4, atol=1e-6)
    np.testing.assert_allclose(fitted["odds_ratio"], np.exp(fitted["coef"]))
    assert fitted.loc["map_size", "or_low"] > 1 and fitted.loc["landmark_density", "or_high"] < 1
    # every other parameter is constant in these results -> one note row each
    notes = table[table["coef"].isna()]
    assert "rotation_error" in set(notes["term"]) and set(notes["note"]) == {"constant in these jobs; dropped"}
    assert (table["n"] == 300).all() and (table["n_detected"] == int(y.sum())).all()


def test_perfect_separation_is_reported_not_raised():
    rows = []
    for i, size in enumerate([16.0, 32.0, 48.0, 64.0, 200.0, 300.0, 400.0, 500.0]):
        rows.append(job(1, "fixed", i + 1, "baseline", 0, 100.0, map_size=size))
        rows.append(job(1, "fixed", i + 1, "missing_angle_wrap", 0, 900.0 if size > 100 else 100.0,
                        map_size=size))
    table = parameter_effects(frame(rows))
    model = table[table["term"] == "(model)"]
    assert len(model) == 1 and "perfect separation" in model["note"].iloc[0]
    assert table["coef"].isna().all()


def test_constant_outcome_and_too_few_jobs():
    rows = [job(1, "fixed", c, v, 0, 100.0 if v == "baseline" else 900.0, map_size=16.0 * c)
            for c in (1, 2, 3) for v in ("baseline", "F")]
    table = parameter_effects(frame(rows))
    assert "every judged job detected" in table.loc[table["term"] == "(model)", "note"].iloc[0]
    rows = [job(1, "fixed", c, v, 0, 100.0 if v == "baseline" or c == 2 else 900.0,
                map_size=16.0 * c, landmark_density=c ** 2, step_size=c ** 0.5)
            for c in (1, 2, 3, 4) for v in ("baseline", "F")]
    table = parameter_effects(frame(rows))
    assert "4 jobs for 4 coefficients" in table.loc[table["term"] == "(model)", "note"].iloc[0]


def test_collinear_parameters_are_reported():
    rng = np.random.default_rng(3)
    rows = []
    for c in range(1, 41):
        size = rng.uniform(16, 400)
        rows.append(job(1, "random", c, "baseline", 0, 100.0, map_size=size, step_size=size / 4))
        rows.append(job(1, "random", c, "F", 0, 900.0 if rng.random() < 0.5 else 100.0, map_size=size,
                        step_size=size / 4))
    table = parameter_effects(frame(rows))
    assert "rank-deficient" in table.loc[table["term"] == "(model)", "note"].iloc[0]


def test_clustered_reps_and_text_output():
    res, _, _ = logistic_results(n=120, seed=1)
    rep1 = res.copy()
    rep1["rep"] = 1
    table = parameter_effects(pd.concat([res, rep1], ignore_index=True))
    fitted = table[table["coef"].notna()]
    assert (fitted["note"] == "cluster-robust by case").all() and (fitted["n"] == 240).all()
    text = format_effects(table)
    assert "naive_resampling" in text and "map_size" in text and "cluster-robust" in text


def test_results_without_parameters_are_refused():
    res, _, _ = logistic_results(n=10)
    with pytest.raises(ResultsError, match="no scenario parameter columns"):
        parameter_effects(res[["run", "suite", "case", "variant", "rep", "rms_mm", "status"]])


def test_predictors_can_be_restricted():
    res, X, y = logistic_results(n=200, seed=2)
    table = parameter_effects(res, parameters=["map_size"])
    fitted = table[table["coef"].notna()]
    assert list(fitted["term"]) == ["map_size"] and table["coef"].notna().all()
    from faultlab.errors import ConfigError
    with pytest.raises(ConfigError, match="unknown parameter 'size'"):
        parameter_effects(res, parameters=["size"])
