"""``python -m faultlab generate``: write a suite of test cases, one PNG per case, print coverage."""

from __future__ import annotations

import argparse

from faultlab.cli.options import positive_int
from faultlab.report.casefig import save_case_png
from faultlab.scenario.files import write_suite
from faultlab.space.parameters import load_space
from faultlab.vocabulary import SUITE_KINDS

__all__ = ["register", "handler"]


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "generate",
        help="generate a test suite (cases + pictures) and print its coverage",
        description="Draw a test suite from the parameter space (Table I, or a TOML override), generate "
                    "every test case (Sec. VI), save it as OUT/case<i>.npz + .json with a picture "
                    "OUT/case<i>.png (Fig. 5 style), write OUT/coverage.csv and OUT/cases.csv, and print "
                    "the coverage table.",
    )
    p.add_argument("--suite", choices=SUITE_KINDS, default="systematic", help="suite kind (default: systematic)")
    p.add_argument("--seed", type=int, default=0,
                   help="root seed, as in an experiment file (default: 0)")
    p.add_argument("--run", type=positive_int, default=1, metavar="R",
                   help="evaluation run (default: 1): the cases are those run R of a campaign with the same "
                        "seed tests for this suite")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--cases", type=int, default=None, metavar="N",
                   help="number of cases (default: the smallest systematic suite, 5 with Table I)")
    p.add_argument("--space", default=None, metavar="FILE",
                   help="TOML file overriding Table I classes (see experiments/space_table1.toml, "
                        "shipped as the name space_table1)")
    p.add_argument("--steps", type=int, default=1000, metavar="N", help="active steps per case (default: 1000)")
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    space = load_space(args.space) if args.space else None
    result = write_suite(args.suite, seed=args.seed, run=args.run, out=args.out, n_cases=args.cases, space=space,
                         n_steps=args.steps)
    for path, sc in zip(result.paths, result.scenarios):
        save_case_png(sc, path.with_suffix(".png"))
    print(f"{result.kind} suite, seed {result.seed}, run {args.run}: {len(result.paths)} cases written to {result.out} "
          f"(case<i>.npz/.json/.png, cases.csv, coverage.csv)")
    print(result.coverage)
    return 0
