"""The verdict of faultlab compare from planted records: crashes the baseline did not have, the pooled
test over cases, missing cases, the exit statuses; and its reports (no NaN or inf written as a number)."""

import json
import math

import numpy as np
from junitparser import Failure, JUnitXml
from scipy.stats import fisher_exact, ttest_1samp

from faultlab.analysis.compare import EXIT_NOT_EQUIVALENT, EXIT_OK, EXIT_REGRESSION, compare_records
from faultlab.campaigns.compare import CaseErrors
from faultlab.report.compare import compare_json, write_compare_reports
from faultlab.report.html.compare import write_compare_html

SPEC = {"slam": "a", "command": [], "suite": "random", "n_cases": 12, "n_steps": 60, "seed": 1, "repetitions": 8,
        "rep_seed": 1}


def _records(factor, n=12, k=8, seed=0, crash=None, deterministic=False):
    rng = np.random.default_rng(seed)
    out = []
    for i in range(n):
        level = 50.0 * (1 + i)
        reps = 1 if deterministic else k
        e = level * factor * np.exp(rng.normal(0, 0.0 if deterministic else 0.1, reps))
        if crash and i in crash:
            e[: crash[i]] = np.nan
        out.append(CaseErrors(f"random-1-{i:03d}", {"map_size": 4.0}, 60, 9, deterministic, tuple(e),
                              tuple("" if np.isfinite(x) else "IndexError: boom" for x in e)))
    return out


def test_pooled_verdict_is_the_paired_t_test_over_case_means():
    b, c = _records(1.0, seed=1), _records(1.3, seed=2)
    r = compare_records(SPEC, b, {**SPEC, "slam": "b"}, c)
    d = [np.mean(np.log(y.errors_mm)) - np.mean(np.log(x.errors_mm)) for x, y in zip(b, c)]
    ref = ttest_1samp(d, 0.0, alternative="greater")
    assert r.pooled.p_regression == ref.pvalue and r.pooled.n == 12
    assert r.regression and r.exit_code() == EXIT_REGRESSION


def test_the_same_slam_again_is_equivalent_and_exit_3_only_when_equivalence_is_missing():
    r = compare_records(SPEC, _records(1.0, seed=1), SPEC, _records(1.0, seed=2))
    assert r.pooled.verdict == "equivalent" and r.exit_code(require_equivalence=True) == EXIT_OK
    r = compare_records(SPEC, _records(1.0, seed=1), SPEC, _records(0.5, seed=2))
    assert r.pooled.verdict == "improvement" and r.exit_code() == EXIT_OK
    assert r.exit_code(require_equivalence=True) == EXIT_NOT_EQUIVALENT


def test_crashes_the_baseline_did_not_have_are_a_regression():
    # deterministic: exactly
    r = compare_records(SPEC, _records(1.0, deterministic=True), SPEC,
                        _records(1.0, deterministic=True, crash={3: 1}))
    assert r.regression and [c.case_id for c in r.crash_regressions] == ["random-1-003"]
    # stochastic: Fisher exact at alpha / cases -- 8 of 8 failed runs are, 1 of 8 is not
    many = compare_records(SPEC, _records(1.0, seed=1), SPEC, _records(1.0, seed=2, crash={3: 8}))
    few = compare_records(SPEC, _records(1.0, seed=1), SPEC, _records(1.0, seed=2, crash={3: 1}))
    p = fisher_exact([[8, 0], [0, 8]], alternative="greater")[1]
    assert p <= 0.05 / 12 and many.regression and many.cases[3].crash_p == p
    assert not few.regression and not few.cases[3].crash_regression


def test_cases_recorded_in_one_version_only_are_missing_and_block_equivalence():
    r = compare_records(SPEC, _records(1.0, seed=1), SPEC, _records(1.0, seed=2)[:-1])
    assert r.missing == ("random-1-011",) and not r.equivalent


def test_reports_write_no_nan_or_inf_as_a_number(tmp_path):
    r = compare_records(SPEC, _records(1.0, deterministic=True), SPEC,
                        _records(1.0, deterministic=True, crash={0: 1}))
    md, js, xml = write_compare_reports(r, tmp_path)
    text = js.read_text()
    assert "NaN" not in text and "Infinity" not in text
    data = json.loads(text)
    assert data["regression"] and data["exit_status"] == EXIT_REGRESSION
    assert "inf" not in md.read_text().replace("info", "")
    failed = [c.name for s in JUnitXml.fromfile(str(xml)) for c in s if any(isinstance(x, Failure) for x in c.result)]
    assert failed == ["random-1-000"]
    assert compare_json(r)["pooled"]["ci_percent"] == [None, None]  # judged exactly: no interval
    site = write_compare_html(r, tmp_path / "html")
    assert 'id="table-cases"' in site.index.read_text()
    assert math.isnan(r.pooled.ci_low)
