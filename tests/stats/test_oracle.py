from math import comb

import numpy as np
import pytest
from scipy.stats import mannwhitneyu

from faultlab.errors import ConfigError
from faultlab.stats import oracle_detections
from tests.stats.synthetic import frame, job

K = 8


def holm_by_hand(p):
    """Holm step-down adjusted p-values, written out."""
    p = np.asarray(p, dtype=float)
    order = np.argsort(p)
    m = p.size
    adj = np.empty(m)
    running = 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (m - rank) * p[i]))
        adj[i] = running
    return adj


def make(seed=0):
    rng = np.random.default_rng(seed)
    rows = []
    shifts = {1: 0.0, 2: 2000.0, 3: 300.0, 4: 0.0}  # case -> how much worse the fault makes the map
    for case, shift in shifts.items():
        base = rng.normal(1000.0, 100.0, K)
        for k in range(K):
            rows.append(job(1, "random", case, "baseline", k, base[k]))
            rows.append(job(1, "random", case, "motion_sign_error", k, base[k] + shift + rng.normal(0, 50)))
    return frame(rows)


def test_mann_whitney_and_holm_against_independent_computation():
    res = make()
    table = oracle_detections(res, alpha=0.05).set_index("case")
    ps = []
    for case in (1, 2, 3, 4):
        x = res[(res["case"] == case) & (res["variant"] != "baseline")]["rms_mm"].to_numpy()
        y = res[(res["case"] == case) & (res["variant"] == "baseline")]["rms_mm"].to_numpy()
        ref = mannwhitneyu(x, y, alternative="greater")
        np.testing.assert_allclose(table.loc[case, "p"], ref.pvalue)
        np.testing.assert_allclose(table.loc[case, "u"], ref.statistic)
        # U of the faulty sample counted by hand
        assert table.loc[case, "u"] == sum((xi > yj) + 0.5 * (xi == yj) for xi in x for yj in y)
        ps.append(ref.pvalue)
    np.testing.assert_allclose(table.loc[[1, 2, 3, 4], "p_holm"], holm_by_hand(ps))
    np.testing.assert_array_equal(table.loc[[1, 2, 3, 4], "detected"], holm_by_hand(ps) <= 0.05)
    assert table.loc[2, "detected"] and not table.loc[1, "detected"]
    np.testing.assert_allclose(table["p_min"], 1 / comb(2 * K, K))
    assert (table["n_faulty"] == K).all() and (table["n_baseline"] == K).all()


def test_untestable_cases_leave_the_family():
    res = make()
    res.loc[(res["case"] == 4) & (res["variant"] == "baseline"), ["status", "rms_mm"]] = ["crash", np.nan]
    table = oracle_detections(res).set_index("case")
    assert np.isnan(table.loc[4, "p"]) and not table.loc[4, "detected"] and table.loc[4, "n_baseline"] == 0
    np.testing.assert_allclose(table.loc[[1, 2, 3], "p_holm"], holm_by_hand(table.loc[[1, 2, 3], "p"]))


def test_three_reps_cannot_reach_holm_significance():
    rows = []
    for case in (1, 2):
        for k in range(3):
            rows.append(job(1, "fixed", case, "baseline", k, 100.0 + k))
            rows.append(job(1, "fixed", case, "naive_resampling", k, 5000.0 + k))
    table = oracle_detections(frame(rows))
    np.testing.assert_allclose(table["p"], 0.05)  # = 1 / C(6, 3), the best possible
    np.testing.assert_allclose(table["p_holm"], 0.1)
    assert not table["detected"].any()
    with pytest.raises(ConfigError, match="alpha"):
        oracle_detections(frame(rows), alpha=1.5)
