"""Class-indicator effects on the case verdicts: Firth under separation, LR tests with Holm, EPV."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from scipy.optimize import minimize
from scipy.stats import chi2

from faultlab.stats.class_effects import MIN_EPV, class_design, fit_class_effects


def _firth_by_hand(X, y):
    """Maximise loglik + 1/2 log det(X'WX) with scipy: an independent transcription of Firth (1993)."""
    Xc = np.c_[np.ones(len(y)), X]

    def neg(b):
        eta = Xc @ b
        p = 1 / (1 + np.exp(-eta))
        ll = np.sum(y * eta - np.logaddexp(0, eta))
        sign, logdet = np.linalg.slogdet((Xc * (p * (1 - p))[:, None]).T @ Xc)
        return -(ll + 0.5 * logdet)

    r = minimize(neg, np.zeros(Xc.shape[1]), method="BFGS", options={"gtol": 1e-9})
    return r.x, -r.fun


def _data(n_per=40, seed=0, separated=True):
    rng = np.random.default_rng(seed)
    rows = []
    for i in range(4 * n_per):
        size = i % 2                     # map-size class 0 / 1
        steps = (i // 2) % 2             # step-size class 0 / 1
        rot = rng.choice([-2 * math.pi, 0.0, 2 * math.pi])
        if separated:
            det = size == 1 and (steps == 1 or rng.random() < 0.5)  # never detected in class 0: separation
        else:
            det = rng.random() < (0.2 + 0.5 * size)
        rows.append({"suite": "random", "run": 1, "case": i + 1, "fault": "f",
                     "verdict": "detected" if det else "not_detected", "class_map_size": size,
                     "class_step_size": steps, "rotation_error": rot})
    df = pd.DataFrame(rows)
    return df[["suite", "run", "case", "fault", "verdict"]], df[["suite", "run", "case", "class_map_size",
                                                                 "class_step_size", "rotation_error"]]


def test_signed_rotation_error_enters_by_magnitude_with_the_first_class_as_reference():
    _, cases = _data(n_per=5)
    design, terms = class_design(cases, ["map_size", "rotation_error"])
    assert terms == {"map_size": ["map_size[class 1]"], "rotation_error": ["|rotation_error|[1x2pi]"]}
    np.testing.assert_array_equal(design["|rotation_error|[1x2pi]"], (cases["rotation_error"] != 0).astype(float))


def test_separation_is_fitted_by_firth_and_matches_a_brute_force_penalised_likelihood():
    verdicts, cases = _data()
    table = fit_class_effects(verdicts, cases, ["map_size", "step_size"])
    assert (table["method"] == "firth").all()
    y = verdicts["verdict"].eq("detected").to_numpy(float)
    X = np.c_[cases["class_map_size"], cases["class_step_size"]].astype(float)
    b, ll = _firth_by_hand(X, y)
    got = table.set_index("term")
    assert got.loc["map_size[class 1]", "coef"] == pytest.approx(b[1], abs=2e-3)
    assert got.loc["step_size[class 1]", "coef"] == pytest.approx(b[2], abs=2e-3)
    assert np.isfinite(got["coef"]).all()  # maximum likelihood would diverge
    # the LR test of map size: the penalised likelihood refitted without it
    _, ll0 = _firth_by_hand(X[:, [1]], y)
    lr = 2 * (ll - ll0)
    assert got.loc["map_size[class 1]", "lr_chi2"] == pytest.approx(lr, rel=1e-3)
    assert got.loc["map_size[class 1]", "p"] == pytest.approx(chi2.sf(lr, 1), rel=1e-2)
    # Holm over the fault's two parameters
    p = got["p"].to_numpy()
    assert got["p_holm"].max() == pytest.approx(min(1, max(p.max(), 2 * p.min())))


def test_without_separation_maximum_likelihood_is_used():
    verdicts, cases = _data(n_per=60, separated=False)
    table = fit_class_effects(verdicts, cases, ["map_size"])
    assert (table["method"] == "ml").all() and table["epv"].iloc[0] >= MIN_EPV


def test_too_few_events_per_predictor_is_said_instead_of_fitted():
    verdicts, cases = _data(n_per=5)
    table = fit_class_effects(verdicts, cases, ["map_size", "step_size", "rotation_error"])
    assert list(table["term"]) == ["(model)"]
    assert "too few data" in table["note"].iloc[0] and "events per predictor" in table["note"].iloc[0]
