"""A/A controls: each strategy against itself on alternate runs, false alarms per comparison and per family apart."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy import stats
from statsmodels.stats.multitest import multipletests
from statsmodels.stats import proportion

from faultlab.stats.controls import aa_controls, aa_halves, aa_summary
from faultlab.stats.killmatrix import KillMatrix

FAULTS = ("fault_a", "fault_b", "fault_c")


def run_matrix(detect) -> KillMatrix:
    """Kill matrix of two strategies over 6 runs of 8 cases; ``detect[strategy](run, case, fault)`` says
    whether a case alone detects a fault (p = 0.001, else 0.5)."""
    rows = []
    for s in ("systematic", "random"):
        for run in range(1, 7):
            for case in range(1, 9):
                for j, v in enumerate(FAULTS):
                    rows.append({"strategy": s, "run": run, "case": case, "variant": v,
                                 "p": 0.001 if detect[s](run, case, j) else 0.5, "crash": False, "timeout": False,
                                 "judged": True, "paper": False, "mean_diff_mm": 1.0, "direction": "worse",
                                 "mean_log_ratio": 0.01})
    return KillMatrix.from_frame(pd.DataFrame(rows))


def test_the_halves_are_alternate_runs_in_run_order():
    a, b = aa_halves([5, 1, 3, 2, 4, 1])
    assert a.tolist() == [1, 3, 5] and b.tolist() == [2, 4]


def test_a_planted_difference_between_one_strategys_halves_is_a_false_alarm_of_that_strategy_only():
    # systematic: fault_a detected on every case of even runs and none of odd ones (its halves differ),
    # fault_b on every other case of every run;
    # random: the same detections in every run (its halves agree)
    km = run_matrix({"systematic": lambda run, case, j: j == 0 and run % 2 == 0 or j == 1 and case % 2 == 0,
                     "random": lambda run, case, j: (case + j) % 3 == 0})
    c = aa_controls(km, FAULTS)
    sys_a = c[(c["strategy"] == "systematic") & (c["variant"] == "fault_a")].iloc[0]
    ref = proportion.test_proportions_2indep(0, 24, 24, 24, method="agresti-caffo", compare="diff").pvalue
    assert sys_a["diff"] == -1.0 and sys_a["p"] == pytest.approx(ref, rel=1e-12) and sys_a["false_alarm"]
    fam = c[(c["strategy"] == "systematic") & (c["comparison"] == "per fault")]
    assert fam["p_holm_family"].tolist() == pytest.approx(multipletests(fam["p"], method="holm")[1].tolist())
    assert fam["family_false_alarm"].all()
    assert not c.loc[c["strategy"] == "random", "false_alarm"].any()
    # the mean over the faults: Welch over the halves' cases, and paired t over consecutive runs
    mean_case = c[(c["strategy"] == "systematic") & (c["comparison"] == "mean over the faults")
                  & (c["unit"] == "case")].iloc[0]
    assert mean_case["diff"] == pytest.approx(-1 / 3) and mean_case["false_alarm"]
    rnd_run = c[(c["strategy"] == "random") & (c["unit"] == "run") & (c["comparison"] == "mean over the faults")]
    assert np.isnan(rnd_run["p"].iloc[0])  # every run scores alike: no spread, nothing to judge
    s = aa_summary(c).set_index(["comparison", "unit"])
    per_fault = s.loc[("per fault", "case")]
    assert (per_fault["comparisons"], per_fault["false_alarms"]) == (6, 1)
    assert (per_fault["families"], per_fault["families_with_false_alarm"]) == (2, 1)
    lo, hi = stats.binomtest(1, 6).proportion_ci(0.95, method="exact")
    assert (per_fault["false_alarm_rate_low"], per_fault["false_alarm_rate_high"]) == pytest.approx((lo, hi))
    # by run, both strategies' pairs of runs differ alike (systematic: -1/3 in each): no spread, not counted
    assert s.loc[("mean over the faults", "run"), "comparisons"] == 0


def test_under_the_null_the_per_comparison_rate_is_near_alpha():
    rng = np.random.default_rng(4)
    draws = {(s, r, c, j): rng.random() < 0.4 for s in ("systematic", "random") for r in range(1, 7)
             for c in range(1, 9) for j in range(3)}
    km = run_matrix({s: (lambda run, case, j, s=s: draws[(s, run, case, j)]) for s in ("systematic", "random")})
    c = aa_controls(km, FAULTS)
    assert len(c) == 2 * (3 + 2)
    assert c["false_alarm"].sum() <= 2


def test_a_study_of_mutants_controls_its_mutants_under_their_name():
    km = run_matrix({s: (lambda run, case, j: case % 2 == 0) for s in ("systematic", "random")})
    c = aa_controls(km, FAULTS, kind="mutant")
    assert set(c["comparison"]) == {"per mutant", "mean over the mutants"}
    s = aa_summary(c)
    assert s.loc[s["comparison"] == "per mutant", "family_rule"].item() == "Holm over the strategy's mutants"
