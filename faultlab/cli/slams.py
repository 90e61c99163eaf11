"""``python -m faultlab slams``: list the built-in SLAMs, their units and the faults that apply."""

from __future__ import annotations

import argparse

from faultlab.faults import list_slams

__all__ = ["register"]


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "slams",
        help="list the built-in SLAMs: units, applicable built-in faults, optional dependencies",
        description="List every built-in SLAM an experiment can name in [slam] name: its description, the "
                    "number of replaceable units, how many built-in faults replace one of them (the others "
                    "do not apply and are skipped in a campaign), and whether optional dependencies such as "
                    "gtsam are installed.")
    p.set_defaults(func=_handler)


def _handler(args: argparse.Namespace) -> int:
    print(list_slams().format())
    return 0
