"""``python -m faultlab faults``: list every fault; ``--slam`` only those that apply to one SLAM;
``--check`` runs the equivalent-mutant check."""

from __future__ import annotations

import argparse

from faultlab.cli.options import add_examples

__all__ = ["register"]


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "faults",
        help="list the injectable faults (built-in and plugins); --check flags equivalent mutants",
        description="List every fault (name, step, origin, description). With --check, run each fault "
                    "against the reference FastSLAM on a small fixed scenario with fixed seeds and flag "
                    "faults whose output is identical to the reference (equivalent mutants, which must "
                    "not count in detection rates); the exit status is 1 if any fault is equivalent or a "
                    "plugin failed to load.")
    p.add_argument("names", nargs="*", metavar="FAULT",
                   help="faults to check (names or module:attr import paths; default: all)")
    p.add_argument("--check", action="store_true", help="run the equivalent-mutant check")
    p.add_argument("--seed", type=int, default=0, help="seed of the check scenario and SLAM runs (default 0)")
    p.add_argument("--repetitions", type=int, default=2, metavar="K", dest="repetitions",
                   help="SLAM repetitions per fault in the check (default 2)")
    p.add_argument("--seeds", type=int, dest="repetitions", help=argparse.SUPPRESS)  # the former spelling
    p.add_argument("--steps", type=int, default=None, metavar="N",
                   help="active steps of the check scenario (default 300; inactivity comes on top)")
    p.add_argument("--particles", type=int, default=None, metavar="N",
                   help="particles of the FastSLAM in the check (default: FastSlamConfig default, 200)")
    p.add_argument("--slam", metavar="NAME", default=None,
                   help="list only the faults that apply to this SLAM (a built-in name such as 'ekf', or "
                        "package.module:factory): those replacing one of its units; says how many do not")
    p.add_argument("--category", choices=("real",), default=None,
                   help="list only the faults of this category: 'real', those reproducing bugs found in public "
                        "SLAM code (provenance in faultlab.faults.real)")
    p.add_argument("--no-plugins", action="store_true", help="ignore third-party fault plugins")
    p.add_argument("-v", "--verbose", action="store_true", help="show each fault's rationale and source")
    add_examples(p, ["faultlab faults --slam ekf", "faultlab faults --category real -v",
                     "faultlab faults --check naive_resampling"])
    p.set_defaults(func=_handler)


def _handler(args: argparse.Namespace) -> int:
    from faultlab.faults import FaultListing, applicable_faults, check_faults, list_faults, not_applicable

    plugins = not args.no_plugins
    if args.check:
        report = check_faults(args.names or None, seed=args.seed, n_seeds=args.repetitions, n_steps=args.steps,
                              particles=args.particles, plugins=plugins)
        print(report)
        return 0 if report.ok else 1
    listing = list_faults(plugins=plugins)
    if args.names:
        listing = listing.select(args.names)
    if args.category is not None:
        listing = listing.in_category(args.category)
    note = ""
    if args.slam is not None:
        fit = applicable_faults(args.slam, listing.faults)
        sensor = tuple(f for f in listing.sensor_faults if not_applicable(f, args.slam) is None)
        listing = FaultListing(faults=fit.applicable, sources=listing.sources, errors=listing.errors,
                               sensor_faults=sensor, categories=listing.categories)
        note = fit.summary() or f"all {len(fit.applicable)} faults apply to {fit.slam!r}"
    print(listing.format(verbose=args.verbose))
    if note:
        print(note)
    return 0
