"""The rendered power plan: its tables read back equal the plan's figures."""

from __future__ import annotations

from faultlab.report.planning import plan_markdown
from faultlab.inference.planning import plan_study


def _table(text: str, heading: str) -> dict[str, list[str]]:
    """The two-or-more-column table under ``heading``: label -> cells."""
    block = text.split(heading, 1)[1].split("\n## ", 1)[0]
    rows = [line.strip("|").split("|") for line in block.splitlines() if line.startswith("| ") and "---" not in line]
    return {cells[0].strip(): [c.strip() for c in cells[1:]] for cells in rows}


def test_the_split_design_section_shows_both_halves_and_whether_they_fit():
    for seconds, fits in ((0.02, True), (1.0, False)):
        plan = plan_study("strategies", strategies=5, faults=17, max_suite=22, seconds_per_execution=seconds)
        text = plan_markdown(plan, study="s", cost=None, cost_source="", settings="fastslam")
        table = _table(text, "## Split design")
        faults, mutants = plan.split
        assert table["SLAM executions"] == [f"{faults.executions:,}", f"{mutants.executions:,}"]
        assert table["pool cases per strategy"] == [str(faults.cases), str(mutants.cases)]
        assert table["detectable mutation-score difference"] == ["none detectable", f"{mutants.score_pp:.1f} pp"]
        assert ("it fits the budget." in text) == fits and ("it does **not** fit the budget" in text) == (not fits)


def test_a_plan_without_faults_has_no_split_section():
    plan = plan_study("strategies", strategies=5, faults=0, max_suite=22, seconds_per_execution=0.02)
    assert "## Split design" not in plan_markdown(plan, study="s", cost=None, cost_source="", settings="fastslam")
