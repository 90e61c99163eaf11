import argparse

import pytest

from faultlab.cli.options import add_execution_options, positive_int


def test_positive_int():
    assert positive_int("3") == 3
    for bad in ("0", "-1", "x", "1.5"):
        with pytest.raises(argparse.ArgumentTypeError, match="positive integer"):
            positive_int(bad)


def test_execution_options_defaults_and_choices():
    p = argparse.ArgumentParser()
    add_execution_options(p)
    args = p.parse_args([])
    assert (args.backend, args.force_new, args.no_progress) == ("loky", False, False)
    with pytest.raises(SystemExit):
        p.parse_args(["--backend", "spark"])


# -- every command's help: examples, program name, shipped experiments --------------------------


def _parsers(parser: argparse.ArgumentParser, path: tuple = ()):
    """(command path, parser) of ``parser`` and of every command and verb under it."""
    yield path, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _parsers(sub, path + (name,))


def test_every_command_help_ends_with_one_to_three_example_commands():
    from faultlab.cli import build_parser

    seen = []
    for path, parser in _parsers(build_parser()):
        text = parser.format_help().rstrip("\n").split("\n")
        start = len(text) - 1 - text[::-1].index("examples:")
        examples = [line.strip() for line in text[start + 1:]]
        assert 1 <= len(examples) <= 3, path
        for example in examples:
            words = example.split()
            command = words[words.index("faultlab") + 1:] if "faultlab" in words else []
            assert words[:1] == ["faultlab"] or words[:4] == ["nice", "-n", "10", "faultlab"], (path, example)
            # the example names this command (the top-level help shows several)
            assert not path or command[:len(path)] == list(path), (path, example)
        seen.append(path)
    assert {("reproduce",), ("run",), ("slams", "run"), ("slams", "report"), ("mutate", "run")} <= set(seen)


def test_examples_are_limited_to_three():
    from faultlab.cli.options import epilog

    with pytest.raises(ValueError):
        epilog([])
    with pytest.raises(ValueError):
        epilog(["a", "b", "c", "d"])


def test_example_commands_parse():
    """Every example (without ``nice``) is a valid command line of the parser."""
    import shlex

    from faultlab.cli import build_parser

    parser = build_parser()
    for path, sub in _parsers(parser):
        text = sub.format_help().rstrip("\n").split("\n")
        start = len(text) - 1 - text[::-1].index("examples:")
        for example in text[start + 1:]:
            words = shlex.split(example)
            argv = words[words.index("faultlab") + 1:]
            if "--help" in argv or "COMMAND" in argv:
                continue
            args = parser.parse_args(argv)
            assert callable(args.func), example


@pytest.mark.parametrize("command", ["reproduce", "run"])
def test_help_lists_every_shipped_experiment(command):
    from faultlab.cli import build_parser
    from faultlab.data import experiment_names

    (parser,) = [p for path, p in _parsers(build_parser()) if path == (command,)]
    text = "".join(parser.format_help().split())  # undo the line wrapping (argparse may break at a hyphen)
    names = experiment_names()
    assert len(names) >= 7
    assert ",".join(names) in text


def test_usage_names_the_program_as_it_was_run(capsys):
    import subprocess
    import shutil
    import sys

    from faultlab.cli import main

    with pytest.raises(SystemExit):
        main(["run", "--help"])
    assert capsys.readouterr().out.startswith("usage: faultlab run ")
    done = subprocess.run([sys.executable, "-m", "faultlab", "slams", "run", "--help"], capture_output=True,
                          text=True, check=True)
    assert done.stdout.startswith("usage: python -m faultlab slams run ")
    script = shutil.which("faultlab")
    if script is not None:  # the installed console script
        done = subprocess.run([script, "--help"], capture_output=True, text=True, check=True)
        assert done.stdout.startswith("usage: faultlab ")
