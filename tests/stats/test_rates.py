import itertools

import numpy as np
import pytest
from statsmodels.stats.proportion import proportion_confint

from faultlab.errors import ConfigError
from faultlab.stats import by_suite, detection_rates, false_alarm_rate, proportion_ci
from tests.stats.synthetic import frame, job

Z = 1.959963984540054  # standard normal 97.5 % quantile


def wilson_by_hand(k, n):
    centre = (k + Z**2 / 2) / (n + Z**2)
    half = Z / (n + Z**2) * np.sqrt(k * (n - k) / n + Z**2 / 4)
    return centre - half, centre + half


def test_wilson_hand_checked_values():
    lo, hi = proportion_ci(5, 10, method="wilson")
    np.testing.assert_allclose([lo, hi], [0.236593, 0.763407], atol=1e-6)  # textbook value for 5/10
    for k, n in [(0, 15), (4, 15), (12, 15), (15, 15), (1, 3)]:
        np.testing.assert_allclose(proportion_ci(k, n, method="wilson"), wilson_by_hand(k, n), rtol=1e-9,
                                   atol=1e-12)


def test_clopper_pearson_closed_forms_and_statsmodels():
    # k = 0: upper = 1 - (alpha/2)^(1/n); k = n: lower = (alpha/2)^(1/n)
    np.testing.assert_allclose(proportion_ci(0, 10, method="cp"), [0.0, 1 - 0.025 ** 0.1], atol=1e-12)
    np.testing.assert_allclose(proportion_ci(10, 10, method="cp"), [0.025 ** 0.1, 1.0], atol=1e-12)
    for k, n, alpha in [(4, 15, 0.05), (7, 9, 0.1), (30, 100, 0.01)]:
        np.testing.assert_allclose(proportion_ci(k, n, alpha=alpha, method="cp"),
                                   proportion_confint(k, n, alpha=alpha, method="beta"))
        np.testing.assert_allclose(proportion_ci(k, n, alpha=alpha, method="wilson"),
                                   proportion_confint(k, n, alpha=alpha, method="wilson"))


def test_ci_vectorised_and_empty():
    lo, hi = proportion_ci([0, 3, 2], [0, 4, 9])
    assert np.isnan(lo[0]) and np.isnan(hi[0])
    np.testing.assert_allclose([lo[1], hi[1]], wilson_by_hand(3, 4))
    with pytest.raises(ConfigError, match="method"):
        proportion_ci(1, 2, method="agresti")


@pytest.mark.parametrize("k, n, kwargs, message", [
    (5, 3, {}, r"k must not exceed n, got k = 5 > n = 3"),
    ([1, 4, 2], [2, 3, 9], {}, r"k = 4 > n = 3 at index \(1,\)"),
    (1, 0, {}, r"k = 1 > n = 0"),
    (-1, 3, {}, r"k must be >= 0, got k = -1"),
    (1, [4, -2], {}, r"n must be >= 0, got n = -2"),
    (2.5, 4, {}, r"k must be integer counts, got k = 2.5"),
    (1, np.nan, {}, r"n must be integer counts, got n = nan"),
    ([1, np.inf], 4, {}, r"k must be integer counts, got k = inf"),
    ("3", 4, {}, r"k must be integer counts, got '3'"),
    (True, 4, {}, r"k must be integer counts, got True"),
    ([1, 2], [3, 4, 5], {}, r"broadcastable"),
    (1, 2, {"alpha": 0.0}, r"alpha must lie in \(0, 1\), got 0.0"),
    (1, 2, {"alpha": 1.0}, r"alpha must lie in \(0, 1\), got 1.0"),
    (1, 2, {"alpha": -0.05}, r"alpha must lie in \(0, 1\), got -0.05"),
    (1, 2, {"alpha": np.nan}, r"alpha must lie in \(0, 1\), got nan"),
    (1, 2, {"alpha": "0.05"}, r"alpha must lie in \(0, 1\), got '0.05'"),
    (1, 2, {"method": "agresti"}, r"method must be one of \['cp', 'wilson'\], got 'agresti'"),
    (1, 2, {"method": None}, r"got None"),
])
def test_bad_counts_and_options_raise_one_config_error_naming_the_value(k, n, kwargs, message):
    with pytest.raises(ConfigError, match=message):
        proportion_ci(k, n, **kwargs)


