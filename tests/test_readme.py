"""The README's promises: short, its Quick start is what CI runs, its example runs, its figures are the reports'."""

import re
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
README = (ROOT / "README.md").read_text()


def _section(title: str) -> str:
    return README.split(f"## {title}", 1)[1].split("\n## ", 1)[0]


def test_readme_is_at_most_200_lines():
    assert len(README.splitlines()) <= 200


def test_quick_start_has_exactly_two_commands_and_ci_runs_the_test_one():
    commands = [line for block in re.findall(r"```bash\n(.*?)```", _section("Quick start"), flags=re.S)
                for line in block.splitlines() if line.strip()]
    assert len(commands) == 2
    assert "faultlab reproduce" in commands[0]
    assert "pytest" in commands[1] and "-n auto" in commands[1]  # pytest-xdist: every core
    assert all("-c requirements/test.lock" in c for c in commands)  # both install what CI tested
    # CI reads the test command out of the README and runs it verbatim in a fresh virtual environment
    ci = subprocess.run(["bash", str(ROOT / ".ci" / "run"), "--print-test-command"], capture_output=True,
                        text=True, check=True)
    assert ci.stdout == commands[1] + "\n"
    script = (ROOT / ".ci" / "run").read_text()
    assert 'eval "$test_command"' in script and "-m venv" in script


def test_example_runs_and_the_paper_rule_detects_the_faulty_rotation(capsys):
    (block,) = re.findall(r"```python\n(.*?)```", README, flags=re.S)
    assert len(block.splitlines()) <= 20
    exec(compile(block, "README.md", "exec"), {})
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == 5  # the systematic suite of Table I has 5 cases
    parsed = [re.fullmatch(r"case \d: baseline +(\d+) mm, faulty +(\d+) mm, detected: (True|False)", line)
              for line in lines]
    assert all(parsed)
    for m in parsed:  # the printed verdict is the paper's rule applied to the printed errors (rounding aside)
        baseline, faulty, detected = float(m[1]), float(m[2]), m[3] == "True"
        if abs(faulty - baseline - 250) > 1 and abs(faulty - 1.25 * baseline) > 1:
            assert detected == (faulty > baseline + 250 and faulty >= 1.25 * baseline)
    # A missing angle wrap wrecks the map wherever bearings cross +-pi (every committed report detects it).
    assert sum(m[3] == "True" for m in parsed) >= 3


def test_every_relative_link_exists():
    links = re.findall(r"\]\(([^)#]+)\)", README)
    assert links
    missing = [link for link in links if not link.startswith("http") and not (ROOT / link).exists()]
    assert not missing


def test_headline_figures_are_quoted_from_the_linked_reports():
    rows = [line for line in _section("Headline figures").splitlines() if line.startswith("| ") and "---" not in line]
    assert len(rows) >= 8
    for row in rows[1:]:
        _, figure, source, _ = row.split(" | ", 1)[0], *row.split(" | ")[1:3], None
        targets = [ROOT / t for t in re.findall(r"\]\(([^)]+)\)", source)]
        assert targets, row
        text = "".join(t.read_text() for t in targets)
        extra = re.findall(r"`([\w./-]+\.(?:md|csv))`", source)
        text += "".join((ROOT / "reports" / e).read_text() for e in extra if (ROOT / "reports" / e).exists())
        decimals = re.findall(r"(?<!FastSLAM )\d+\.\d+", figure)  # not the SLAMs' version numbers
        absent = [d for d in decimals if d not in text]
        assert not absent, (row, absent)
