import itertools
from math import comb

import numpy as np
import pytest
from scipy.stats import rankdata
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import mannwhitneyu

from faultlab.errors import ConfigError
from faultlab.stats import oracle_detections
from faultlab.stats.oracle import MAX_TIED_SPLITS, mann_whitney_p
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


# --------------------------------------------------------------------------- exact p values, ties


def brute_force_mw_p(x, y) -> float:
    """Exact one-sided permutation p value of U by enumerating every split of the pooled values."""
    pooled = np.concatenate([x, y]).astype(float)
    n = len(x)

    def u(a, b):
        return sum((ai > bj) + 0.5 * (ai == bj) for ai in a for bj in b)

    observed = u(x, y)
    hits = total = 0
    for chosen in itertools.combinations(range(pooled.size), n):
        mask = np.zeros(pooled.size, bool)
        mask[list(chosen)] = True
        hits += u(pooled[mask], pooled[~mask]) >= observed
        total += 1
    assert total == comb(pooled.size, n)
    return hits / total


def one_case(x, y):
    rows = [job(1, "random", 1, "baseline", k, v) for k, v in enumerate(y)]
    rows += [job(1, "random", 1, "naive_resampling", k, v) for k, v in enumerate(x)]
    return frame(rows)


@pytest.mark.parametrize("x, y", [
    ([5.0, 7.0, 9.0], [1.0, 6.0, 8.0]),                 # no ties
    ([3.0, 3.0, 4.0, 5.0], [1.0, 3.0, 2.0, 2.0]),       # ties across and within the samples
    ([2.0, 2.0, 2.0], [2.0, 2.0, 2.0]),                 # everything tied
    ([4.0, 4.0, 6.0, 1.0, 4.0], [4.0, 1.0, 3.0, 4.0]),  # unequal sizes with ties
    ([10.0, 11.0, 12.0, 13.0], [1.0, 2.0, 3.0, 4.0]),   # the floor 1 / C(8, 4)
    ([3.0], [1.0, 3.0, 5.0, 3.0]),                      # one faulty value, tied
    ([2.0, 3.0, 3.0, 7.0], [3.0]),                      # one baseline value, tied
])
def test_oracle_p_equals_the_enumerated_permutation_distribution(x, y):
    table = oracle_detections(one_case(x, y))
    assert table.loc[0, "p"] == pytest.approx(brute_force_mw_p(np.array(x), np.array(y)), abs=1e-12)
    assert table.loc[0, "p"] >= table.loc[0, "p_min"] - 1e-15


@settings(max_examples=40, deadline=None)
@given(st.lists(st.integers(0, 4), min_size=1, max_size=5), st.lists(st.integers(0, 4), min_size=1, max_size=5))
def test_exact_p_with_ties_matches_brute_force_and_never_beats_the_floor(x, y):
    x, y = np.array(x, float), np.array(y, float)
    u, p = mann_whitney_p(x, y)
    assert p == pytest.approx(brute_force_mw_p(x, y), abs=1e-12)
    assert u == sum((a > b) + 0.5 * (a == b) for a in x for b in y)
    assert p >= 1.0 / comb(x.size + y.size, x.size) - 1e-15


def test_minimum_p_values_of_the_docstring_table():
    for k, p_min in ((3, 0.05), (4, 0.0143), (5, 0.00397), (6, 0.00108), (7, 0.000291), (8, 7.77e-05),
                     (10, 5.41e-06)):
        assert 1.0 / comb(2 * k, k) == pytest.approx(p_min, rel=5e-3)
    for k in range(1, 10):
        x, y = np.arange(k) + 100.0, np.arange(k, dtype=float)
        assert mann_whitney_p(x, y)[1] == pytest.approx(1.0 / comb(2 * k, k), rel=1e-12)
        # ties inside the faulty sample only: the floor still holds and is reached
        assert mann_whitney_p(np.full(k, 100.0), y)[1] == pytest.approx(1.0 / comb(2 * k, k), rel=1e-12)


def test_asymptotic_only_when_asked_and_bad_methods_are_refused():
    x, y = [10.0, 11.0, 12.0], [1.0, 2.0, 3.0]
    exact = oracle_detections(one_case(x, y))
    approx = oracle_detections(one_case(x, y), method="asymptotic")
    assert exact.loc[0, "p"] == pytest.approx(0.05)
    ref = mannwhitneyu(x, y, alternative="greater", method="asymptotic").pvalue
    assert approx.loc[0, "p"] == pytest.approx(ref) and ref < exact.loc[0, "p_min"]  # below the exact floor
    for bad in ("auto", "normal", None):
        with pytest.raises(ConfigError, match="method"):
            oracle_detections(one_case(x, y), method=bad)


def _exact_tied_p(x, y) -> float:
    """Exact one-sided permutation p of U with ties: the distribution of the sum of the pooled midranks
    (doubled to integers) over all subsets of size n, by dynamic programming over the pooled values."""
    ranks = (2 * rankdata(np.concatenate([x, y]))).astype(int)
    n = len(x)
    top = int(ranks.sum())
    ways = np.zeros((n + 1, top + 1), dtype=object)  # ways[j, s]: subsets of j values with doubled sum s
    ways[0, 0] = 1
    for r in ranks:
        ways[1:, r:] = ways[1:, r:] + ways[:-1, :top + 1 - r]
    observed = int(ranks[:n].sum())
    return float(sum(ways[n, observed:]) / comb(len(ranks), n))


def test_large_samples_exact_without_ties_and_seeded_monte_carlo_with_ties():
    rng = np.random.default_rng(4)
    x, y = rng.normal(1.0, 1.0, 12), rng.normal(0.0, 1.0, 12)
    table = oracle_detections(one_case(x, y))
    assert table.loc[0, "p"] == pytest.approx(mannwhitneyu(x, y, alternative="greater", method="exact").pvalue)
    assert table.loc[0, "p_mc_se"] == 0.0
    y[3] = x[5]  # one tie: C(24, 12) splits are too many to enumerate
    tied = oracle_detections(one_case(x, y))
    assert tied.loc[0, "p_mc_se"] > 0
    assert abs(tied.loc[0, "p"] - _exact_tied_p(x, y)) <= 4 * tied.loc[0, "p_mc_se"] + 1e-4
    assert oracle_detections(one_case(x, y)).equals(tied)  # seeded: the same p again
    with pytest.raises(ConfigError, match="rng"):
        mann_whitney_p(x, y)
    # an equivalent variant reproducing the baseline bit for bit (every value tied): the oracle still answers
    same = oracle_detections(one_case(y.copy(), y))
    assert abs(same.loc[0, "p"] - _exact_tied_p(y, y)) <= 4 * same.loc[0, "p_mc_se"] + 1e-4
    assert not same.loc[0, "detected"]
    assert comb(18, 9) <= MAX_TIED_SPLITS < comb(20, 10)
