"""Argument types and options shared by several commands."""

from __future__ import annotations

import argparse

from faultlab.vocabulary import BACKENDS

__all__ = ["BACKENDS", "positive_int", "add_execution_options", "add_verb_group", "print_paths"]


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
                        help="joblib backend (default: loky; dask and ray are optional extras)")
    parser.add_argument("--force-new", action="store_true",
                        help="start afresh: move results of another (or a changed) experiment in the "
                             "results directory to <dir>/previous-<time>/")
    parser.add_argument("--no-progress", action="store_true",
                        help="no progress output (neither the bar on a terminal nor the log lines elsewhere)")


def add_verb_group(subparsers, name: str, *, help: str, description: str):
    """A command with verbs (``faultlab NAME VERB``); without a verb it prints its help and exits with 2.

    Returns the verbs' subparsers (``add_parser`` for each verb).
    """
    p = subparsers.add_parser(name, help=help, description=description)
    sub = p.add_subparsers(dest=f"{name}_command", metavar="VERB")

    def usage(args: argparse.Namespace) -> int:
        p.print_help()
        return 2

    p.set_defaults(func=usage)
    return sub


def print_paths(paths) -> int:
    """Print the files a command wrote, one per line; exit code 0."""
    for path in paths:
        print(path)
    return 0
