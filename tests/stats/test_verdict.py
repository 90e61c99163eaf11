"""Per-case verdicts (exact sign-flip test, equivalence), against independent references."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from faultlab.errors import ConfigError, ResultsError
from faultlab.inference.exact import detectable_shift_factor
from faultlab.stats.verdict import Verdict, case_verdicts
from tests.stats.synthetic import frame, job
from tests.inference.test_exact import brute_force_p


# --------------------------------------------------------------------------- case verdicts


FAULTS = ("naive_resampling", "motion_sign_error")


def campaign(k=8, *, seed=0, shifts=(0.0, 600.0, 150.0), statuses=None, base_statuses=None):
    """K repetitions of the baseline and two faults on len(shifts) random-suite cases of run 1.

    ``statuses[(case, fault, rep)]`` / ``base_statuses[(case, rep)]`` override a job's status.
    """
    rng = np.random.default_rng(seed)
    statuses, base_statuses = statuses or {}, base_statuses or {}
    rows = []
    for case, shift in enumerate(shifts, 1):
        base = rng.normal(1000.0, 80.0, k)
        for rep in range(k):
            rows.append(job(1, "random", case, "baseline", rep, base[rep],
                            status=base_statuses.get((case, rep), "ok")))
            for j, fault in enumerate(FAULTS):
                value = base[rep] + (j + 1) * shift + rng.normal(0.0, 40.0)
                rows.append(job(1, "random", case, fault, rep, value, status=statuses.get((case, fault, rep), "ok")))
    return frame(rows)


def test_verdicts_follow_the_exact_test_on_pairs_matched_by_repetition():
    res = campaign(seed=1)  # seed 0 draws a no-effect case whose noise alone is two-sided significant
    shuffled = res.sample(frac=1.0, random_state=1)  # pairing is by repetition, not by row order
    table = case_verdicts(shuffled).set_index(["case", "fault"])
    assert len(table) == 6
    for (case, fault), row in table.iterrows():
        f = res[(res["case"] == case) & (res["variant"] == fault)].set_index("rep")["rms_mm"]
        b = res[(res["case"] == case) & (res["variant"] == "baseline")].set_index("rep")["rms_mm"]
        d = (f - b.reindex(f.index)).to_numpy()
        assert row["p"] == pytest.approx(float(brute_force_p(d, "two-sided")), abs=1e-12)
        assert row["alternative"] == "two-sided"
        assert row["direction"] == ("worse" if d.mean() > 0 else "better")
        s = np.sort(d)
        assert (row["median_low_mm"], row["median_high_mm"]) == (s[0], s[7])  # K = 8: 1 - 2/256 >= 95 %
        r = np.sort(f.to_numpy() / b.reindex(f.index).to_numpy())
        assert row["ratio"] == pytest.approx(np.median(r)) and (row["ratio_low"], row["ratio_high"]) == (r[0], r[7])
        assert row["verdict"] == (Verdict.DETECTED if row["p"] <= 0.05 else Verdict.NOT_DETECTED)
        assert row["detected"] == (row["p"] <= 0.05)
        assert row["n_pairs"] == row["n_reps"] == 8 and row["n_failed"] == 0 and row["reason"] == ""
        assert row["mean_diff_mm"] == pytest.approx(d.mean()) and row["median_diff_mm"] == pytest.approx(np.median(d))
        assert row["p_min"] == 2.0 ** -7
        sd = np.std(b.to_numpy(), ddof=1)
        assert row["baseline_sd_mm"] == pytest.approx(sd)
        assert row["mde_mm"] == pytest.approx(detectable_shift_factor(8, alternative="two-sided")
                                              * math.sqrt(2.0) * sd)
    assert table.loc[(2, "motion_sign_error"), "verdict"] == Verdict.DETECTED
    assert table.loc[(1, "naive_resampling"), "verdict"] == Verdict.NOT_DETECTED


def test_a_planted_improving_fault_is_a_change_with_direction_better():
    """A fault that lowers the error on every case: the two-sided rule detects it as "better" with
    its effect; the paper's one-sided notion does not detect it."""
    res = campaign(k=10, seed=2, shifts=(-120.0, -200.0, -300.0))
    two = case_verdicts(res).set_index(["case", "fault"])
    assert (two["verdict"] == Verdict.DETECTED).all() and (two["direction"] == "better").all()
    assert (two["median_high_mm"] < 0).all() and (two["ratio_high"] < 1).all()
    for (case, fault), row in two.iterrows():  # the planted shift lies in the effect interval
        planted = (1 + FAULTS.index(fault)) * (-120.0, -200.0, -300.0)[case - 1]
        assert row["median_low_mm"] < planted < row["median_high_mm"]
    one = case_verdicts(res, direction="worse")
    assert (one["verdict"] == Verdict.NOT_DETECTED).all() and (one["p"] > 0.9).all()
    assert (one["alternative"] == "greater").all()


