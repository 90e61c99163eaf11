"""Several SLAMs under one protocol (faultlab.analysis.slams)."""

import warnings

import numpy as np
import pytest

from faultlab.analysis.slams import ACCURACY, NOT_JUDGED, SENSITIVITY, compare_slams
from faultlab.faults import FaultNotApplicableWarning
from faultlab.runner import load_results, run_experiment
from faultlab.runner.experiment import parse_experiment
from faultlab.stats.cases import case_rates


@pytest.fixture(scope="module")
def stores(tmp_path_factory):
    """One tiny campaign per SLAM: 2 fixed cases, 40 steps, K = 2, the paper's rule."""
    root = tmp_path_factory.mktemp("slams")
    out = {}
    for label, slam in {"fs1": {"name": "fastslam", "particles": 8}, "ekf": {"name": "ekf"},
                        "fs1u": {"name": "fastslam", "particles": 8, "association": "unknown"}}.items():
        exp = parse_experiment({"seed": 3, "suites": {"fixed": 2}, "n_steps": 40, "repetitions": 2,
                                "variants": ["baseline", "naive_resampling", "motion_sign_error"], "slam": slam},
                               source=label)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", FaultNotApplicableWarning)
            run_experiment(exp, root / label, jobs=1, progress=False)
        out[label] = root / label
    return out


def test_the_tables_hold_each_slams_figures(stores):
    c = compare_slams(stores, not_installed=["gtsam"])
    assert list(c.accuracy.columns) == list(ACCURACY) and list(c.sensitivity.columns) == list(SENSITIVITY)
    assert list(c.not_judged.columns) == list(NOT_JUDGED)
    acc = c.accuracy.set_index("slam")
    assert acc.loc["fs1u", "metric"] == "emd" and acc.loc["fs1", "metric"] == "rms"
    for label, store in stores.items():
        df = load_results(store)
        base = df[df.variant == "baseline"]
        col = f"{acc.loc[label, 'metric']}_mm"
        per_case = base.groupby("case")[col].mean()
        assert acc.loc[label, "mean_mm"] == pytest.approx(per_case.mean())
        assert acc.loc[label, "n_cases"] == 2 and acc.loc[label, "n_jobs"] == 4
    # EKF-SLAM has no resampling: that fault is not applicable there, and listed as such
    nj = c.not_judged
    assert ((nj.slam == "ekf") & (nj.fault == "naive_resampling") & (nj.what == "not applicable")).any()
    assert ((nj.slam == "gtsam") & (nj.what == "not run")).any()
    sens = c.sensitivity.set_index(["slam", "fault"])
    assert ("ekf", "naive_resampling") not in sens.index
    # the case rates are those of the per-store verdicts, pooled over the suites
    from faultlab.analysis import analyse
    v = analyse(stores["fs1"], paper=False).case_verdicts
    ref = case_rates(v.assign(suite="all")).set_index("fault")
    for fault in ("naive_resampling", "motion_sign_error"):
        assert sens.loc[("fs1", fault), "k"] == ref.loc[fault, "k"]
        assert sens.loc[("fs1", fault), "n"] == ref.loc[fault, "n"]
        # the detectable shift: the verdicts' own, summarised over the fault's judged cases
        mde = v.loc[(v.fault == fault) & v.mde_mm.notna(), "mde_mm"].to_numpy(float)
        assert mde.size == 2
        got = sens.loc[("fs1", fault), ["mde_median_mm", "mde_min_mm", "mde_max_mm"]].to_numpy(float)
        np.testing.assert_array_equal(got, [np.median(mde), mde.min(), mde.max()])
    # K = 2 repetitions: the exact test cannot reach alpha, so no shift is detectable on any case
    assert sens.loc[("fs1", "motion_sign_error"), "mde_median_mm"] == np.inf
    # the per-repetition rate of a SLAM without ids counts repetitions flagged by its EMD
    df = load_results(stores["fs1u"])
    b = df[df.variant == "baseline"].set_index(["case", "rep"]).emd_mm
    f = df[df.variant == "motion_sign_error"].set_index(["case", "rep"]).emd_mm
    flagged = int(((f > b + 250) & (f >= 1.25 * b)).sum())
    assert sens.loc[("fs1u", "motion_sign_error"), "rep_k"] == flagged
    assert sens.loc[("fs1u", "motion_sign_error"), "rep_n"] == 4


def test_a_deterministic_slam_is_judged_exactly_and_its_cases_are_the_unit(stores, tmp_path):
    """EKF-SLAM gives the same map for every seed: under the statistical rule its K = 2 repetitions (too few
    for the sign-flip test) are copies of one execution, so each case is judged by its exact difference,
    while FastSLAM's K = 2 cannot be judged."""
    rule = {"rule": "statistical", "alpha": 0.05, "family": "fault"}
    for label, slam in {"ekf": {"name": "ekf"}, "fs1": {"name": "fastslam", "particles": 8}}.items():
        exp = parse_experiment({"seed": 3, "suites": {"fixed": 2}, "n_steps": 40, "repetitions": 2,
                                "variants": ["baseline", "motion_sign_error"], "slam": slam, "detection": rule},
                               source=label)
        run_experiment(exp, tmp_path / label, jobs=1, progress=False)
    c = compare_slams({"ekf": tmp_path / "ekf", "fs1": tmp_path / "fs1"})
    sens = c.sensitivity.set_index(["slam", "fault"])
    ekf = sens.loc[("ekf", "motion_sign_error")]
    assert ekf["n_exact"] == ekf["n"] == 2 and ekf["n_cannot_judge"] == 0
    res = load_results(tmp_path / "ekf")
    faulty = res[res.variant == "motion_sign_error"].pivot(index="case", columns="rep", values="rms_mm")
    b = res[res.variant == "baseline"].pivot(index="case", columns="rep", values="rms_mm")
    assert (faulty[0] == faulty[1]).all() and (b[0] == b[1]).all()  # the determinism is real
    assert ekf["k"] == int((faulty[0] != b[0]).sum()) == 2
    fs1 = sens.loc[("fs1", "motion_sign_error")]
    assert fs1["n_exact"] == 0 and fs1["n_cannot_judge"] == 2  # K = 2 cannot reach alpha by the test