def test_whole_number_floats_and_integer_arrays_are_counts():
    np.testing.assert_allclose(proportion_ci(3.0, 4.0), proportion_ci(3, 4))
    lo, hi = proportion_ci(np.array([0, 4], dtype=np.int32), np.array([4, 4], dtype=np.int64), method="cp")
    np.testing.assert_allclose([lo[0], hi[1]], [0.0, 1.0])
    assert np.isnan(proportion_ci(0, 0)[0])  # no trials: NaN, not an error


def results_with_failures():
    """2 suites x 1 fault, 2 runs x 2 cases x K = 2 reps, with every outcome class."""
    rows = []
    faulty = {  # (suite, run, case, rep) -> (rms or status)
        ("systematic", 1, 1, 0): 900.0, ("systematic", 1, 1, 1): 150.0,
        ("systematic", 1, 2, 0): "crash", ("systematic", 1, 2, 1): 980.0,
        ("systematic", 2, 1, 0): 120.0, ("systematic", 2, 1, 1): "timeout",
        ("systematic", 2, 2, 0): 5000.0, ("systematic", 2, 2, 1): 110.0,
        ("random", 1, 1, 0): 100.0, ("random", 1, 1, 1): 100.0,
        ("random", 1, 2, 0): 100.0, ("random", 1, 2, 1): 100.0,
        ("random", 2, 1, 0): 700.0, ("random", 2, 1, 1): 100.0,
        ("random", 2, 2, 0): 800.0, ("random", 2, 2, 1): 100.0,
    }
    base_crash = {("systematic", 2, 2, 0)}
    for (suite, run, case, rep), v in faulty.items():
        b_status = "crash" if (suite, run, case, rep) in base_crash else "ok"
        rows.append(job(run, suite, case, "baseline", rep, 100.0, b_status))
        rows.append(job(run, suite, case, "naive_resampling", rep, 0.0 if isinstance(v, str) else v,
                        v if isinstance(v, str) else "ok"))
    return frame(rows), faulty, base_crash


def test_detection_rates_counts_and_both_conventions():
    res, faulty, base_crash = results_with_failures()
    table = detection_rates(res).set_index("suite")
    for suite in ("systematic", "random"):
        cells = {k: v for k, v in faulty.items() if k[0] == suite}
        det = sum(1 for k, v in cells.items() if k not in base_crash and not isinstance(v, str)
                  and v - 100 > 250 and v - 100 >= 25)
        nd = sum(1 for k, v in cells.items() if k not in base_crash and not isinstance(v, str)) - det
        fails = sum(1 for k, v in cells.items() if k not in base_crash and isinstance(v, str))
        row = table.loc[suite]
        assert (row["detected"], row["not_detected"], row["crash"] + row["timeout"]) == (det, nd, fails)
        assert row["baseline_failed"] == sum(1 for k in cells if k in base_crash)
        assert (row["k"], row["n"]) == (det, det + nd)
        assert (row["k_incl"], row["n_incl"]) == (det + fails, det + nd + fails)
        np.testing.assert_allclose([row["wilson_low"], row["wilson_high"]], wilson_by_hand(det, det + nd))
        np.testing.assert_allclose([row["cp_low_incl"], row["cp_high_incl"]],
                                   proportion_confint(det + fails, det + nd + fails, method="beta"))
        assert (row["n_cases"], row["n_reps"], row["n_jobs"]) == (4, 2, 8)
    sysrow = table.loc["systematic"]
    assert (sysrow["detected"], sysrow["crash"], sysrow["timeout"], sysrow["baseline_failed"]) == (2, 1, 1, 1)
    assert list(detection_rates(res)["suite"]) == ["systematic", "random"]  # Table II order


