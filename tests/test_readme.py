"""The README's promises: its adapter example runs, and CI runs its test command verbatim."""

import re
from pathlib import Path

import numpy as np

from faultlab.slam.profiles import differences_markdown

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _code_blocks(lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", README, flags=re.S)


def test_quick_start_has_exactly_two_commands_and_ci_runs_the_test_one():
    quick = README.split("## Quick start", 1)[1].split("\n## ", 1)[0]
    commands = [line for block in re.findall(r"```bash\n(.*?)```", quick, flags=re.S)
                for line in block.splitlines() if line.strip()]
    assert len(commands) == 2
    assert "faultlab reproduce" in commands[0]
    assert "pytest" in commands[1]
    ci = (ROOT / ".ci" / "run").read_text().splitlines()
    assert commands[1] in ci


def test_minimal_adapter_example_runs_and_maps_landmarks(capsys):
    (block,) = [b for b in _code_blocks("python") if "class OdometryMapper" in b]
    namespace: dict = {}
    exec(compile(block, "README.md", "exec"), namespace)
    printed = capsys.readouterr().out
    assert printed.startswith("MapErrors(")
    estimate, scenario = namespace["estimate"], namespace["scenario"]
    assert estimate.landmark_ids.size > 0
    # The example maps every landmark it observed and nothing else.
    np.testing.assert_array_equal(np.sort(estimate.landmark_ids), np.unique(scenario.obs_ids))


def test_differences_table_is_the_paper_profiles_rows():
    section = README.split("### Differences from the paper's system and what they change", 1)[1]
    rows = [line for line in section.split("\n\n", 2)[1].splitlines() if line.startswith("| ")]
    expected = differences_markdown("paper").splitlines()
    assert len(rows) == len(expected) - 1  # the separator row does not start with "| "
    for row, want in zip([rows[0]] + rows[1:], [expected[0]] + expected[2:]):
        assert row.startswith(want.rstrip(" |") + " | ")
