"""The campaign's own settings, read from its results metadata."""

import pytest

from faultlab.stats.metadata import count_expected_jobs, read_rule, read_space
from faultlab.errors import ConfigError, ResultsError
from faultlab.space import table1_space
from faultlab.stats import DetectionRule


def test_the_stored_rule_is_read_and_missing_thresholds_are_the_papers():
    assert read_rule({"detection": {"abs_mm": 100.0, "rel": 0.5}}) == (DetectionRule(100.0, 0.5), True)
    assert read_rule({"detection": {"rel": 0.1}}) == (DetectionRule(250.0, 0.1), True)
    assert read_rule({}) == (DetectionRule(), False)
    with pytest.raises(ResultsError, match="invalid detection rule .*'abs_mm': -1"):
        read_rule({"detection": {"abs_mm": -1}})
    with pytest.raises(ResultsError, match="invalid detection rule"):
        read_rule({"detection": {"abs_mm": 1, "bogus": 2, "rel": "x"}})


def test_expected_jobs_from_the_stored_experiment():
    exp = {"runs": 3, "suites": [["systematic", 5], ["random", 5], ["fixed", 5]],
           "variants": ["baseline", "a", "b", "c"], "repetitions": 2}
    assert count_expected_jobs({"experiment": exp}) == 3 * 15 * 4 * 2
    assert count_expected_jobs({"experiment": {**exp, "suites": {"fixed": 2}}}) == 3 * 2 * 4 * 2
    assert count_expected_jobs({"experiment": {**exp, "suites": [["systematic", "auto"]]}}) is None
    assert count_expected_jobs({}) is None
    # a variant whose fault does not apply to the SLAM was skipped: it has no jobs
    skipped = [{"fault": "b", "step": "resample", "slam": "ekf", "n_units": 13, "reason": "..."}]
    assert count_expected_jobs({"experiment": exp, "skipped_variants": skipped}) == 3 * 15 * 3 * 2


def test_the_stored_space_overrides_table1():
    assert read_space({}).to_dict() == table1_space().to_dict()
    space = read_space({"experiment": {"space": {"map_size": {"classes": {"small": [4, 16], "big": [16, 400]}}}}})
    assert space["map_size"].class_names == ("small", "big")
    with pytest.raises(ConfigError, match="paper.toml \\[space\\]"):
        read_space({"experiment_source": "paper.toml", "experiment": {"space": {"map_size": {"nope": 1}}}})


def test_a_statistical_rule_stored_without_a_direction_is_read_as_it_ran_one_sided():
    old = read_rule({"detection": {"abs_mm": 250.0, "rel": 0.25, "rule": "statistical"}})[0]
    assert old.direction == "worse"
    new = DetectionRule(rule="statistical")
    assert new.to_dict()["direction"] == "either" and read_rule({"detection": new.to_dict()})[0] == new
    assert "direction" not in DetectionRule().to_dict()  # the paper rule's hash is unchanged


def test_expected_jobs_and_summary_of_adaptive_repetitions():
    # 1 run, 2 cases, baseline + a + b, K = 4 in stages 2 + 2.  Case 1: a stops after 2, b runs
    # on, so the baseline runs 4: 2 + 4 + 4 = 10 jobs.  Case 2: a and b stop after 2, so does the
    # baseline: 6 jobs.  16 of the fixed design's 24.
    from faultlab.stats.metadata import adaptive_summary

    exp = {"runs": 1, "suites": [["fixed", 2]], "variants": ["baseline", "a", "b"], "repetitions": 4,
           "adaptive": {"stages": [2, 4], "level": 0.05, "alternative": "greater", "futility": 0.5}}
    stops = [{"run": 1, "suite": "fixed", "case": 1, "variant": "a", "repetitions": 2, "reason": "futile"},
             {"run": 1, "suite": "fixed", "case": 2, "variant": "a", "repetitions": 2, "reason": "futile"},
             {"run": 1, "suite": "fixed", "case": 2, "variant": "b", "repetitions": 2, "reason": "curtailed"}]
    meta = {"experiment": exp, "adaptive_stops": stops}
    assert count_expected_jobs(meta) == 16
    assert count_expected_jobs(meta, adaptive=False) == 24
    text = adaptive_summary(meta)
    assert "3 (case, variant) pair(s) stopped early (1 curtailed, 2 futile)" in text
    assert "16 of the fixed design's 24 executions (33.3 % saved)" in text
    assert adaptive_summary({"experiment": {k: v for k, v in exp.items() if k != "adaptive"}}) is None


def test_judged_metric_is_the_stored_one_and_must_have_been_recorded():
    from faultlab.stats.metadata import judged_metric, metrics_note
    from faultlab.errors import ConfigError, ResultsError

    old = {"metric": "rms"}  # a store from before the metrics option recorded both
    assert judged_metric(old) == "rms" and judged_metric(old, "emd") == "emd" and metrics_note(old) is None
    assert judged_metric({"experiment": {"metric": "emd"}}) == "emd"
    only = {"metric": "rms", "metrics": ["rms"], "experiment_source": "e.toml"}
    assert judged_metric(only) == "rms" and "EMD was not computed" in metrics_note(only)
    with pytest.raises(ResultsError, match=r"e.toml cannot be judged by 'emd': the experiment recorded only 'rms'"):
        judged_metric(only, "emd")
    with pytest.raises(ResultsError, match="cannot be judged by 'emd'"):
        judged_metric({"metric": "emd", "metrics": ["rms"]})
    with pytest.raises(ConfigError, match="metric must be one of"):
        judged_metric(old, "mae")


def test_the_ate_is_judged_only_where_recorded_and_its_absence_is_no_note():
    from faultlab.stats.metadata import judged_metric, metrics_note
    from faultlab.errors import ResultsError

    new = {"metric": "rms", "metrics": ["rms", "emd", "ate"]}
    assert judged_metric(new, "ate") == "ate" and metrics_note(new) is None
    for before in ({"metric": "rms"}, {"metric": "rms", "metrics": ["rms", "emd"]}):  # stores from before the ATE
        assert metrics_note(before) is None  # their reports read as they did
        with pytest.raises(ResultsError, match="cannot be judged by 'ate': the experiment recorded only 'rms', 'emd'"):
            judged_metric(before, "ate")
    assert metrics_note({"metric": "rms", "metrics": ["rms", "ate"]}) == metrics_note({"metric": "rms",
                                                                                       "metrics": ["rms"]})
