"""Command line: ``faultlab <command>`` (or ``python -m faultlab <command>``).

The CLI only parses arguments and delegates to library functions.  Each
command lives in its own module that defines ``register(subparsers)``; the
module attaches its handler as ``func`` (``handler(args) -> int`` exit code).
"""

from __future__ import annotations

import argparse
import importlib
import sys

from faultlab import __version__
from faultlab.cli.options import epilog
from faultlab.errors import FaultlabError

__all__ = ["main", "build_parser"]

#: Command modules, in the order shown by ``--help``.
COMMAND_MODULES = (
    "faultlab.cli.reproduce",  # reproduce, report
    "faultlab.cli.run",  # run
    "faultlab.cli.generate",  # generate
    "faultlab.cli.faults",  # faults
    "faultlab.cli.slams",  # slams
    "faultlab.cli.stats",  # paper-table, effects
    "faultlab.cli.calibrate",  # calibrate
    "faultlab.cli.mutate",  # mutate list, mutate show
    "faultlab.cli.metamorphic",  # metamorphic
    "faultlab.cli.study",  # study run, study report
    "faultlab.cli.adapter",  # adapter check
    "faultlab.cli.export",  # export
)


#: The program name of the installed command (``python -m faultlab`` passes its own).
PROG = "faultlab"


def build_parser(prog: str = PROG) -> argparse.ArgumentParser:
    """The parser of every command; ``prog`` is the name the usage lines show."""
    parser = argparse.ArgumentParser(
        prog=prog,
        description="Coverage-driven testing of SLAM algorithms with injected faults.",
        **epilog(["faultlab reproduce --quick --out results/quick", "faultlab run smoke --out results/smoke",
                  "faultlab COMMAND --help"]),
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


def main(argv: list[str] | None = None, *, prog: str = PROG) -> int:
    """Run the command of ``argv`` (default ``sys.argv[1:]``); returns the exit status."""
    parser = build_parser(prog)
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
