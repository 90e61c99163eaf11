"""``python -m faultlab metamorphic``: which faults violate which metamorphic relation (a matrix)."""

from __future__ import annotations

import argparse
import functools

from faultlab.cli.options import LazyText, add_examples
from faultlab.errors import ConfigError

__all__ = ["register"]


def _defaults() -> tuple[float, float]:
    """``--factor`` and ``--atol`` when not given (read when needed: the metamorphic package is slow to import)."""
    from faultlab.metamorphic import DEFAULT_ATOL, DEFAULT_FACTOR

    return DEFAULT_FACTOR, DEFAULT_ATOL


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "metamorphic",
        help="check metamorphic relations (rigid motion, id permutation, 2 pi bearings, halved noise) "
             "on a SLAM and its faults",
        description="Run the SLAM (unmodified, then with each fault that applies to it) on a short source "
                    "case and on each relation's follow-up case, and print which faults violate which "
                    "relation. A relation holds when the median discrepancy over the repetitions is within "
                    "the tolerance: for the unmodified SLAM and statistical relations a multiple of its "
                    "seed-to-seed spread, for faults on exact relations a multiple of the unmodified SLAM's "
                    "own discrepancy (see faultlab.metamorphic.check). Exit status 1 if the unmodified SLAM "
                    "violates a relation.")
    p.add_argument("--slam", default="fastslam", metavar="NAME",
                   help="built-in SLAM or package.module:factory (default fastslam)")
    p.add_argument("--faults", nargs="*", default=None, metavar="FAULT",
                   help="faults to check (names or module:attr paths; default: every fault that applies)")
    p.add_argument("--relations", nargs="*", default=None, metavar="RELATION",
                   help="relations to check (default: all, plugins included)")
    p.add_argument("--repetitions", type=int, default=5, metavar="K", dest="repetitions",
                   help="repetitions (SLAM seeds), >= 2 (default 5)")
    p.add_argument("--reps", type=int, dest="repetitions", help=argparse.SUPPRESS)  # the former spelling
    p.add_argument("--steps", type=int, default=150, metavar="N",
                   help="active steps of the source case (default 150)")
    p.add_argument("--particles", type=int, default=50, metavar="N",
                   help="particles, for SLAMs that have them (default 50)")
    p.add_argument("--seed", type=int, default=0, help="seed of the source case and the repetitions (default 0)")
    p.add_argument("--factor", type=float, default=None,
                   help=LazyText(lambda: f"tolerance factor of the decision rule (default {_defaults()[0]:g})"))
    p.add_argument("--atol", type=float, default=None,
                   help=LazyText(lambda: f"least tolerance, m (default {_defaults()[1]:g})"))
    p.add_argument("--no-plugins", action="store_true", help="ignore fault and relation plugins")
    add_examples(p, ["faultlab metamorphic", "faultlab metamorphic --slam ekf --repetitions 3",
                     "faultlab metamorphic --faults naive_resampling --relations rigid_motion"])
    p.set_defaults(func=_handler)


def _handler(args: argparse.Namespace) -> int:
    import numpy as np

    from faultlab.faults import all_faults, applicable_faults, resolve_fault
    from faultlab.metamorphic import all_relations, get_relation, metamorphic_scenario, relation_matrix
    from faultlab.slam.registry import build_slam, get_slam_kind

    factor, atol = _defaults()
    factor = factor if args.factor is None else args.factor
    atol = atol if args.atol is None else args.atol
    if args.repetitions < 2:
        raise ConfigError(f"--repetitions must be >= 2 (the seed-to-seed spread needs two runs), "
                          f"got {args.repetitions}")
    if args.steps < 1:
        raise ConfigError(f"--steps must be >= 1, got {args.steps}")
    kind = get_slam_kind(args.slam, where="--slam")
    options = {}
    if kind is not None and kind.config is not None and "particles" in {o.key for o in kind.config.OPTIONS.values()}:
        options = kind.options({"particles": args.particles}, where="--particles")
    factory = functools.partial(build_slam, args.slam, options)
    plugins = not args.no_plugins
    faults = ([resolve_fault(f) for f in args.faults] if args.faults is not None
              else all_faults(plugins=plugins, warn=False))
    fit = applicable_faults(factory() if kind is None else args.slam, faults)
    relations = ([get_relation(r) for r in args.relations] if args.relations is not None
                 else all_relations(plugins=plugins))
    scenario = metamorphic_scenario(seed=args.seed, n_steps=args.steps)
    rngs = [np.random.default_rng(np.random.SeedSequence([args.seed, 1, k])) for k in range(args.repetitions)]
    description = (f"SLAM {args.slam!r}{f' ({args.particles} particles)' if options else ''}, fixed-suite case "
                   f"on a 4 m x 4 m map ({args.steps} steps, seed {args.seed})")
    matrix = relation_matrix(factory, relations, fit.applicable, scenario, rngs=rngs, factor=factor,
                             atol=atol, description=description,
                             skipped=[fit.summary()] if fit.not_applicable else [])
    print(matrix.format())
    return 0 if all(matrix.results[("baseline", r)].holds for r in matrix.relations) else 1
