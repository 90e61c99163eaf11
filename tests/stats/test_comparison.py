import numpy as np
from scipy.stats import norm

from faultlab.stats import compare_suites, odds_ratio
from tests.stats.synthetic import frame, job


def counts_frame(counts):
    """counts: {(suite, fault): (detected, n)} -> results with n one-rep cases per cell."""
    rows = []
    for (suite, fault), (k, n) in counts.items():
        for case in range(1, n + 1):
            rows.append(job(1, suite, case, "baseline", 0, 100.0))
            rows.append(job(1, suite, case, fault, 0, 1000.0 if case <= k else 100.0))
    # one baseline row per (suite, case) is enough: drop duplicates from several faults
    return frame(rows).drop_duplicates(["run", "suite", "case", "variant", "rep"])


def test_fisher_hand_computed_and_haldane_odds_ratio():
    table = compare_suites(counts_frame({("systematic", "F"): (3, 3), ("random", "F"): (0, 3)}))
    assert len(table) == 1
    row = table.iloc[0]
    assert (row["suite_a"], row["suite_b"], row["k_a"], row["n_a"], row["k_b"], row["n_b"]) == (
        "systematic", "random", 3, 3, 0, 3)
    # [[3, 0], [0, 3]]: two-sided Fisher p = 2 / C(6, 3)
    np.testing.assert_allclose(row["p"], 0.1)
    np.testing.assert_allclose(row["risk_difference"], 1.0)
    # zero cells: Haldane-Anscombe, (3.5 * 3.5) / (0.5 * 0.5) = 49
    assert row["haldane"]
    np.testing.assert_allclose(row["odds_ratio"], 49.0)
    se = np.sqrt(2 / 3.5 + 2 / 0.5)
    np.testing.assert_allclose([row["or_low"], row["or_high"]],
                               np.exp(np.log(49.0) + np.array([-1, 1]) * norm.ppf(0.975) * se))


def test_no_correction_without_zero_cells():
    orr, lo, hi, corrected = odds_ratio(4, 10, 2, 10)
    assert not corrected
    np.testing.assert_allclose(orr, (4 * 8) / (6 * 2))
    assert lo < orr < hi


def test_every_suite_pair_per_fault_with_holm():
    counts = {(s, f): (k, 6) for (s, f), k in {
        ("systematic", "A"): 5, ("fixed", "A"): 0, ("random", "A"): 3,
        ("systematic", "B"): 6, ("fixed", "B"): 6, ("random", "B"): 6}.items()}
    table = compare_suites(counts_frame(counts))
    assert len(table) == 6
    assert list(zip(table["suite_a"], table["suite_b"]))[:3] == [
        ("systematic", "fixed"), ("systematic", "random"), ("fixed", "random")]
    b = table[table["fault"] == "B"]
    np.testing.assert_allclose(b["p"], 1.0)
    np.testing.assert_allclose(b["risk_difference"], 0.0)
    assert (b["rd_low"] < 0).all() and (b["rd_high"] > 0).all()
    p = table["p"].to_numpy()
    order = np.argsort(p)
    adj = np.maximum.accumulate(np.minimum(1, (len(p) - np.arange(len(p))) * p[order]))
    np.testing.assert_allclose(table["p_holm"].to_numpy()[order], adj)
    a = table[(table["fault"] == "A") & (table["suite_b"] == "fixed")].iloc[0]
    assert a["p"] < 0.05 and a["rd_low"] > 0