def test_a_failure_of_the_faulty_variant_alone_is_a_detection():
    res = campaign(statuses={(1, "naive_resampling", 3): "crash", (1, "motion_sign_error", 0): "timeout"})
    res.loc[(res["case"] == 2) & (res["variant"] == "naive_resampling") & (res["rep"] == 5), "rms_mm"] = np.nan
    table = case_verdicts(res).set_index(["case", "fault"])
    for cell, failed in (((1, "naive_resampling"), 1), ((1, "motion_sign_error"), 1), ((2, "naive_resampling"), 1)):
        row = table.loc[cell]
        assert row["verdict"] == Verdict.CRASH_DETECTED and bool(row["detected"])
        assert row["n_failed"] == failed and row["n_pairs"] == 7 and np.isnan(row["p"])
    assert table.loc[(2, "motion_sign_error"), "verdict"] == Verdict.DETECTED


def test_a_failed_baseline_makes_the_case_unjudgeable_never_a_miss():
    res = campaign(base_statuses={(1, 4): "crash", (2, 0): "timeout"},
                   statuses={(2, "naive_resampling", 3): "crash"})
    res = res[~((res["case"] == 3) & (res["variant"] == "baseline") & (res["rep"] == 7))]  # missing job
    table = case_verdicts(res).set_index(["case", "fault"])
    assert (table["verdict"] == Verdict.CANNOT_JUDGE).all()
    assert (table["reason"] == "baseline_failed").all()
    assert table["detected"].isna().all()
    assert table["p"].isna().all() and table["mde_mm"].isna().all()


def test_too_few_pairs_cannot_be_judged_at_that_alpha():
    res = campaign(k=4, shifts=(5000.0,))
    table = case_verdicts(res, alpha=0.05)
    assert (table["verdict"] == Verdict.CANNOT_JUDGE).all() and (table["reason"] == "too_few_pairs").all()
    assert np.isinf(table["mde_mm"]).all() and table["detected"].isna().all()
    lenient = case_verdicts(res, alpha=0.1, direction="worse")  # one-sided 2^-4 = 0.0625 <= 0.1
    assert (lenient["verdict"] == Verdict.DETECTED).all() and (lenient["p"] == 2.0 ** -4).all()
    two_sided = case_verdicts(res, alpha=0.1)  # two-sided 2^-3 > 0.1
    assert (two_sided["reason"] == "too_few_pairs").all()
    strict = case_verdicts(campaign(k=6, shifts=(5000.0,)), min_pairs_required=7)
    assert (strict["reason"] == "too_few_pairs").all()
    # a missing faulty job leaves fewer pairs
    res6 = campaign(k=6, shifts=(5000.0,))
    res6 = res6[~((res6["variant"] == "naive_resampling") & (res6["rep"] == 2))]
    row = case_verdicts(res6).set_index("fault").loc["naive_resampling"]
    assert (row["verdict"], row["n_reps"], row["n_pairs"]) == (Verdict.CANNOT_JUDGE, 5, 5)


