import csv
from collections import defaultdict
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from faultlab.errors import ResultsError
from faultlab.stats import DetectionRule, paper_table, percent, resolve_data_path

REPO = Path(__file__).resolve().parents[2]
RAW = REPO / "paper_repro" / "paper_table2_rms.csv"
REPORTED = REPO / "paper_repro" / "paper_table2_reported.csv"


def independent_counts(abs_mm=250.0, rel=0.25):
    """Detections per (suite, fault) and per (suite, fault, run), by a plain loop over the CSV."""
    with open(RAW, newline="") as fh:
        rows = list(csv.DictReader(fh))
    base = {(r["suite"], r["run"], r["case"]): float(r["rms_mm"]) for r in rows if r["variant"] == "baseline"}
    cell, count, total, per_run = {}, defaultdict(int), defaultdict(int), defaultdict(bool)
    for r in rows:
        if r["variant"] == "baseline":
            continue
        b = base[(r["suite"], r["run"], r["case"])]
        inc = float(r["rms_mm"]) - b
        hit = inc > abs_mm and inc >= rel * b
        cell[(r["suite"], r["variant"], int(r["run"]), int(r["case"]))] = hit
        count[(r["suite"], r["variant"])] += hit
        total[(r["suite"], r["variant"])] += 1
        per_run[(r["suite"], r["variant"], r["run"])] |= hit
    return cell, count, total, per_run


@pytest.fixture(scope="module")
def table():
    return paper_table(RAW, REPORTED)


def test_computed_detections_follow_the_rule_on_the_raw_data(table):
    cell, count, total, _ = independent_counts()
    rates = table.rates.set_index(["suite", "fault"])
    assert len(rates) == len(count) == 9
    for key, k in count.items():
        assert rates.loc[key, "detected"] == k and rates.loc[key, "n"] == total[key] == 15
        assert rates.loc[key, "computed_pct"] == int(np.floor(100 * k / 15 + 0.5))
    assert rates.loc[("systematic", "naive_resampling"), "detected"] == count[("systematic", "naive_resampling")]
    for (suite, fault, run, case), hit in cell.items():
        assert table.detected.loc[(suite, fault), (run, case)] == hit
    assert not table.detected.xs("baseline", level="variant").to_numpy().any()


def test_by_suite_follows_the_raw_data(table):
    _, _, _, per_run = independent_counts()
    bs = table.by_suite.set_index("suite")
    for suite in ("systematic", "fixed", "random"):
        pairs = [hit for (s, _, _), hit in per_run.items() if s == suite]
        assert bs.loc[suite, "n_pairs"] == len(pairs) == 9
        assert bs.loc[suite, "detected_pairs"] == sum(pairs)
        assert bs.loc[suite, "computed_pct"] == int(np.floor(100 * sum(pairs) / 9 + 0.5))


def test_which_cells_agree_with_the_printed_table(table):
    # The raw data reproduces every printed percentage except random / faulty rotation.
    _, count, _, _ = independent_counts()
    assert count[("random", "missing_angle_wrap")] == 11  # 73 %; Table II prints 80 %
    dis = table.disagreements
    assert list(zip(dis["column"], dis["suite"], dis["fault"])) == [
        ("Detected Faults", "random", "missing_angle_wrap")]
    assert dis["computed_pct"].iloc[0] == 73
    assert table.rates["agrees"].sum() == 8 and table.by_suite["agrees"].all()
    text = table.to_text()
    assert text.count("<-- DIFFERS") == 1
    assert "random / missing_angle_wrap: computed 73 %, printed 80 %" in text


def test_rms_table_is_the_raw_data(table):
    raw = pd.read_csv(RAW)
    assert table.rms.shape == (12, 15)
    for r in raw.itertuples():
        assert table.rms.loc[(r.suite, r.variant), (r.run, r.case)] == r.rms_mm
    assert list(table.rms.index.get_level_values("suite").unique()) == ["systematic", "fixed", "random"]


def test_rule_is_configurable():
    strict = paper_table(RAW, REPORTED, rule=DetectionRule(abs_mm=1000.0, rel=0.5))
    _, count, _, _ = independent_counts(1000.0, 0.5)
    rates = strict.rates.set_index(["suite", "fault"])
    for key, k in count.items():
        assert rates.loc[key, "detected"] == k
    assert rates.loc[("fixed", "missing_angle_wrap"), "detected"] == 1  # only 101 -> 2239 mm


def test_percent_rounds_half_up_like_the_paper():
    assert [percent(4, 15), percent(2, 15), percent(13, 15), percent(6, 9), percent(7, 9)] == [27, 13, 87, 67, 78]
    assert percent(1, 8) == 13 and percent(3, 8) == 38 and percent(0, 5) == 0  # exact halves go up
    np.testing.assert_array_equal(percent([1, 2], [2, 3]), [50, 67])


def test_bad_paper_files(tmp_path):
    bad = tmp_path / "raw.csv"
    bad.write_text("suite,variant,run,case\nfixed,baseline,1,1\n")
    with pytest.raises(ResultsError, match="missing column.*rms_mm"):
        paper_table(bad, REPORTED)
    bad.write_text("suite,variant,run,case,rms_mm\nfixed,baseline,1,1,12\nfixed,baseline,1,2,abc\n")
    with pytest.raises(ResultsError, match="row 3: column rms_mm has invalid value 'abc'"):
        paper_table(bad, REPORTED)


def test_by_suite_rows_in_the_reported_file_are_used(tmp_path):
    rep = tmp_path / "reported.csv"
    rep.write_text(REPORTED.read_text() + "systematic,by_suite,90\n")
    t = paper_table(RAW, rep)
    bs = t.by_suite.set_index("suite")
    assert bs.loc["systematic", "reported_pct"] == 90 and not bs.loc["systematic", "agrees"]
    assert np.isnan(bs.loc["fixed", "reported_pct"])


def test_data_path_resolution(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert resolve_data_path(None, "paper_repro/paper_table2_rms.csv").samefile(RAW)  # the shipped copy
    (tmp_path / "paper_repro").mkdir()
    local = tmp_path / "paper_repro" / "paper_table2_rms.csv"
    local.write_text("x")
    assert resolve_data_path(None, "paper_repro/paper_table2_rms.csv") == local  # cwd first
    with pytest.raises(ResultsError, match="not found: tried .*nope.csv"):
        resolve_data_path("nope.csv", "unused")
