"""``python -m faultlab generate``: write a suite of test cases, one PNG per case, print coverage."""

from __future__ import annotations

import argparse

from faultlab.cli.options import LazyChoices, LazyText, add_examples, positive_int

__all__ = ["register", "handler"]


def _base_item(text: str) -> tuple[str, str]:
    """argparse type: ``parameter=class``."""
    name, sep, cls = text.partition("=")
    if not sep or not name.strip() or not cls.strip():
        raise argparse.ArgumentTypeError(f"expected PARAMETER=CLASS such as map_size=small, got {text!r}")
    return name.strip(), cls.strip()


def _suite_kinds() -> tuple[str, ...]:
    from faultlab.space.registry import suite_kinds

    return suite_kinds()


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "generate",
        help="generate a test suite (cases + pictures) and print its coverage",
        description="Draw a test suite from the parameter space (Table I, or a TOML override), generate "
                    "every test case (Sec. VI), save it as OUT/case<i>.npz + .json with a picture "
                    "OUT/case<i>.png (Fig. 5 style), write OUT/coverage.csv and OUT/cases.csv, and print "
                    "the class coverage table and the pairwise coverage (and the base-choice or t-wise "
                    "coverage of those suites).",
    )
    p.add_argument("--suite", choices=LazyChoices(_suite_kinds), default="systematic", metavar="KIND",
                   help=LazyText(lambda: f"suite kind: {', '.join(_suite_kinds())} (default: systematic); pairwise and "
                                "<t>-wise cover every combination of classes of any t parameters, base-choice "
                                "varies one parameter of a base case at a time, effect-guided chooses classes "
                                "by weight after covering each once"))
    p.add_argument("--seed", type=int, default=0,
                   help="root seed, as in an experiment file (default: 0)")
    p.add_argument("--run", type=positive_int, default=1, metavar="R",
                   help="evaluation run (default: 1): the cases are those run R of a campaign with the same "
                        "seed tests for this suite")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--cases", type=int, default=None, metavar="N",
                   help="number of cases (default: the builder's choice: 5 with Table I for systematic, "
                        "random, fixed and effect-guided; the covering rows for base-choice and t-wise, "
                        "which is also their minimum)")
    p.add_argument("--space", default=None, metavar="FILE",
                   help="TOML file overriding Table I classes, with optional [constraints], [base] and "
                        "[weights] (see experiments/space_table1.toml, shipped as the name space_table1)")
    p.add_argument("--base", type=_base_item, action="append", default=[], metavar="PARAMETER=CLASS",
                   help="base class of a parameter for the base-choice suite (repeatable; default: the "
                        "class of the fixed suite's value)")
    p.add_argument("--weights", default=None, metavar="CSV",
                   help="class weights of the effect-guided suite: a CSV file with the columns "
                        "parameter, class, weight")
    p.add_argument("--steps", type=int, default=1000, metavar="N", help="active steps per case (default: 1000)")
    p.add_argument("--fov-bug", action="store_true",
                   help="reproduce the paper's replication package's field-of-view DEFECT: every right-side "
                        "bearing is visible whatever the opening (as an experiment's fov_bug = true)")
    add_examples(p, ["faultlab generate --out cases/systematic", "faultlab generate --suite pairwise --seed 3 --out cases/pairwise",
                     "faultlab generate --suite random --cases 10 --steps 200 --out cases/random"])
    p.set_defaults(func=handler)


def handler(args: argparse.Namespace) -> int:
    from faultlab.report.casefig import save_case_png
    from faultlab.scenario.files import write_suite
    from faultlab.space.parameters import load_space, table1_space
    from faultlab.space.registry import suite_criteria
    from faultlab.space.settings import read_class_weights

    space = load_space(args.space) if args.space else None
    if args.base or args.weights:
        space = space or table1_space()
        if args.base:
            space = space.with_base(dict(args.base), source="--base")
        if args.weights:
            space = space.with_weights(read_class_weights(args.weights), source=args.weights)
    result = write_suite(args.suite, seed=args.seed, run=args.run, out=args.out, n_cases=args.cases, space=space,
                         n_steps=args.steps, fov_bug=args.fov_bug)
    for path, sc in zip(result.paths, result.scenarios):
        save_case_png(sc, path.with_suffix(".png"))
    print(f"{result.kind} suite, seed {result.seed}, run {args.run}: {len(result.paths)} cases written to {result.out} "
          f"(case<i>.npz/.json/.png, cases.csv, coverage.csv)")
    print(result.coverage)
    cases = [sc.case for sc in result.scenarios]
    for measure in suite_criteria(result.kind, cases, space or table1_space()):
        print(measure)
    return 0