def test_vectorised_verdicts_equal_one_case_at_a_time():
    rng = np.random.default_rng(5)
    rows = []
    for case in range(1, 13):
        k = int(rng.integers(5, 10))  # cases with different K in one call
        base = rng.normal(500.0, 50.0, k)
        for rep in range(k):
            rows.append(job(2, "fixed", case, "baseline", rep, base[rep]))
            rows.append(job(2, "fixed", case, "naive_resampling", rep, base[rep] + rng.normal(30.0, 60.0)))
    res = frame(rows)
    together = case_verdicts(res)
    alone = pd.concat([case_verdicts(res[res["case"] == c]) for c in range(1, 13)], ignore_index=True)
    pd.testing.assert_frame_equal(together, alone)
    assert together["n_pairs"].nunique() > 1 and together["p"].nunique() > 3


def test_metric_choice_and_bad_input():
    res = campaign()
    emd = case_verdicts(res, metric="emd")
    assert (emd["mean_diff_mm"].to_numpy() == pytest.approx(case_verdicts(res)["mean_diff_mm"].to_numpy() / 2))
    by_ate = case_verdicts(res.assign(ate_mm=3 * res["rms_mm"]), metric="ate")  # the trajectory error's column
    assert (by_ate["mean_diff_mm"].to_numpy() == pytest.approx(3 * case_verdicts(res)["mean_diff_mm"].to_numpy()))
    with pytest.raises(ConfigError, match="metric"):
        case_verdicts(res, metric="mae")
    with pytest.raises(ConfigError, match="alpha"):
        case_verdicts(res, alpha=0.0)
    with pytest.raises(ConfigError, match="power"):
        case_verdicts(res, power=1.5)
    with pytest.raises(ResultsError, match="more than once"):
        case_verdicts(pd.concat([res, res.iloc[:1]]))
    with pytest.raises(ResultsError, match="status"):
        case_verdicts(res.assign(status="weird"))
    with pytest.raises(ResultsError, match="rms_mm"):
        case_verdicts(res.drop(columns="rms_mm"))
    assert case_verdicts(res[res["variant"] == "baseline"]).empty


def test_equivalence_is_tost_with_the_shifted_exact_test_and_identity_is_observed():
    rng = np.random.default_rng(4)
    k, rows = 10, []
    base = rng.normal(1000.0, 30.0, k)
    for rep in range(k):
        rows.append(job(1, "fixed", 1, "baseline", rep, base[rep]))
        rows.append(job(1, "fixed", 1, "naive_resampling", rep, base[rep] + rng.normal(0.0, 10.0)))  # within 10 %
        rows.append(job(1, "fixed", 1, "motion_sign_error", rep, base[rep] + 95.0 + rng.normal(0.0, 10.0)))
        rows.append(job(1, "fixed", 1, "missing_angle_wrap", rep, base[rep]))                         # bit-identical
    res = frame(rows)
    table = case_verdicts(res).set_index("fault")
    delta = 0.10 * np.median(base)
    for fault, row in table.iterrows():
        d = res[res["variant"] == fault]["rms_mm"].to_numpy() - base
        # the larger of the two one-sided p values on the shifted differences, by enumeration
        expect = max(brute_force_p(d + delta, "greater"), brute_force_p(d - delta, "less"))
        assert row["margin_mm"] == pytest.approx(delta)
        assert row["p_equivalence"] == pytest.approx(float(expect), abs=1e-12)
    assert table.loc["naive_resampling", "p_equivalence"] <= 0.05          # equivalent within +-10 %
    assert table.loc["motion_sign_error", "p_equivalence"] > 0.05          # 95 mm of 100: not shown
    assert table.loc["missing_angle_wrap", "identical"] and not table.loc["naive_resampling", "identical"]
    assert np.isnan(table.loc["missing_angle_wrap", "median_low_mm"])     # no interval from identical runs
    # an absolute margin replaces a smaller relative one
    wide = case_verdicts(res, margin_mm=200.0).set_index("fault")
    assert wide.loc["motion_sign_error", "p_equivalence"] <= 0.05
    with pytest.raises(ConfigError, match="margin_rel"):
        case_verdicts(res, margin_rel=-0.1)


# --------------------------------------------------------------------------- deterministic cases


