"""Morris and Sobol indices on a planted response: a known function of two parameters plus noise."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from faultlab.errors import ResultsError
from faultlab.inference.screening import morris_indices, noise_floor, screen, sobol_indices
from faultlab.space import table1_space
from faultlab.space.design import morris_design, sobol_design

PLANTED = ("map_size", "bias")


def _table(indices) -> pd.DataFrame:
    """The indices as the table a caller builds from them."""
    return pd.DataFrame(indices.as_dict())


def _planted(unit: np.ndarray, factors, rng: np.random.Generator, noise: float = 0.05) -> np.ndarray:
    """y = 3 u_map + 2 sin(pi u_bias) + noise: two parameters matter, nine do not."""
    a = unit[:, factors.index("map_size")]
    b = unit[:, factors.index("bias")]
    return 3.0 * a + 2.0 * np.sin(np.pi * b) + rng.normal(0.0, noise, unit.shape[0])


def test_morris_ranks_the_planted_parameters_first():
    d = morris_design(table1_space(), rng=np.random.default_rng(1), trajectories=20)
    y = _planted(d.unit, d.factors, np.random.default_rng(2))
    indices = morris_indices(d.unit, y, factors=d.factors, levels=d.levels, seed=3)
    t = _table(indices)
    assert set(t["parameter"].head(2)) == set(PLANTED)
    # an inert parameter's mu* is the noise's: far below the planted ones
    assert t["mu_star"].iloc[2] < 0.2 * t["mu_star"].iloc[1]
    assert (t["mu_star_low"] <= t["mu_star"]).all() and (t["mu_star"] <= t["mu_star_high"]).all()
    assert screen([indices], keep=2) == ("map_size", "bias")
    assert list(t["rank"]) == list(range(1, len(d.factors) + 1)) and t["mu_star"].is_monotonic_decreasing


def test_morris_mu_star_matches_the_textbook_elementary_effects():
    """Noise-free linear response: every elementary effect of x_i is its slope, so mu* = |slope|."""
    d = morris_design(table1_space(), rng=np.random.default_rng(4), trajectories=6)
    slopes = np.arange(len(d.factors), dtype=float) - 5.0
    y = d.unit @ slopes
    t = _table(morris_indices(d.unit, y, factors=d.factors, levels=d.levels, seed=1)).set_index("parameter")
    np.testing.assert_allclose(t.loc[list(d.factors), "mu_star"], np.abs(slopes), atol=1e-9)
    np.testing.assert_allclose(t.loc[list(d.factors), "sigma"], 0.0, atol=1e-9)


def test_a_factor_whose_elementary_effects_are_all_zero_gets_no_interval():
    d = morris_design(table1_space(), rng=np.random.default_rng(4), trajectories=6)
    slopes = np.arange(len(d.factors), dtype=float) - 5.0  # factor 5 has no effect at all
    t = _table(morris_indices(d.unit, d.unit @ slopes, factors=d.factors, levels=d.levels, seed=1)).set_index("parameter")
    inert = d.factors[5]
    assert t.loc[inert, "mu_star"] == 0 and np.isnan(t.loc[inert, "mu_star_low"]) and np.isnan(t.loc[inert, "mu_star_high"])
    others = t.drop(index=inert)
    assert np.isfinite(others["mu_star_low"]).all() and np.isfinite(others["mu_star_high"]).all()


def test_sobol_ranks_the_planted_parameters_and_clears_the_others():
    d = sobol_design(table1_space(), rng=np.random.default_rng(5), base=512)
    y = _planted(d.unit, d.factors, np.random.default_rng(6))
    t = _table(sobol_indices(y, factors=d.factors, seed=7, noise_var=0.05 ** 2))
    assert set(t["parameter"].head(2)) == set(PLANTED)
    rest = t.iloc[2:]
    assert (rest["ST_low"] <= 0.0).all() and (rest["ST_high"] >= 0.0).all()
    assert (t.iloc[:2]["ST_low"] > 0.1).all()
    # analytic indices of the planted function (u ~ U(0,1)): Var(3u) = 0.75, Var(2 sin(pi u)) = 2 - 16/pi^2
    va, vb = 0.75, 2.0 - 16.0 / np.pi ** 2
    s = t.set_index("parameter")
    assert s.loc["map_size", "S1_low"] <= va / (va + vb) <= s.loc["map_size", "S1_high"] + 0.02
    assert s.loc["bias", "ST_low"] - 0.02 <= vb / (va + vb) <= s.loc["bias", "ST_high"] + 0.02


def test_without_the_noise_correction_every_total_index_carries_the_noise_share():
    d = sobol_design(table1_space(), rng=np.random.default_rng(5), base=512)
    y = _planted(d.unit, d.factors, np.random.default_rng(6), noise=0.3)
    raw = _table(sobol_indices(y, factors=d.factors, seed=7)).iloc[2:]
    share = 0.3 ** 2 / np.var(y, ddof=1)
    assert ((raw["ST_low"] <= share + 0.005) & (share - 0.005 <= raw["ST_high"])).all()
    assert (raw["ST_low"] > 0).all()


def test_missing_or_constant_responses_are_one_clear_error():
    d = sobol_design(table1_space(), rng=np.random.default_rng(5), base=4, factors=["map_size", "bias"])
    y = np.ones(d.n_points)
    with pytest.raises(ResultsError, match="constant"):
        sobol_indices(y, factors=d.factors, seed=1)
    y = np.arange(d.n_points, dtype=float)
    y[3] = np.nan
    with pytest.raises(ResultsError, match="1 of 16 design points"):
        sobol_indices(y, factors=d.factors, seed=1)


def test_a_response_that_varies_only_at_mixed_points_is_refused():
    d = sobol_design(table1_space(), rng=np.random.default_rng(5), base=8, factors=["map_size", "bias", "symmetry"])
    y = np.zeros(d.n_points)
    y[2] = 1.0  # one A_B point: A and B constant
    with pytest.raises(ResultsError, match="base samples A and B"):
        sobol_indices(y, factors=d.factors, seed=1)


def test_noise_floor_is_the_noise_share_of_the_variance():
    rng = np.random.default_rng(0)
    v = rng.normal(0, 2.0, 5000)
    assert noise_floor(v, np.full(v.size, 1.0)) == pytest.approx(0.25, rel=0.05)
    assert np.isnan(noise_floor(v, np.full(v.size, np.nan)))


def test_indices_are_arrays_ranked_like_a_stable_descending_sort_with_nan_last():
    from faultlab.inference.screening import MORRIS_COLUMNS, _ranked

    got = _ranked({"parameter": np.array(list("abcde"), dtype=object),
                   "mu_star": np.array([1.0, np.nan, 3.0, 1.0, 0.0])}, "mu_star")
    # the reference: pandas' stable descending sort
    ref = pd.DataFrame({"parameter": list("abcde"), "mu_star": [1.0, np.nan, 3.0, 1.0, 0.0]}).sort_values(
        "mu_star", ascending=False, kind="mergesort")
    assert list(got["parameter"]) == list(ref["parameter"]) == ["c", "a", "d", "e", "b"]
    assert list(got["rank"]) == [1, 2, 3, 4, 5]
    d = morris_design(table1_space(), rng=np.random.default_rng(1), trajectories=4)
    idx = morris_indices(d.unit, d.unit[:, 0], factors=d.factors, levels=d.levels, seed=3)
    assert idx.columns == MORRIS_COLUMNS and all(isinstance(v, np.ndarray) for v in idx.as_dict().values())
