"""The study report renders what the analysis holds: tables, figure panels, intervals in the text."""

from __future__ import annotations

import pandas as pd

from faultlab.analysis.study import StudyAnalysis, _power
from faultlab.stats.killmatrix import StudySpec
from faultlab.report.study import detection_figure, study_markdown
from faultlab.stats.killmatrix import compare_scores, detection_table, evaluate_suites, score_table
from tests.stats.test_killmatrix import hand_matrix


def _analysis() -> StudyAnalysis:
    km = hand_matrix()
    spec = StudySpec(sizes=(1, 2, 4), draws=200, bootstrap=100, seed=4)
    ev = evaluate_suites(km, spec.sizes, draws=spec.draws, bootstrap=spec.bootstrap, seed=spec.seed,
                         mutants=["mutant:x"])
    det = detection_table(ev, km.variants)
    det.insert(1, "kind", ["mutant" if v.startswith("mutant:") else "fault" for v in det["variant"]])
    meta = {"study": spec.to_dict(), "quick": True, "pool": {"systematic": 6, "random": 5}, "runs": 1,
            "repetitions": 7, "n_steps": 60, "slam": {"name": "fastslam", "particles": 20}, "timeout_s": 10.0,
            "faults": ["fault_a", "fault_b"], "mutants": ["mutant:x"], "n_jobs": 100, "status_counts": {"ok": 100},
            "slam_time_s": 12.0, "wall_time_s": 60.0, "sessions": [{"started": 0.0, "jobs": 2, "cpus": 2}],
            "load": {"samples": 3, "load1_mean": 5.0, "load1_min": 4.0, "load1_max": 6.0}}
    return StudyAnalysis(kill_matrix=km.to_frame(), detection=det, scores=score_table(ev),
                         comparisons=compare_scores(ev), power=_power(ev.pool_sizes, spec), meta=meta)


def test_markdown_quotes_every_strategy_rate_with_its_interval_and_states_the_power():
    a = _analysis()
    md = study_markdown(a)
    row = a.detection[(a.detection["variant"] == "fault_b") & (a.detection["strategy"] == "random")
                      & (a.detection["size"] == 2)].iloc[0]
    cell = f"{100 * row['rate']:.0f} % ({100 * row['ci_low']:.0f}-{100 * row['ci_high']:.0f})"
    assert "| fault_b | 2 |" in md and cell in md
    assert "Quick scale (reduced)" in md and "load average 5.0" in md
    assert "## Power" in md and "## Strategies compared at equal size" in md
    assert md.count("systematic vs random") == 3          # one comparison per size


def test_figure_has_one_panel_per_fault_and_one_for_the_mutation_score(tmp_path):
    a = _analysis()
    fig = detection_figure(a)
    titles = [ax.get_title() for ax in fig.axes if ax.get_visible()]
    assert titles == ["fault_a", "fault_b", "mutation score"]
    fig.savefig(tmp_path / "f.png")
    assert (tmp_path / "f.png").stat().st_size > 1000


def test_saved_analysis_loads_back_equal(tmp_path):
    a = _analysis()
    a.save(tmp_path)
    b = StudyAnalysis.load(tmp_path)
    pd.testing.assert_frame_equal(a.detection, b.detection, check_dtype=False)
    assert b.meta["study"]["sizes"] == [1, 2, 4]


def test_markdown_lists_whole_suites_with_their_exact_interval():
    from dataclasses import replace

    from faultlab.stats.killmatrix import whole_suite_table, whole_suites

    a = _analysis()
    assert "## Whole generated suites" not in study_markdown(a)        # none configured: no section
    km = hand_matrix()
    whole = whole_suite_table(whole_suites(km, ["random"]), mutants=["mutant:x"])
    md = study_markdown(replace(a, whole=whole))
    assert "## Whole generated suites" in md and "`random`" in md
    row = whole[whole["variant"] == "fault_a"].iloc[0]
    # one suite of 5 cases: 0 % or 100 % with the Clopper-Pearson interval of 1 suite (2.5 % or 97.5 %)
    text = f"{100 * row['rate']:.0f} % ({100 * row['ci_low']:.0f}-{100 * row['ci_high']:.0f})"
    assert text in md and row["ci_high"] - row["ci_low"] > 0.9


def test_an_interval_narrower_than_the_last_decimal_is_rounded_outwards_never_to_zero_width():
    from faultlab.report.study import _interval

    assert _interval(1.0, 1 - 3e-12, 1.0) == "100 % (99.999-100.000)"
    assert _interval(0.5, 0.3, 0.7) == "50 % (30-70)"
    assert _interval(0.9, 0.8561, 0.8569) == "90 % (85.6-85.7)"  # visible at one decimal: not widened


def test_markdown_shows_the_fault_comparisons_the_analysis_holds(tmp_path):
    from dataclasses import replace

    from faultlab.stats.killmatrix import compare_detection, compare_mean_detection

    a = _analysis()
    assert "single-case detection probability" not in study_markdown(a)   # none computed: no section
    km = hand_matrix()
    ev = evaluate_suites(km, [1], draws=50, bootstrap=20, seed=1, mutants=["mutant:x"])
    per_fault = compare_detection(ev, ["fault_a", "fault_b"])
    means = compare_mean_detection(km, ["fault_a", "fault_b"])
    md = study_markdown(replace(a, detection_comparisons=per_fault, detection_means=means))
    r = means.iloc[0]
    assert (f"| systematic vs random | {100 * r['mean_a']:.0f} % | {100 * r['mean_b']:.0f} % | "
            f"{100 * r['diff']:+.1f} pp ({100 * r['ci_low']:+.1f} to {100 * r['ci_high']:+.1f}) |") in md
    for fault in ("fault_a", "fault_b"):
        margin = per_fault.loc[per_fault["variant"] == fault, "equivalence_margin"].max()
        assert f"| {fault} | none | ±{100 * margin:.0f} pp |" in md     # nothing shown with 5 and 6 cases
    b = StudyAnalysis.load(replace(a, detection_comparisons=per_fault, detection_means=means).save(tmp_path))
    pd.testing.assert_frame_equal(b.detection_means, means, check_dtype=False)
    pd.testing.assert_frame_equal(b.detection_comparisons, per_fault, check_dtype=False)


def test_the_controls_section_keeps_per_comparison_and_family_rates_apart_and_prints_no_nan():
    from dataclasses import replace

    from faultlab.stats.controls import CONTROL_SUMMARY_COLUMNS

    summary = pd.DataFrame([["per fault", "case", 85, 2, 2 / 85, 0.0029, 0.0824, 5, 0, "Holm over the strategy's faults"],
                            ["mean over the faults", "run", 0, 0, float("nan"), float("nan"), float("nan"), 0, 0,
                             "one comparison per strategy"]], columns=list(CONTROL_SUMMARY_COLUMNS))
    md = study_markdown(replace(_analysis(), controls_summary=summary))
    assert "| per fault, case as unit | 2/85 = 2 % (0-8) | 0 of 5 (Holm over the strategy's faults) |" in md
    assert "| mean over the faults, run as unit | none testable (too few runs, or no spread) | - |" in md
    assert "nan" not in md.lower().replace("nanosecond", "")