def deterministic_campaign(k=10, *, base=(812.5, 640.25, 1020.0), faulty=(900.0, 640.25, 700.0)):
    """A planted deterministic SLAM: every repetition of a case gives the same error, bit for bit
    (baseline ``base[i]``, the fault ``faulty[i]`` on case i + 1), as EKF-SLAM does whatever its seed."""
    rows = []
    for case, (b, f) in enumerate(zip(base, faulty), 1):
        for rep in range(k):
            rows.append(job(1, "systematic", case, "baseline", rep, b))
            rows.append(job(1, "systematic", case, "naive_resampling", rep, f))
    return frame(rows)


def test_a_deterministic_case_is_judged_by_its_exact_difference_not_a_test_over_copies():
    """Ten copies of one execution: a sign-flip test would report p = 2^-9 from one observation; the
    verdict is the difference itself, with no p value, no interval, and any shift detectable."""
    table = case_verdicts(deterministic_campaign()).set_index("case")
    assert (table["test"] == "exact").all()
    assert table["p"].isna().all() and table["p_min"].isna().all() and table["p_equivalence"].isna().all()
    assert table["median_low_mm"].isna().all() and table["ratio_low"].isna().all()
    assert list(table["verdict"]) == [Verdict.DETECTED, Verdict.NOT_DETECTED, Verdict.DETECTED]
    assert list(table["direction"]) == ["worse", "none", "better"]
    assert list(table["mean_diff_mm"]) == [900.0 - 812.5, 0.0, 700.0 - 1020.0]
    assert table.loc[1, "ratio"] == 900.0 / 812.5 and table.loc[3, "ratio"] == 700.0 / 1020.0
    assert (table["mde_mm"] == 0).all()
    assert list(table["identical"]) == [False, True, False]


def test_a_deterministic_case_needs_no_minimum_of_pairs_and_one_stochastic_repetition_ends_it():
    few = case_verdicts(deterministic_campaign(k=3)).set_index("case")  # K = 3 < min_pairs: still judged
    assert (few["test"] == "exact").all() and few.loc[1, "verdict"] == Verdict.DETECTED
    res = deterministic_campaign()
    wobble = (res["case"] == 1) & (res["variant"] == "baseline") & (res["rep"] == 4)
    res.loc[wobble, "rms_mm"] = 812.5 + 1e-9  # the baseline varies on case 1: the repetitions are evidence
    table = case_verdicts(res).set_index("case")
    assert table.loc[1, "test"] == "sign-flip" and table.loc[1, "p"] == pytest.approx(2.0 ** -9)
    assert list(table.loc[[2, 3], "test"]) == ["exact", "exact"]
    one = case_verdicts(deterministic_campaign(k=1))  # one repetition shows nothing about determinism
    assert (one["test"] == "").all() and (one["verdict"] == Verdict.CANNOT_JUDGE).all()


def test_rule_verdicts_keep_an_exact_case_out_of_the_holm_family():
    from faultlab.metrics.detection import DetectionRule
    from faultlab.stats.cases import rule_verdicts
    from faultlab.stats.detection import outcomes

    res = deterministic_campaign()
    rule = DetectionRule(rule="statistical", family="fault")
    table = rule_verdicts(res, outcomes(res, rule=rule), rule=rule).set_index("case")
    assert table["p_holm"].isna().all() and (table["test"] == "exact").all()
    assert list(table["verdict"]) == [Verdict.DETECTED, Verdict.NOT_DETECTED, Verdict.DETECTED]


def test_the_committed_deterministic_slams_are_judged_exactly_and_the_stochastic_ones_by_the_test(tmp_path):
    """reports/slams: EKF-SLAM's repetitions are bit-identical on every case, FastSLAM's are not."""
    import shutil

    from faultlab.runner.store import load_results
    from tests.report.committed import REPORTS

    for slam, test in (("ekf", "exact"), ("fastslam1", "sign-flip")):
        store = tmp_path / slam
        store.mkdir()
        shutil.copy2(REPORTS / "slams" / "store" / slam / "results.sqlite", store / "results.sqlite")
        v = case_verdicts(load_results(store))
        assert len(v) >= 10 and (v["test"] == test).all(), slam
