"""Argument types and options shared by several commands."""

from __future__ import annotations

import argparse
from collections.abc import Callable, Iterator

from faultlab.vocabulary import BACKENDS

__all__ = ["BACKENDS", "positive_int", "add_execution_options", "add_verb_group", "print_paths", "epilog", "add_examples",
           "shipped_experiments", "LazyChoices", "LazyText"]


class LazyText:
    """A help text or description made when it is shown (it names a default or choices read from a module
    that is slow to import); the commands' formatter turns it into its text."""

    def __init__(self, make: Callable[[], str]):
        self._make = make

    def __str__(self) -> str:
        return self._make()

    def strip(self, *chars: str) -> str:
        return str(self).strip(*chars)

    def __contains__(self, part: str) -> bool:
        return part in str(self)

    def __mod__(self, params) -> str:
        return str(self) % params


class LazyChoices:
    """argparse ``choices`` read from a module on first use (parsing that command or showing its help),
    so that registering every command for ``faultlab --help`` imports none of the libraries behind them.

    Give the argument a ``metavar`` (argparse lists the choices of one without it when it is added)
    and name the choices in its help (a :class:`LazyText`).
    """

    def __init__(self, load: Callable[[], tuple[str, ...]]):
        self._load = load
        self._values: tuple[str, ...] | None = None

    def _get(self) -> tuple[str, ...]:
        if self._values is None:
            self._values = tuple(self._load())
        return self._values

    def __contains__(self, value: object) -> bool:
        return value in self._get()

    def __iter__(self) -> Iterator[str]:
        return iter(self._get())

    def __len__(self) -> int:
        return len(self._get())


def positive_int(text: str) -> int:
    """argparse type: an integer >= 1."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value




def add_execution_options(parser: argparse.ArgumentParser) -> None:
    """``--backend``, ``--force-new`` and ``--no-progress`` of the commands that run jobs."""
    parser.add_argument("--backend", default="loky", choices=BACKENDS,
                        help="joblib backend (default: loky); threading only with --jobs 1, dask and ray are refused: "
                             "timeout_s needs workers the campaign can kill")
    parser.add_argument("--force-new", action="store_true",
                        help="start afresh: move results of another (or a changed) experiment in the "
                             "results directory to <dir>/previous-<time>/")
    parser.add_argument("--no-progress", action="store_true",
                        help="no progress output (neither the bar on a terminal nor the log lines elsewhere)")


def epilog(examples: list[str]) -> dict:
    """``add_parser`` keywords that end a command's help with its example commands (1-3).

    The description keeps its own line breaks (``RawDescriptionHelpFormatter``) only where it has
    them; each example is one line under "examples:".
    """
    if not 1 <= len(examples) <= 3:
        raise ValueError(f"a command's help shows 1 to 3 examples, got {len(examples)}")
    return {"epilog": "examples:\n" + "\n".join(f"  {e}" for e in examples),
            "formatter_class": _Formatter}


def add_examples(parser: argparse.ArgumentParser, examples: list[str]) -> argparse.ArgumentParser:
    """End ``parser``'s help with its example commands (:func:`epilog`); returns ``parser``."""
    for key, value in epilog(examples).items():
        setattr(parser, key, value)
    return parser


class _Formatter(argparse.RawDescriptionHelpFormatter):
    """Keeps the epilog's lines; wraps the description like the default formatter.

    A help text or description may be a :class:`LazyText`, made when the help is shown.
    """

    def _get_help_string(self, action):
        return str(action.help)

    def _format_text(self, text):
        return super()._format_text(str(text))

    def _fill_text(self, text, width, indent):
        if text.startswith("examples:\n"):
            return super()._fill_text(text, width, indent)
        return argparse.HelpFormatter._fill_text(self, text, width, indent)


def shipped_experiments() -> str:
    """The shipped experiment names, comma-separated (from :func:`faultlab.data.experiment_names`)."""
    from faultlab.data import experiment_names

    return ", ".join(experiment_names())


def add_verb_group(subparsers, name: str, *, help: str, description: str, examples: list[str],
                   default=None):
    """A command with verbs (``faultlab NAME VERB``).

    Without a verb it runs ``default`` (a handler), or prints its help and exits with 2.  Returns
    the verbs' subparsers (``add_parser`` for each verb).
    """
    p = subparsers.add_parser(name, help=help, description=description, **epilog(examples))
    sub = p.add_subparsers(dest=f"{name}_command", metavar="VERB")

    def usage(args: argparse.Namespace) -> int:
        p.print_help()
        return 2

    p.set_defaults(func=default or usage)
    return sub


def print_paths(paths) -> int:
    """Print the files a command wrote, one per line; exit code 0."""
    for path in paths:
        print(path)
    return 0
