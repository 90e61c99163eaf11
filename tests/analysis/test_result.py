"""The Analysis: computed once, with the campaign's stored rule, saved and loaded back exactly."""

import ast
import hashlib
import dataclasses
import json
import shutil
import sqlite3
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

import faultlab.stats.detection
from faultlab.analysis import Analysis, Note, analyse
from faultlab.analysis.effects import CAMPAIGN_EFFECT_COLUMNS
from faultlab.analysis.schema import TABLES
from faultlab.precision import FLOAT_FORMAT
from faultlab.errors import ConfigError, ResultsError
from faultlab.runner import load_metadata, load_results
from faultlab.runner.store import META_CHECKSUM_KEY, meta_checksum
from faultlab.stats.paper import data_label
from faultlab.stats import (
    DetectionRule,
    by_suite,
    compare_suites,
    detection_rates,
    false_alarm_rate,
    oracle_detections,
    outcomes,
    paper_table,
    parameter_effects,
    resolve_data_path,
)
from tests.stats.synthetic import frame, job

REPO = Path(__file__).resolve().parents[2]
STORE = REPO / "reports" / "store"
STRICT = {"detection": {"abs_mm": 400.0, "rel": 1.0}}


def rich_results() -> pd.DataFrame:
    """Two suites, two faults, K = 3 repetitions, a crash and a timeout, varied parameters."""
    rng = np.random.default_rng(3)
    rows = []
    for run in (1, 2):
        for suite in ("systematic", "random"):
            for case in (1, 2, 3):
                size = float(rng.uniform(16, 400))
                for rep in range(3):
                    b = float(rng.uniform(50, 300))
                    rows.append(job(run, suite, case, "baseline", rep, b, map_size=size))
                    # +300 mm: detected by the paper's rule (> 250 mm, >= 25 %), not by STRICT (> 400 mm)
                    hit = rng.random() < size / 500
                    rows.append(job(run, suite, case, "naive_resampling", rep, b + (300.0 if hit else 20.0),
                                    map_size=size))
                    status = {(1, "random", 2, 0): "crash", (2, "systematic", 1, 2): "timeout"}.get(
                        (run, suite, case, rep), "ok")
                    rows.append(job(run, suite, case, "motion_sign_error", rep, b + 5000.0 * (case > 1), status,
                                    map_size=size))
    return frame(rows)


@pytest.fixture(scope="module")
def rich():
    return rich_results()


@pytest.fixture(scope="module")
def strict(rich):
    return Analysis.from_frame(rich, STRICT)


def _named(stats_table: pd.DataFrame, schema_name: str) -> pd.DataFrame:
    """A statistic's table with its schema's column kinds (text as object, not pandas' string dtype)."""
    return {s.name: s for s in TABLES}[schema_name].conform(stats_table)


def test_every_statistic_uses_the_stored_rule(rich, strict):
    rule = DetectionRule(400.0, 1.0)
    assert strict.rule == rule and not strict.notes_on("rule")
    first = rich[rich["rep"] == 0]  # the paper's protocol: one SLAM pair per case (the shown repetition)
    expected = detection_rates(first, rule=rule).rename(columns={"fault": "variant"})
    mine = strict.detection_rates[list(expected.columns)]
    pd.testing.assert_frame_equal(mine, expected.astype(mine.dtypes.to_dict()))
    pd.testing.assert_frame_equal(strict.by_suite, _named(by_suite(first, rule=rule), "by_suite"))
    pd.testing.assert_frame_equal(strict.false_alarms, _named(false_alarm_rate(rich, rule=rule), "false_alarms"))
    pd.testing.assert_frame_equal(strict.suite_comparisons,
                                  _named(compare_suites(first, rule=rule), "suite_comparisons"))
    pd.testing.assert_frame_equal(strict.parameter_effects,
                                  _named(parameter_effects(first, rule=rule), "parameter_effects"))
    pd.testing.assert_frame_equal(strict.oracle, _named(oracle_detections(rich), "oracle"))
    oc = outcomes(rich, rule=rule)
    this = strict.outcomes[strict.outcomes["source"] == "this run"].reset_index(drop=True)
    pd.testing.assert_frame_equal(this, _named(oc.assign(source="this run"), "outcomes"))
    # the paper's data is judged by the same rule
    pd.testing.assert_frame_equal(strict.paper_rates, _named(paper_table(
        resolve_data_path(None, "paper_repro/paper_table2_rms.csv"),
        resolve_data_path(None, "paper_repro/paper_table2_reported.csv"), rule=rule).rates, "paper_rates"))
    # ... and the default rule would have given other figures
    default = Analysis.from_frame(rich, {})
    assert default.rule == DetectionRule() and default.notes_on("rule")
    nr = lambda a: a.detection_rates.set_index(["suite", "variant"]).loc[("random", "naive_resampling"), "k"]
    assert nr(strict) == 0 < nr(default)


