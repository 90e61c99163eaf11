"""``faultlab check SLAM``: test a SLAM on a coverage-driven suite with oracles that need no injected fault."""

from __future__ import annotations

import argparse
import shlex
import sys

from faultlab.cli.options import LazyText, add_examples, positive_int
from faultlab.errors import ConfigError, FaultlabError
from faultlab.vocabulary import DEFAULT_ALPHA

__all__ = ["register"]


def _defaults():
    """(suite, oracles, oracle options) when not given: read when needed, the oracles are slow to import."""
    from faultlab.campaigns.check import DEFAULT_ORACLES, DEFAULT_SUITE
    from faultlab.oracles import DEFAULT_OPTIONS

    return DEFAULT_SUITE, DEFAULT_ORACLES, DEFAULT_OPTIONS


def _default_timeout() -> float:
    from faultlab.campaigns.checkspec import DEFAULT_TIMEOUT_S

    return DEFAULT_TIMEOUT_S


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "check", help="test your SLAM: a coverage-driven suite judged by execution, metamorphic, floor and "
                      "differential oracles; failures shrunk to minimal reproducers",
        description="Run the SLAM under test K times on each case of a coverage-driven suite (default: the "
                    "pairwise suite over Table I) and judge every case by oracles that need no injected fault. "
                    "Each failure is reduced to a minimal scenario and written as a reproducer (case file, "
                    "replay command, pytest file). Exit status 0 when nothing fails, 1 when a case fails, 2 on a "
                    "usage error.")
    p.add_argument("slam", nargs="?", default="", metavar="SLAM",
                   help="built-in SLAM name or package.module:factory (the working directory and --path are on "
                        "the import path)")
    p.add_argument("--command", default="", metavar="'PROG ARGS'",
                   help="a SLAM program speaking the process protocol, instead of SLAM")
    p.add_argument("--path", action="append", default=[], metavar="DIR",
                   help="directory to put on the import path before importing the factory (repeatable)")
    p.add_argument("--reference", default="ekf", metavar="SLAM",
                   help="reference SLAM of the differential oracle, or 'none' (default ekf)")
    p.add_argument("--suite", default=None, help=LazyText(lambda: f"suite kind (default {_defaults()[0]})"))
    p.add_argument("--space", default=None, metavar="FILE.toml",
                   help="override Table I's classes (format of experiments/space_table1.toml), e.g. smaller maps")
    p.add_argument("--cases", type=positive_int, default=None, metavar="N", help="suite size (default: the suite's)")
    p.add_argument("--steps", type=positive_int, default=200, metavar="N", help="active steps per case (default 200)")
    p.add_argument("--seed", type=int, default=1, help="seed of the suite and the repetitions (default 1)")
    p.add_argument("--repetitions", "-K", type=int, default=8, metavar="K",
                   help="runs per case, >= 2; a deterministic SLAM is run twice (default 8)")
    p.add_argument("--alpha", type=float, default=DEFAULT_ALPHA,
                   help=f"chance that a correct stochastic SLAM fails a case (default {DEFAULT_ALPHA:g})")
    p.add_argument("--oracles", nargs="+", default=None, metavar="ORACLE",
                   help=LazyText(lambda: f"oracles to apply (default: {' '.join(_defaults()[1])}; plugins by name)"))
    p.add_argument("--relations", nargs="+", default=None, metavar="RELATION",
                   help=LazyText(lambda: f"metamorphic relations (default: {' '.join(_defaults()[2]['relations'])})"))
    p.add_argument("--option", action="append", default=[], metavar="KEY=VALUE",
                   help=LazyText(lambda: f"an oracle margin: {', '.join(k for k in _defaults()[2] if k not in _NOT_NUMBERS)}"))
    p.add_argument("--budget", action="append", default=[], metavar="PARAMETER.CLASS=MM",
                   help="an accuracy budget of the budget oracle for the cases in one Table I class, e.g. "
                        "map_size.large=500 (repeatable; with --option budget_mm=MM for every other case)")
    p.add_argument("--case", default=None, metavar="CASE.npz", help="judge one saved case instead of a suite")
    p.add_argument("--case-id", default=None, help="the case's id (its repetition seeds); default from the file")
    p.add_argument("--html", action="store_true",
                   help="also write the HTML report (REPORTS/html: the verdict per oracle, every result in a sortable, "
                        "filterable table, the minimal failing scenarios)")
    p.add_argument("--out", default="results/check", help="results directory (default results/check; resumable)")
    p.add_argument("--reports", default=None, help="reports directory (default OUT/report)")
    p.add_argument("--timeout", type=float, default=None, metavar="S",
                   help=LazyText(lambda: f"wall-clock limit of one run of the SLAM, s; a run past it fails the "
                                         f"execution oracle (default {_default_timeout():g})"))
    p.add_argument("--jobs", type=positive_int, default=1, help="worker processes (default 1)")
    p.add_argument("--no-shrink", action="store_true", help="do not reduce failures to minimal scenarios")
    add_examples(p, ["faultlab check mylab.mapper:make --path .", "faultlab check --command './my_slam --quiet'",
                     "faultlab check fastslam --cases 5 --steps 100 --jobs 2"])
    p.set_defaults(func=_handler)


