"""Command line: ``python -m faultlab <command>``.

The CLI only parses arguments and delegates to library functions.  Each
command lives in its own module that defines ``register(subparsers)``; the
module attaches its handler as ``func`` (``handler(args) -> int`` exit code).
"""

from __future__ import annotations

import argparse
import importlib
import sys

from faultlab import __version__
from faultlab.errors import FaultlabError

__all__ = ["main", "build_parser"]

#: Command modules, in the order shown by ``--help``.
COMMAND_MODULES = (
    "faultlab.cli.reproduce",  # reproduce, report
    "faultlab.cli.run",  # run
    "faultlab.cli.generate",  # generate
    "faultlab.cli.faults",  # faults
    "faultlab.cli.slams",  # slams
    "faultlab.cli.stats",  # paper-table
    "faultlab.cli.effects",  # effects design|run|report, effects RESULTS
    "faultlab.cli.calibrate",  # calibrate
    "faultlab.cli.mutate",  # mutate list, mutate show
    "faultlab.cli.metamorphic",  # metamorphic
    "faultlab.cli.study",  # study run, study report
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="python -m faultlab",
        description="Coverage-driven testing of SLAM algorithms with injected faults.",
    )
    parser.add_argument("--version", action="version", version=f"faultlab {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:  # a command not built yet
            if exc.name != name:
                raise
            continue
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except FaultlabError as exc:
        print(f"faultlab: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("faultlab: interrupted; finished results are saved", file=sys.stderr)
        return 130
