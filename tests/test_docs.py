"""The docs site's promises: each how-to lists its files and its code runs, the tutorial's code runs,
the command-line page covers every command, the paper-fidelity table is the profile's own."""

import os
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from faultlab.slam.profiles import differences_markdown

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
HOWTOS = sorted((DOCS / "how-to").glob("add-a-*.md"))
SNIPPET = re.compile(r'--8<-- "examples/([\w.]+\.py)"')


def _blocks(text: str, lang: str) -> list[str]:
    return re.findall(rf"```{lang}\n(.*?)```", text, flags=re.S)


def test_there_is_a_how_to_for_each_extension_point():
    names = {p.stem for p in HOWTOS}
    assert {"add-a-fault", "add-a-slam", "add-a-suite-strategy", "add-a-mutation-operator",
            "add-a-metamorphic-relation"} <= names


@pytest.mark.parametrize("howto", HOWTOS, ids=lambda p: p.stem)
def test_how_to_lists_existing_files_and_includes_a_runnable_example(howto):
    text = howto.read_text()
    listed = re.findall(r"^- `([^`]+)`:", text.split("## Files to touch", 1)[1].split("\n## ", 1)[0], flags=re.M)
    assert listed, "no files to touch"
    for path in listed:  # a file of the package or tests that exists, or a pattern for a new one
        if "<" not in path and "*" not in path:
            assert (ROOT / path).exists(), path
    (example,) = SNIPPET.findall(text)
    assert (DOCS / "examples" / example).is_file()


@pytest.mark.parametrize("example", sorted((DOCS / "examples").glob("*.py")), ids=lambda p: p.stem)
def test_how_to_example_runs_and_its_checks_pass(example):
    # A separate process: an example registers its strategy or SLAM in the process's registries.
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT), os.environ.get("PYTHONPATH", "")])}
    result = subprocess.run([sys.executable, str(example)], capture_output=True, text=True, env=env, timeout=300)
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip()


def test_every_example_is_included_by_a_how_to():
    included = {name for p in HOWTOS for name in SNIPPET.findall(p.read_text())}
    assert included == {p.name for p in (DOCS / "examples").glob("*.py")}


def test_tutorial_adapter_maps_every_landmark_it_observed(capsys):
    text = (DOCS / "tutorial" / "test-your-own-slam.md").read_text()
    (block,) = [b for b in _blocks(text, "python") if "class OdometryMapper" in b]
    namespace: dict = {}
    exec(compile(block, "test-your-own-slam.md", "exec"), namespace)
    assert capsys.readouterr().out.startswith("MapErrors(")
    estimate, scenario = namespace["estimate"], namespace["scenario"]
    assert estimate.landmark_ids.size > 0
    np.testing.assert_array_equal(np.sort(estimate.landmark_ids), np.unique(scenario.obs_ids))


def test_cli_reference_covers_every_command_and_subcommand():
    sys.path.insert(0, str(DOCS / "hooks"))
    try:
        from faultlab_docs import cli_markdown
    finally:
        sys.path.remove(str(DOCS / "hooks"))
    from faultlab.cli import build_parser

    text = cli_markdown()
    parser = build_parser()
    (sub,) = [a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction"]
    assert len(sub.choices) >= 10
    for name, command in sub.choices.items():
        assert f"\n## {name}\n" in text
        assert command.format_usage().split()[1] in text
    from faultlab.cli.effects import VERBS

    for verb in VERBS:  # parsed by `effects` itself, not argparse subparsers: listed all the same
        assert f"\n## effects {verb}\n" in text and f"usage: faultlab effects {verb}" in text


def test_paper_fidelity_table_is_the_paper_profiles_rows():
    text = (DOCS / "explanation" / "paper-fidelity.md").read_text()
    section = text.split("## Differences from the paper's system and what they change", 1)[1]
    rows = [line for line in section.split("\n\n", 2)[1].splitlines() if line.startswith("| ")]
    expected = differences_markdown("paper").splitlines()
    assert len(rows) == len(expected) - 1  # the separator row does not start with "| "
    for row, want in zip(rows, [expected[0]] + expected[2:]):
        assert row.startswith(want.rstrip(" |") + " | ")


def test_site_settings_keep_the_pages_readable_and_link_nothing_unchecked():
    import yaml

    config = yaml.safe_load((ROOT / "mkdocs.yml").read_text())
    assert "repo_url" not in config  # no repository address that nobody checked
    css = (DOCS / config["extra_css"][0]).read_text()
    assert "white-space: pre-wrap" in css  # code blocks wrap rather than hide text behind a scrollbar
    sys.path.insert(0, str(DOCS / "hooks"))
    try:
        import faultlab_docs
    finally:
        sys.path.remove(str(DOCS / "hooks"))
    # argparse wraps the options' help of the command-line reference to the narrower width
    options = [line for line in faultlab_docs.cli_markdown().splitlines() if line.startswith("  -")]
    assert options and max(map(len, options)) <= int(faultlab_docs.CLI_COLUMNS)
    assert faultlab_docs.SECTION_TITLES["api"] == "API"
    assert (DOCS / "index.md").read_text().startswith("---\ntitle: Overview\n---\n")


def test_every_test_the_integrity_page_cites_exists():
    text = (DOCS / "explanation" / "integrity.md").read_text()
    cited = 0
    for row in (line for line in text.splitlines() if line.startswith("| ") and "`tests/" in line):
        path = None
        for ref in re.findall(r"`(tests/[^`]*|::[^`]*)`", row):
            file, _, name = ref.partition("::") if ref.startswith("tests/") else (None, None, ref[2:])
            path = ROOT / file if file else path
            assert path is not None and path.exists(), ref
            assert re.search(rf"^def {re.escape(name)}\(", path.read_text(), re.M), ref
            cited += 1
    assert cited >= 25


def test_compare_ci_recipe_commands_parse_and_its_yaml_is_valid():
    import shlex

    import yaml

    from faultlab.cli import build_parser

    text = (DOCS / "how-to" / "compare-in-ci.md").read_text()
    blocks = _blocks(text, "yaml")
    assert len(blocks) == 2
    commands = []
    for block in blocks:
        job = yaml.safe_load(block)
        assert isinstance(job, dict)
        commands += re.findall(r"(faultlab compare [^\n\"]+)", block)
    for block in _blocks(text, "bash"):
        commands += [line for line in block.splitlines() if line.startswith("faultlab compare")]
    assert len(commands) >= 6
    parser = build_parser()
    for line in commands:
        args = parser.parse_args(shlex.split(line)[1:])  # exits (a test failure) on an unknown option
        assert args.command == "compare" and (args.baseline or args.baseline_command)
    # the exit statuses promised are the command's
    from faultlab.analysis.compare import EXIT_NOT_EQUIVALENT, EXIT_OK, EXIT_REGRESSION, EXIT_USAGE

    table = dict(re.findall(r"^\| (\d) \| (.+) \|$", text, flags=re.M))
    assert set(map(int, table)) == {EXIT_OK, EXIT_REGRESSION, EXIT_USAGE, EXIT_NOT_EQUIVALENT}
    assert "regression" in table[str(EXIT_REGRESSION)] and "require-equivalence" in table[str(EXIT_NOT_EQUIVALENT)]