def _options(args) -> dict:
    default_options = _defaults()[2]
    options: dict = {}
    for item in args.option:
        key, sep, value = item.partition("=")
        if not sep or key not in default_options or key in _NOT_NUMBERS:
            raise ConfigError(f"--option {item!r}: expected KEY=VALUE with KEY one of "
                              f"{', '.join(k for k in default_options if k not in _NOT_NUMBERS)}")
        try:
            options[key] = float(value)
        except ValueError:
            raise ConfigError(f"--option {item!r}: {value!r} is not a number") from None
    if args.relations is not None:
        options["relations"] = tuple(args.relations)
    budgets = {}
    for item in args.budget:
        key, sep, value = item.partition("=")
        try:
            budgets[key] = float(value) if sep else None
        except ValueError:
            budgets[key] = None
        if budgets[key] is None:
            raise ConfigError(f"--budget {item!r}: expected PARAMETER.CLASS=MM, e.g. map_size.large=500")
    if budgets:
        options["budget_classes"] = budgets
    return options


#: Oracle options that are not one number (set by their own flags).
_NOT_NUMBERS = ("relations", "budget_classes")


def _oracles(args) -> tuple[str, ...]:
    """The oracles asked for; by default check's, plus ``budget`` when a budget is declared."""
    if args.oracles:
        return tuple(args.oracles)
    declared = args.budget or any(item.partition("=")[0] in ("budget_mm", "budget_step_ms") for item in args.option)
    return tuple(_defaults()[1]) + (("budget",) if declared else ())


def _handler(args: argparse.Namespace) -> int:
    from faultlab.analysis.check import summarise_check
    from faultlab.campaigns.check import CheckSpec, case_records, run_check
    from faultlab.campaigns.checkspec import judge_scenario
    from faultlab.config import read_toml
    from faultlab.report.check import write_check_reports
    from faultlab.scenario.model import load_scenario

    try:
        spec = CheckSpec(slam=args.slam, command=tuple(shlex.split(args.command)), n_cases=args.cases,
                         reference="" if args.reference == "none" else args.reference,
                         suite=args.suite or _defaults()[0],
                         n_steps=args.steps, seed=args.seed, repetitions=args.repetitions, alpha=args.alpha,
                         oracles=_oracles(args), options=_options(args), paths=tuple(args.path),
                         space=read_toml(args.space, what="--space")[0] if args.space else {},
                         timeout_s=_default_timeout() if args.timeout is None else args.timeout).validate()
    except ConfigError as exc:
        print(f"faultlab check: error: {exc}", file=sys.stderr)
        return 2
    try:
        if args.case:
            scenario = load_scenario(args.case)
            case_id = args.case_id or scenario.meta.get("check_case", scenario.meta.get("name", "case"))
            judgement = judge_scenario(spec, case_id, scenario)
            for r in judgement.results:
                print(f"{case_id} {r.oracle}: {r.status.upper() if r.failed else r.status} -- {r.message}")
            return 1 if judgement.failed else 0
        records = run_check(spec, args.out, jobs=args.jobs, shrink=not args.no_shrink)
        records = case_records(args.out)
    except ConfigError as exc:
        print(f"faultlab check: error: {exc}", file=sys.stderr)
        return 2
    except FaultlabError:
        raise
    summary = summarise_check(spec.to_dict(), records)
    paths = write_check_reports(summary, records, spec.to_dict(), args.reports or f"{args.out}/report")
    if args.html:
        from faultlab.report.html.check import write_check_html

        paths.append(write_check_html(summary, records, spec.to_dict(), paths[0].parent / "html").pages[0])
    print(paths[0].read_text(), end="")
    print("reports: " + ", ".join(map(str, paths)))
    return 1 if summary.failed else 0
