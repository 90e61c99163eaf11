"""Tables that arrange results and statistics, checked against hand-made expectations."""

import math

import numpy as np
import pandas as pd

from faultlab.analysis.schema import ALL_VARIANTS, CASES, COVERAGE, RUNTIMES, TABLE2_CELLS
from faultlab.analysis.tables import (
    case_spec,
    case_table,
    coverage_table,
    detection_rate_table,
    oracle_summary_table,
    runtime_table,
    table2_cell_table,
)
from faultlab.space import coverage, table1_space
from faultlab.stats import outcomes, tabulate_rates
from tests.stats.synthetic import frame, job


def _results():
    rows = []
    for run in (1, 2):
        for suite in ("random", "fixed"):
            for case in (1, 2):
                for rep in (0, 1):
                    b = 100.0 * case
                    rows.append(job(run, suite, case, "baseline", rep, b, map_size=10.0 * case + run,
                                    runtime_s=1.0))
                    faulty = b + 500.0 if (rep == 1 or suite == "random") else b + 1.0
                    status = "crash" if (run, suite, case, rep) == (2, "fixed", 2, 0) else "ok"
                    rows.append(job(run, suite, case, "motion_sign_error", rep, faulty, status,
                                    map_size=10.0 * case + run))
    df = frame(rows)
    df["runtime_s"] = np.arange(len(df), dtype=float)
    return df


def test_table2_cells_show_one_repetition_and_mark_detections():
    res = _results()
    cells = table2_cell_table(res, outcomes(res), source="this run", rep=0)
    assert list(cells.columns) == list(TABLE2_CELLS.columns) and len(cells) == len(res) / 2
    c = cells.set_index(["suite", "variant", "run", "case"])
    # random: +500 mm on a 100/200 mm baseline -> detected; fixed rep 0: +1 mm -> not; the crash has no RMS
    assert c.loc[("random", "motion_sign_error", 1, 1), "detected"]
    assert not c.loc[("fixed", "motion_sign_error", 1, 1), "detected"]
    crash = c.loc[("fixed", "motion_sign_error", 2, 2)]
    assert crash["status"] == "crash" and math.isnan(crash["rms_mm"]) and not crash["detected"]
    assert not c.xs("baseline", level="variant")["detected"].any()
    assert c.loc[("fixed", "baseline", 2, 2), "rms_mm"] == 200.0
    rep1 = table2_cell_table(res, outcomes(res), source="paper", rep=1).set_index(["suite", "variant", "run", "case"])
    assert rep1.loc[("fixed", "motion_sign_error", 1, 1), "detected"] and (rep1["source"] == "paper").all()


def test_detection_rates_carry_the_papers_figures_beside():
    res = _results()
    rates = tabulate_rates(outcomes(res))
    paper = pd.DataFrame({"suite": ["fixed"], "fault": ["motion_sign_error"], "detected": [4], "n": [15],
                          "rate": [4 / 15], "reported_pct": [27.0]})
    table = detection_rate_table(rates, paper).set_index(["suite", "variant"])
    assert table.loc[("fixed", "motion_sign_error"), ["paper_k", "paper_n", "paper_printed_pct"]].tolist() == [4, 15, 27.0]
    assert table.loc[("random", "motion_sign_error"), ["paper_k", "paper_n"]].isna().all()
    assert table.loc[("fixed", "motion_sign_error"), "crash"] == 1
    pd.testing.assert_series_equal(table["rate"].reset_index(drop=True), rates["rate"], check_names=False)
    alone = detection_rate_table(rates, None)
    assert alone["paper_k"].isna().all() and alone["paper_rate"].isna().all()


def test_cases_and_their_coverage_match_the_space_module():
    res = _results()
    cases = case_table(res)
    assert list(cases.columns) == list(CASES.columns) and len(cases) == 2 * 2 * 2
    assert list(zip(cases["run"], cases["suite"], cases["case"]))[:4] == [
        (1, "fixed", 1), (1, "fixed", 2), (1, "random", 1), (1, "random", 2)]  # Table II suite order
    space = table1_space()
    cov = coverage_table(cases, space)
    assert list(cov.columns) == list(COVERAGE.columns)
    run1 = cov[(cov["run"] == 1) & (cov["suite"] == "random")].reset_index(drop=True)
    expected = coverage([case_spec(r) for r in cases[(cases["run"] == 1) & (cases["suite"] == "random")]
                         .to_dict("records")], space).table()
    pd.testing.assert_frame_equal(run1[list(expected.columns)], expected, check_dtype=False)
    pooled = cov[cov["run"].isna()]
    assert set(pooled["suite"]) == {"fixed", "random"}
    assert pooled.loc[pooled["parameter"] == "overall", "counts"].tolist() == ["4 cases", "4 cases"]


def test_runtimes_per_variant_and_overall():
    res = _results()
    rt = runtime_table(res)
    assert list(rt.columns) == list(RUNTIMES.columns)
    assert rt["variant"].tolist() == ["baseline", "motion_sign_error", ALL_VARIANTS]
    base = res.loc[res["variant"] == "baseline", "runtime_s"].to_numpy()
    assert rt.iloc[0].tolist()[1:] == [len(base), np.median(base), base.max(), base.sum()]
    assert rt.iloc[2]["total_s"] == res["runtime_s"].sum() and rt.iloc[2]["n_jobs"] == len(res)


def test_oracle_summary_counts_by_hand():
    oracle = pd.DataFrame({"suite": ["random"] * 3 + ["fixed"], "fault": ["f"] * 4,
                           "p": [0.01, np.nan, 0.2, 0.5], "p_min": [0.001, np.nan, 0.001, 0.002],
                           "p_holm": [0.03, np.nan, 0.4, 0.5], "detected": [True, False, False, False]})
    s = oracle_summary_table(oracle).set_index("suite")
    assert s.loc["random", ["n_cases", "n_tested", "n_detected"]].tolist() == [3, 2, 1]
    assert s.loc["random", "min_p_holm"] == 0.03 and s.loc["fixed", "min_p_min"] == 0.002
    assert oracle_summary_table(oracle.iloc[:0]).empty
