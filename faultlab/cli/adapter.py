"""``python -m faultlab adapter check CMD...``: the process protocol's edge cases against a SLAM program."""

from __future__ import annotations

import argparse

from faultlab.cli.options import LazyText, add_examples, add_verb_group
from faultlab.errors import ConfigError

__all__ = ["register"]


def _env(text: str) -> tuple[str, str]:
    name, sep, value = text.partition("=")
    if not sep or not name:
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE, got {text!r}")
    return name, value


def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected seconds, got {text!r}") from None
    if not value > 0:
        raise argparse.ArgumentTypeError(f"expected a positive number of seconds, got {text!r}")
    return value


def _description() -> str:
    from faultlab.slam.conformance import CHECKS

    return ("Start the program and reset it once (if it cannot, one error and no check), then start it "
            "once per check and drive it through the protocol's edge cases: " + ", ".join(CHECKS) + ". "
            "Each is reported as pass or FAIL with what to fix; a check that times out ends the run (the "
            "rest are reported as not run); the exit status is 1 if any check fails.")


def register(subparsers) -> None:
    verbs = add_verb_group(
        subparsers, "adapter", help="check a SLAM program that speaks the process protocol",
        description="Tools for SLAMs run as child processes ([slam] name = \"process\"; the protocol is in "
                    "docs/reference/process-protocol.md).",
        examples=["faultlab adapter check ./example_slam"])
    p = verbs.add_parser(
        "check", help="run the protocol's edge cases against a program; exit 1 if any fails",
        description=LazyText(_description))
    p.add_argument("--reply-timeout", type=_seconds, default=10.0, metavar="S",
                   help="longest wait for one reply, s (default: 10)")
    p.add_argument("--execution-timeout", type=_seconds, default=60.0, metavar="S",
                   help="longest execution from reset to estimate, s (default: 60)")
    p.add_argument("--env", type=_env, action="append", default=[], metavar="NAME=VALUE",
                   help="an environment variable for the program (repeatable)")
    p.add_argument("program", metavar="CMD", help="the program")
    p.add_argument("args", nargs=argparse.REMAINDER, metavar="ARG", help="its arguments")
    add_examples(p, ["faultlab adapter check ./example_slam",
                     "faultlab adapter check --reply-timeout 2 --env MY_SLAM_PARTICLES=50 ./my_slam --quiet"])
    p.set_defaults(func=_check)


def _check(args: argparse.Namespace) -> int:
    from faultlab.slam.conformance import check_program

    command = [args.program, *args.args]
    if not args.program:
        raise ConfigError("adapter check: no program given")
    report = check_program(command, env=args.env, reply_timeout_s=args.reply_timeout,
                           execution_timeout_s=args.execution_timeout)
    print(report.format())
    return 0 if report.passed else 1
