"""Command line: ``faultlab <command>`` (or ``python -m faultlab <command>``).

The CLI only parses arguments and delegates to library functions.  Each
command lives in its own module that defines ``register(subparsers)``; the
module attaches its handler as ``func`` (``handler(args) -> int`` exit code).
"""

from __future__ import annotations

import argparse
import contextlib
import errno
import importlib
import os
import signal
import sqlite3
import sys
import threading
import warnings

from faultlab import __version__
from faultlab.cli.options import epilog
from faultlab.errors import FaultlabError, UnknownPluginError

__all__ = ["main", "build_parser"]

#: Command modules, in the order shown by ``--help``.
COMMAND_MODULES = (
    "faultlab.cli.reproduce",  # reproduce, report
    "faultlab.cli.run",  # run
    "faultlab.cli.generate",  # generate
    "faultlab.cli.faults",  # faults
    "faultlab.cli.slams",  # slams
    "faultlab.cli.robustness",  # robustness run, robustness report
    "faultlab.cli.stats",  # paper-table
    "faultlab.cli.effects",  # effects design|run|report, effects RESULTS
    "faultlab.cli.calibrate",  # calibrate
    "faultlab.cli.mutate",  # mutate list, mutate show
    "faultlab.cli.metamorphic",  # metamorphic
    "faultlab.cli.study",  # study plan, study run, study report
    "faultlab.cli.adapter",  # adapter check
    "faultlab.cli.export",  # export
    "faultlab.cli.check",  # check
    "faultlab.cli.compare",  # compare
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
    parser.add_argument("--accept-unverified", action="store_true",
                        help="read (and resume) results stores whose rows carry no checksums -- written before "
                             "faultlab checked its stores, or with their integrity entries removed -- instead "
                             "of refusing them; their values are not verified")
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


def _silence_stdout() -> None:
    """Point stdout at /dev/null, so that the interpreter's final flush into a closed pipe stays quiet."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError, AttributeError):
        pass


def _format_warning(message, category, filename, lineno, line=None) -> str:
    """A note about a store read without checksums is one line for a user, not a source location."""
    store = sys.modules.get("faultlab.runner.store")  # not loaded: no store was read, so no such warning
    if store is not None and issubclass(category, store.UnverifiedStoreWarning):
        return f"faultlab: note: {message}\n"
    return _python_format_warning(message, category, filename, lineno, line)


_python_format_warning = warnings.formatwarning


class Terminated(KeyboardInterrupt):
    """Raised in the main thread when the process receives SIGTERM (Slurm, systemd, ``timeout``, ``kill``).

    A KeyboardInterrupt, so that a campaign stops exactly as on Ctrl-C: finished rows stay committed
    and its session is marked ``interrupted``.
    """


def _terminate(signum, frame) -> None:
    raise Terminated()


def _unknown_name(exc: BaseException | None) -> bool:
    """True if ``exc`` or an error it was raised from is an :class:`~faultlab.errors.UnknownPluginError`."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, UnknownPluginError):
            return True
        seen.add(id(exc))
        exc = exc.__cause__
    return False


def main(argv: list[str] | None = None, *, prog: str = PROG) -> int:
    """Run the command of ``argv`` (default ``sys.argv[1:]``); returns the exit status.

    Every expected failure is one ``faultlab: error:`` line on stderr and exit code 1; a name no
    plugin of its kind has (:class:`~faultlab.errors.UnknownPluginError`, also when a setting's
    error wraps it) exits with 2, as a usage error.  ``--accept-unverified`` (before the command)
    reads stores without row checksums (:func:`faultlab.runner.store.accept_unverified`).

    A reader that closes the pipe early (``faultlab mutate list | head``) ends the command quietly
    with exit code 141, as a process killed by SIGPIPE (the shell's convention); the command stops
    at its next write, so a campaign keeps the rows it committed.  SIGTERM is handled like Ctrl-C
    (:class:`Terminated`): the command stops, keeps what it finished, and exits with 143 (128 + 15;
    Ctrl-C: 130).
    """
    warnings.formatwarning = _format_warning
    if (sys.argv[1:] if argv is None else argv) == ["--version"]:  # without importing any command
        print(f"{prog} {__version__}")
        return 0
    parser = build_parser(prog)
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    previous = None
    if threading.current_thread() is threading.main_thread():
        previous = signal.signal(signal.SIGTERM, _terminate)
    accepting = contextlib.nullcontext()
    if args.accept_unverified:
        from faultlab.runner.store import accept_unverified

        accepting = accept_unverified()
    try:
        with accepting:
            code = int(args.func(args) or 0)
        sys.stdout.flush()
        return code
    except Terminated:
        print("faultlab: terminated (SIGTERM); finished results are saved: rerun the same command to resume",
              file=sys.stderr)
        return 128 + signal.SIGTERM
    except BrokenPipeError:
        _silence_stdout()
        return 128 + 13  # SIGPIPE
    except FaultlabError as exc:
        print(f"faultlab: error: {exc}", file=sys.stderr)
        return 2 if _unknown_name(exc) else 1
    except OSError as exc:  # the file system refused (disk full, permission, read-only): no traceback
        target = exc.filename or next((getattr(args, a) for a in ("reports", "out") if getattr(args, a, None)), None)
        where = f" ({target if exc.filename else f'writing under {target}'})" if target else ""
        what = "the disk is full" if exc.errno == errno.ENOSPC else (exc.strerror or str(exc))
        print(f"faultlab: error: {what}{where}", file=sys.stderr)
        return 1
    except sqlite3.Error as exc:  # a store read outside faultlab.runner.store's own error handling
        print(f"faultlab: error: a results store cannot be read or written (SQLite: {exc})", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("faultlab: interrupted; finished results are saved", file=sys.stderr)
        return 130
    finally:
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