def test_by_suite_counts_fault_run_pairs_with_any_detection():
    rows = []
    # systematic: fault A detected in run 1 (case 2 only), not in run 2; fault B in both runs
    spec = {("A", 1): [100, 900], ("A", 2): [110, 120], ("B", 1): [900, 100], ("B", 2): [100, 5000]}
    for (fault, run), values in spec.items():
        for case, v in enumerate(values, start=1):
            rows.append(job(run, "systematic", case, fault, 0, v))
    for run in (1, 2):
        for case in (1, 2):
            rows.append(job(run, "systematic", case, "baseline", 0, 100.0))
    table = by_suite(frame(rows)).set_index("suite")
    row = table.loc["systematic"]
    assert (row["detected_pairs"], row["n_pairs"]) == (3, 4)
    np.testing.assert_allclose(row["rate"], 0.75)
    assert row["missed"] == "A (run 2)"


def test_by_suite_failures_detect_option():
    rows = [job(1, "fixed", 1, "baseline", 0, 100.0), job(1, "fixed", 1, "F", 0, 0.0, "crash")]
    assert by_suite(frame(rows)).loc[0, "detected_pairs"] == 0
    assert by_suite(frame(rows), failures_detect=True).loc[0, "detected_pairs"] == 1


def test_false_alarm_rate_uses_ordered_rep_pairs():
    reps = {("random", 1): [100.0, 100.0, 1000.0], ("random", 2): [2000.0, 2600.0], ("fixed", 1): [50.0]}
    rows = [job(1, s, c, "baseline", k, v) for (s, c), vals in reps.items() for k, v in enumerate(vals)]
    rows.append(job(1, "random", 1, "naive_resampling", 0, 99999.0))  # faulty rows are ignored
    table = false_alarm_rate(frame(rows)).set_index("suite")
    expected_flags, expected_pairs = 0, 0
    for vals in (reps[("random", 1)], reps[("random", 2)]):
        for a, b in itertools.permutations(vals, 2):
            expected_pairs += 1
            expected_flags += (a - b > 250) and (a - b >= 0.25 * b)
    assert (table.loc["random", "n_pairs"], table.loc["random", "flagged"]) == (expected_pairs, expected_flags)
    assert (expected_pairs, expected_flags) == (8, 3)
    assert table.loc["random", "n_cases"] == 2
    assert table.loc["fixed", "n_pairs"] == 0 and np.isnan(table.loc["fixed", "rate"])
    assert table.loc["all", "flagged"] == 3
    # ordered pairs of one case are correlated: the interval is clustered by case
    from faultlab.inference.intervals import clustered_rate

    flags = [a - b > 250 and a - b >= 0.25 * b for vals in (reps[("random", 1)], reps[("random", 2)])
             for a, b in itertools.permutations(vals, 2)]
    ref = clustered_rate(np.array(flags), np.array([1] * 6 + [2] * 2))
    np.testing.assert_allclose([table.loc["all", "low"], table.loc["all", "high"]], [ref.low, ref.high])
    assert table.loc["all", "high"] > wilson_by_hand(3, 8)[1]  # wider than treating the pairs as independent


def test_suspected_equivalent_faults_flags_only_bit_identical_faults():
    from faultlab.stats import suspected_equivalent_faults

    from tests.stats.synthetic import frame, job

    rows = []
    for case, base in enumerate([100.0, 250.5, 3000.0], start=1):
        rows += [job(1, "systematic", case, "baseline", 0, base),
                 job(1, "systematic", case, "missing_angle_wrap", 0, base),  # identical everywhere
                 job(1, "systematic", case, "naive_resampling", 0, base + (case == 3) * 1e-9)]
    # a crashed pair does not count against (or for) equivalence
    rows += [job(1, "systematic", 4, "baseline", 0, 50.0),
             job(1, "systematic", 4, "missing_angle_wrap", 0, 0.0, status="crash"),
             job(1, "systematic", 4, "naive_resampling", 0, 50.0)]
    assert suspected_equivalent_faults(frame(rows)) == ["missing_angle_wrap"]
    # with no pair where both finished there is nothing to judge
    assert suspected_equivalent_faults(frame(rows[-3:-2] + rows[-2:-1])) == []
