"""The shipped paper-k10 experiment, run in a tiny reduced form: the statistical rule end to end."""

from __future__ import annotations

import pytest

from faultlab.analysis import analyse
from faultlab.config import ExperimentOverrides
from faultlab.runner import load_experiment, run_experiment
from faultlab.inference.exact import alternative_of, min_pairs
from faultlab.vocabulary import REPLICA


def test_paper_k10_repetitions_are_the_fewest_the_two_sided_holm_family_needs():
    exp = load_experiment("paper-k10")
    family = exp.runs * sum(s.n_cases for s in exp.suites)  # family "fault": every case of one fault
    alternative = alternative_of(exp.detection.direction)
    assert exp.detection.family == "fault" and alternative == "two-sided"
    assert exp.repetitions == min_pairs(exp.detection.alpha / family, alternative=alternative)


@pytest.mark.slow
def test_paper_k10_in_tiny_form_judges_cases_by_the_statistical_rule(tmp_path):
    exp = load_experiment("paper-k10")
    assert exp.detection.rule == "statistical" and REPLICA in exp.variants
    tiny = exp.apply(ExperimentOverrides(runs=1, repetitions=7, n_steps=25, suites={"random": 1, "fixed": 1},
                                         particles=8, variants=("baseline", REPLICA, "motion_sign_error")))
    run_experiment(tiny, tmp_path, jobs=1, progress=False)
    a = analyse(tmp_path, paper=False)
    assert a.rule.rule == "statistical" and a.rule.family == "fault"
    v = a.case_verdicts
    assert set(v["fault"]) == {REPLICA, "motion_sign_error"} and (v["rule"] == "statistical").all()
    assert len(v) == 2 * 2 and (v["n_reps"] == 7).all()  # two variants on the two cases of the replaced [suites]
    judged = v[v["verdict"] != "cannot_judge"]
    assert judged["p_holm"].notna().all() and (judged["p_holm"] >= judged["p"]).all()
    assert set(a.replica_false_alarms["rule"]) == {"paper", "statistical"}
    assert set(a.case_rates["fault"]) == {"motion_sign_error"}  # the replica is a control, not a fault