def test_the_paper_protocol_tables_do_not_change_with_k_nor_count_the_replica(rich):
    """More repetitions of the same cases, or an A/A replica, leave Table II's rates and "by Suite" alone."""
    one = Analysis.from_frame(rich[rich["rep"] == 0], STRICT, paper=False)
    replica = rich[rich["variant"] == "baseline"].assign(variant="baseline_replica", rms_mm=lambda d: d["rms_mm"] + 900)
    more = Analysis.from_frame(pd.concat([rich, replica], ignore_index=True), STRICT, paper=False)
    for name in ("detection_rates", "by_suite", "suite_comparisons"):
        pd.testing.assert_frame_equal(getattr(more, name), getattr(one, name), obj=name)
    assert "baseline_replica" not in set(more.detection_rates["variant"])
    # while the case-level verdicts use all K repetitions and judge the replica apart
    assert set(more.case_verdicts["fault"]) >= {"baseline_replica", "naive_resampling"}
    assert not more.replica_false_alarms.empty


def test_every_job_is_classified_once_per_data_set(rich, monkeypatch):
    calls = []
    original = faultlab.stats.detection.classify
    monkeypatch.setattr(faultlab.stats.detection, "classify",
                        lambda pairs, **kw: calls.append(len(pairs)) or original(pairs, **kw))
    Analysis.from_frame(rich, STRICT, paper=False)
    assert calls == [len(rich) * 2 // 3]  # this run's faulty jobs, once
    calls.clear()
    Analysis.from_frame(rich, STRICT)
    assert sorted(calls) == [len(rich) * 2 // 3, 9 * 15]  # and the paper's 135 faulty cells, once


def _written(frame: pd.DataFrame) -> pd.DataFrame:
    """``frame`` with every float as a table holds it (FLOAT_FORMAT, Python's own rounding; an infinite
    value is written as a blank cell, which reads back as NaN)."""
    out = frame.copy()
    for c in out.columns:
        if out[c].dtype == np.float64:
            out[c] = [float(FLOAT_FORMAT % v) if not np.isinf(v) else np.nan for v in out[c]]
    return out


def test_save_and_load_round_trip_at_the_written_precision(strict, tmp_path):
    strict.save(tmp_path / "a")
    assert sorted(p.name for p in (tmp_path / "a").iterdir()) == sorted(
        [f"{s.name}.csv" for s in TABLES] + ["analysis.json"])
    back = Analysis.load(tmp_path / "a")
    written = dataclasses.replace(strict, **{s.name: _written(getattr(strict, s.name)) for s in TABLES})
    assert back.equals(written) and written.equals(back)
    for s in TABLES:
        pd.testing.assert_frame_equal(getattr(back, s.name), getattr(written, s.name), check_exact=True)
        assert not getattr(strict, s.name).empty or s.name in ("cases", "replica_false_alarms"), s.name
    assert (back.rule, back.alpha, back.rep, back.parameters, back.notes, back.metadata, back.paper_raw) == (
        strict.rule, strict.alpha, strict.rep, strict.parameters, strict.notes, strict.metadata, strict.paper_raw)
    assert back.paper_table.to_text() == strict.paper_table.to_text()
    # saving the loaded analysis writes the same bytes
    back.save(tmp_path / "b")
    for p in (tmp_path / "a").iterdir():
        assert p.read_bytes() == (tmp_path / "b" / p.name).read_bytes(), p.name


def test_equals_notices_any_change(strict, tmp_path):
    assert not strict.equals(dataclasses.replace(strict, alpha=0.1))
    assert not strict.equals(dataclasses.replace(strict, notes=strict.notes + (Note("rule", "x"),)))
    rates = strict.detection_rates.copy()
    rates.loc[0, "wilson_low"] = np.nextafter(rates.loc[0, "wilson_low"], 1.0)  # one ulp
    assert not strict.equals(dataclasses.replace(strict, detection_rates=rates))
    strict.save(tmp_path)
    path = tmp_path / "by_suite.csv"
    path.write_text(path.read_text().replace("systematic", "Systematic", 1))
    assert not Analysis.load(tmp_path).equals(strict)


def test_load_refuses_what_is_not_a_saved_analysis(strict, tmp_path):
    with pytest.raises(ResultsError, match="cannot read a saved analysis"):
        Analysis.load(tmp_path)
    strict.save(tmp_path)
    data = json.loads((tmp_path / "analysis.json").read_text())
    (tmp_path / "analysis.json").write_text(json.dumps({**data, "format": 99}))
    with pytest.raises(ResultsError, match="not a saved analysis of format 2"):
        Analysis.load(tmp_path)
    (tmp_path / "analysis.json").write_text(json.dumps({**data, "rule": {"abs_mm": -1}}))
    with pytest.raises(ResultsError, match="malformed saved analysis"):
        Analysis.load(tmp_path)
    (tmp_path / "analysis.json").write_text(json.dumps(data))
    (tmp_path / "oracle.csv").unlink()
    with pytest.raises(ResultsError, match="oracle.csv: cannot read table oracle"):
        Analysis.load(tmp_path)


def test_paper_table_view_equals_the_stats_function(strict):
    ref = paper_table(resolve_data_path(strict.paper_raw, "paper_repro/paper_table2_rms.csv"),
                      resolve_data_path(strict.paper_reported, "paper_repro/paper_table2_reported.csv"),
                      rule=strict.rule)
    view = strict.paper_table
    pd.testing.assert_frame_equal(view.rms, ref.rms)
    pd.testing.assert_frame_equal(view.detected, ref.detected)
    assert view.to_text() == ref.to_text()


def test_table2_cells_show_the_chosen_repetition(rich):
    a = Analysis.from_frame(rich, STRICT, rep=2, paper=False)
    cells = a.table2_cells.set_index(["suite", "variant", "run", "case"])
    row = rich[(rich["rep"] == 2) & (rich["variant"] == "baseline") & (rich["run"] == 1)
               & (rich["suite"] == "random") & (rich["case"] == 3)]
    assert cells.loc[("random", "baseline", 1, 3), "rms_mm"] == row["rms_mm"].iloc[0]
    assert cells.loc[("systematic", "motion_sign_error", 2, 1), "status"] == "timeout"
    assert set(a.table2_cells["source"]) == {"this run"} and not a.has_paper and a.paper_table is None
    with pytest.raises(ResultsError, match="no results for SLAM repetition 5; the store has \\[0, 1, 2\\]"):
        Analysis.from_frame(rich, STRICT, rep=5)


def test_summaries_of_the_campaign(strict, rich):
    assert strict.n_rows == len(rich) and strict.n_reps == 3
    assert strict.status_counts == {"ok": len(rich) - 2, "crash": 1, "timeout": 1}
    assert strict.cases_per_run == {"systematic": 3, "random": 3}
    assert strict.expected_jobs is None  # no experiment in the metadata


def test_notes_say_what_could_not_be_done_and_why(tmp_path):
    rows = []
    for case in (1, 2):
        rows += [job(1, "fixed", case, "baseline", 0, 100.0), job(1, "fixed", case, "naive_resampling", 0, 100.0)]
    meta = {"metric": "emd", "detection": {"abs_mm": 250.0, "rel": 0.25},
            "experiment": {"runs": 1, "suites": [["fixed", 3]], "variants": ["baseline", "naive_resampling"],
                           "repetitions": 1, "space": {"map_size": {"nope": 1}}}}
    a = Analysis.from_frame(frame(rows), meta, paper_raw=tmp_path / "missing.csv")
    topics = [n.topic for n in a.notes]
    assert topics == ["metric", "equivalent_faults", "paper", "campaign", "coverage", "false_alarms", "oracle",
                      "suite_comparisons", "verdicts", "replica_false_alarms"]
    text = {n.topic: n.text for n in a.notes}
    assert "primary metric is 'emd'" in text["metric"]
    assert text["equivalent_faults"].startswith("naive_resampling: every result is identical")
    assert "paper's data was not found" in text["paper"] and "missing.csv" in text["paper"]
    assert "incomplete: 4 of 6 jobs" in text["campaign"]
    assert "stored parameter space is invalid" in text["coverage"] and a.coverage.empty
    assert "need at least 2 SLAM repetitions per case (this run has 1)" in text["false_alarms"]
    assert "no suite pair" in text["suite_comparisons"]
    eff = a.parameter_effects  # fitted nothing, and says why in its rows
    assert eff["term"].iloc[-1] == "(model)" and eff["coef"].isna().all() and "does not vary" in eff["note"].iloc[-1]
    assert isinstance(a.notes[0], Note) and str(a.notes[0]) == a.notes[0].text
    assert a.notes_on("oracle", "paper") == (a.notes[6], a.notes[2])[::-1]


def test_bad_input_is_refused(rich, strict):
    with pytest.raises(ResultsError, match="no rows"):
        Analysis.from_frame(rich.iloc[:0])
    with pytest.raises(ConfigError, match="alpha must lie in"):
        Analysis.from_frame(rich, alpha=1.5)
    with pytest.raises(ConfigError, match="unknown parameter 'size'"):
        Analysis.from_frame(rich, parameters=["size"])
    with pytest.raises(ResultsError, match="invalid detection rule"):
        Analysis.from_frame(rich, {"detection": {"rel": -0.5}})
    with pytest.raises(ResultsError, match="table cases: missing column\\(s\\) n_landmarks"):
        Analysis.from_frame(rich.drop(columns=["n_landmarks"]))
    with pytest.raises(KeyError, match="no table 'nope'"):
        strict.table("nope")
    assert strict.table("oracle") is strict.oracle


def test_analyse_reads_the_store_and_its_rule(tmp_path):
    store = tmp_path / "store"
    shutil.copytree(STORE, store)
    a = analyse(store, paper=False)
    assert a.rule == DetectionRule() and a.n_rows == 180 and a.metadata == json.loads(json.dumps(load_metadata(store)))
    a.save(tmp_path / "saved")  # the live analysis knows where its store is; the saved one names no machine path
    assert json.loads((tmp_path / "saved" / "analysis.json").read_text())["metadata"]["path"] == "store/results.sqlite"
    with sqlite3.connect(store / "results.sqlite") as conn:
        conn.execute("UPDATE meta SET value = ? WHERE key = 'detection'", (json.dumps(STRICT["detection"]),))
        # a store written with another rule carries the checksum of its own metadata
        meta = {k: json.loads(v) for k, v in conn.execute("SELECT key, value FROM meta")}
        conn.execute("UPDATE meta SET value = ? WHERE key = ?", (json.dumps(meta_checksum(meta)), META_CHECKSUM_KEY))
    conn.close()
    b = analyse(store, paper=False, parameters=["map_size"])
    assert b.rule == DetectionRule(400.0, 1.0) and b.parameters == ("map_size",)
    pd.testing.assert_frame_equal(b.parameter_effects, _named(
        parameter_effects(load_results(store), rule=b.rule, parameters=["map_size"]), "parameter_effects"))
    with pytest.raises(ResultsError, match="no results store"):
        analyse(tmp_path / "nothing")


def _module_file(name: str) -> Path | None:
    """The source file of a faultlab module (None for a name that is not a module, e.g. a function)."""
    p = REPO.joinpath(*name.split("."))
    for candidate in (p / "__init__.py", p.with_suffix(".py")):
        if candidate.exists():
            return candidate
    return None


def _imported_names(path: Path) -> set[str]:
    """Every absolute import of a module, at any level of nesting."""
    names = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            names |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names |= {node.module} | {f"{node.module}.{a.name}" for a in node.names}
    return names


def test_the_analysis_layer_imports_no_report_cli_or_plotting():
    """Follow every faultlab import from faultlab.analysis (a static, transitive layer check)."""
    todo = ["faultlab.analysis"] + [f"faultlab.analysis.{p.stem}" for p in (REPO / "faultlab" / "analysis").glob("*.py")]
    seen, outside = set(), set()
    while todo:
        name = todo.pop()
        path = _module_file(name)
        if name in seen or path is None:
            continue
        seen.add(name)
        for imported in _imported_names(path):
            if imported.startswith("faultlab"):
                todo.append(imported)
            else:
                outside.add(imported.split(".")[0])
    assert "faultlab.analysis.result" in seen and "faultlab.stats.rates" in seen and "faultlab.runner.store" in seen
    assert not [m for m in seen if m.startswith(("faultlab.report", "faultlab.cli"))]
    assert "matplotlib" not in outside and "seaborn" not in outside and "statsmodels" in outside


def test_suite_verdicts_report_the_combined_decision_beside_the_per_case_minimum():
    """One suite run of 12 cases, K = 11: a fault ~13 % worse on every case (noisy) is seen only by the
    pooled test; a fault 50 % worse on one case only by the per-case minimum; the A/A replica is no fault."""
    factors = np.exp(np.random.default_rng(9).normal(0.12, 0.3, (12, 11)))
    rng = np.random.default_rng(3)
    rows = []
    for case in range(12):
        base = 1000.0 + 200.0 * rng.random(11)
        for rep in range(11):
            rows += [job(1, "random", case, "baseline", rep, base[rep]),
                     job(1, "random", case, "baseline_replica", rep, base[rep] * factors[case, rep]),
                     job(1, "random", case, "naive_resampling", rep, base[rep] * factors[case, rep]),
                     job(1, "random", case, "motion_sign_error", rep, base[rep] * (1.5 if case == 0 else 1.0))]
    a = Analysis.from_frame(frame(rows), {"detection": {"rule": "statistical", "alpha": 0.05, "direction": "either"}},
                            paper=False)
    sv = a.suite_verdicts.set_index("fault")
    assert set(sv.index) == {"naive_resampling", "motion_sign_error"}
    assert sv.loc["naive_resampling", "detected_combined"] and not sv.loc["naive_resampling", "detected_min"]
    assert sv.loc["naive_resampling", "pooled_p"] <= 0.025 and sv.loc["naive_resampling", "min_p"] > 0.05 / 12
    assert sv.loc["motion_sign_error", "detected_min"] and not sv.loc["motion_sign_error", "by_pool"]
    assert sv.loc["motion_sign_error", "min_p"] == pytest.approx(2.0 ** -10)


def test_saved_analysis_names_no_machine_path_and_older_ones_load_portable(strict, tmp_path):
    assert (strict.paper_raw, strict.paper_reported) == ("paper_repro/paper_table2_rms.csv",
                                                        "paper_repro/paper_table2_reported.csv")
    strict.save(tmp_path / "a")
    text = (tmp_path / "a" / "analysis.json").read_text()
    assert str(Path.cwd()) not in text and "sha256" not in text
    # an analysis saved with absolute paths (before they were made portable) loads with portable names
    data = json.loads(text)
    shipped = resolve_data_path(None, "paper_repro/paper_table2_rms.csv")
    data.update(paper_raw=str(shipped.resolve()), paper_reported="/elsewhere/gone/paper_table2_reported.csv")
    data["metadata"]["path"] = "/some/machine/runs/quick/results.sqlite"
    (tmp_path / "a" / "analysis.json").write_text(json.dumps(data))
    old = Analysis.load(tmp_path / "a")
    assert (old.paper_raw, old.paper_reported) == ("paper_repro/paper_table2_rms.csv", "paper_table2_reported.csv")
    assert old.metadata["path"] == "quick/results.sqlite"
    # a user's own file is named by its name and content hash
    mine = tmp_path / "mine.csv"
    mine.write_bytes(shipped.read_bytes() + b"\n")
    digest = hashlib.sha256(mine.read_bytes()).hexdigest()
    assert data_label(mine) == f"mine.csv (sha256 {digest})" and data_label("rel/mine.csv") == "rel/mine.csv"


def test_campaign_effects_are_those_of_the_results_by_the_judged_metric(rich, strict):
    import scipy.stats

    from faultlab.analysis.effects import campaign_effects

    ref = _named(campaign_effects(rich, metric="rms", rule=strict.rule, alpha=strict.alpha), "campaign_effects")
    pd.testing.assert_frame_equal(strict.campaign_effects, ref, check_exact=True)
    assert strict.notes_on("campaign_effects") == ()
    # brute force: the difficulty is each case's mean log baseline error over its repetitions; its row is their
    # mean over the 12 cases with the t interval
    base = rich[rich["variant"] == "baseline"]
    per_case = np.log(base["rms_mm"]).groupby([base["run"], base["suite"], base["case"]]).mean()
    row = strict.campaign_effects.query("response == 'difficulty' and term == '(mean over cases)'").iloc[0]
    assert row["n_cases"] == len(per_case) == 12
    assert row["estimate"] == pytest.approx(per_case.mean(), rel=1e-12)
    interval = scipy.stats.t.interval(0.95, len(per_case) - 1, loc=per_case.mean(), scale=scipy.stats.sem(per_case))
    assert (row["low"], row["high"]) == pytest.approx(interval, rel=1e-9)
    # judged by EMD (half the RMS error in these results): the difficulty drops by log 2, the effect sizes
    # (log ratios of the same repetition) stay
    emd = Analysis.from_frame(rich, STRICT, metric="emd", paper=False).campaign_effects
    means = [t.set_index("response").query("term == '(mean over cases)'")["estimate"]
             for t in (strict.campaign_effects, emd)]
    assert means[1]["difficulty"] == pytest.approx(means[0]["difficulty"] - np.log(2.0), rel=1e-12)
    faults = [r for r in means[0].index if r.startswith("effect:")]
    assert len(faults) == 2 and means[1][faults].to_numpy() == pytest.approx(means[0][faults].to_numpy(), rel=1e-9)


def test_campaign_effects_that_cannot_be_computed_leave_an_empty_table_and_a_note(rich, monkeypatch):
    def fail(*args, **kwargs):
        raise ResultsError("no baseline jobs")

    monkeypatch.setattr("faultlab.analysis.result.campaign_effects", fail)
    a = Analysis.from_frame(rich, STRICT, paper=False)
    assert a.campaign_effects.empty and list(a.campaign_effects.columns) == list(CAMPAIGN_EFFECT_COLUMNS)
    assert [n.text for n in a.notes_on("campaign_effects")] == ["Continuous effects: not available (no baseline jobs)."]
    assert not a.case_verdicts.empty  # the other tables are computed


def test_an_analysis_saved_before_the_campaign_effects_loads_without_them(strict, tmp_path):
    strict.save(tmp_path)
    (tmp_path / "campaign_effects.csv").unlink()
    old = Analysis.load(tmp_path)
    assert old.campaign_effects.empty and list(old.campaign_effects.columns) == list(CAMPAIGN_EFFECT_COLUMNS)
    (note,) = old.notes_on("campaign_effects")
    assert "saved before" in note.text and "analyse the results store again" in note.text
    assert old.notes[:-1] == strict.notes
    assert all(getattr(old, s.name).equals(_written(getattr(strict, s.name))) for s in TABLES
               if s.name != "campaign_effects")
    # saved again, it keeps saying so; only that table may be missing
    old.save(tmp_path / "again")
    assert Analysis.load(tmp_path / "again").equals(old)
    (tmp_path / "case_rates.csv").unlink()
    with pytest.raises(ResultsError, match="case_rates.csv: cannot read table case_rates"):
        Analysis.load(tmp_path)
