"""``paper-table`` and ``effects`` commands."""

from __future__ import annotations

import argparse

from faultlab import analysis, stats  # both load their submodules (statsmodels, ...) on first use
from faultlab.cli.options import add_examples
from faultlab.errors import ConfigError, ResultsError

__all__ = ["register"]


def register(subparsers) -> None:
    d = stats.DetectionRule()
    p = subparsers.add_parser(
        "paper-table", help="recompute Table II from the paper's raw data and compare with the printed one",
        description="Recompute the paper's Table II (detected cells, Detected Faults %, by Suite %) from "
                    "its raw RMS data with faultlab's detection rule and mark every cell where the "
                    "printed figure differs. Given a results directory, the rule is the one stored with "
                    "that campaign, and the table is the one its report compares with.")
    p.add_argument("results", nargs="?", default=None, metavar="RESULTS",
                   help="results directory whose stored detection rule judges the paper's data (default: "
                        "the rule of --abs-mm / --rel)")
    p.add_argument("--raw", default=None, metavar="PATH",
                   help="raw RMS CSV (default: the paper's raw data in paper_repro/, looked up in the "
                        "current directory, then in the copy shipped with faultlab)")
    p.add_argument("--reported", default=None, metavar="PATH",
                   help="printed percentages CSV (default: the paper's Table II percentages in paper_repro/)")
    p.add_argument("--abs-mm", type=float, default=None, metavar="MM",
                   help=f"absolute RMS increase a detection must exceed (default {d.abs_mm:g} mm)")
    p.add_argument("--rel", type=float, default=None,
                   help=f"relative RMS increase a detection needs at least (default {d.rel:g})")
    add_examples(p, ["faultlab paper-table", "faultlab paper-table results/paper", "faultlab paper-table --abs-mm 200"])
    p.set_defaults(func=_paper_table)

    e = subparsers.add_parser(
        "effects", help="logistic regression of detection on the scenario parameters, per fault",
        description="Per fault, a binomial GLM of detection on the standardised scenario parameters "
                    "(odds ratio per standard deviation, 95 % CI) from a results directory, detection "
                    "judged by the rule stored with the campaign (as in its report).")
    e.add_argument("results", metavar="RESULTS", help="results directory written by `faultlab run`")
    e.add_argument("--parameters", default=None, metavar="A,B,...",
                   help="comma-separated predictors (default: every scenario parameter)")
    add_examples(e, ["faultlab effects results/paper", "faultlab effects results/paper --parameters map_size,landmark_density"])
    e.set_defaults(func=_effects)


def _paper_table(args: argparse.Namespace) -> int:
    if args.results is None:
        d = stats.DetectionRule()
        rule = stats.DetectionRule(abs_mm=d.abs_mm if args.abs_mm is None else args.abs_mm,
                                   rel=d.rel if args.rel is None else args.rel)
        table = stats.paper_table(stats.resolve_data_path(args.raw, stats.RAW_CSV),
                                  stats.resolve_data_path(args.reported, stats.REPORTED_CSV), rule=rule)
    else:
        if args.abs_mm is not None or args.rel is not None:
            raise ConfigError("paper-table: give either RESULTS (its stored detection rule) or --abs-mm / --rel")
        result = analysis.analyse(args.results, paper_raw=args.raw, paper_reported=args.reported)
        table = result.paper_table
        if table is None:
            raise ResultsError(" ".join(n.text for n in result.notes_on("paper")))
    print(table.to_text(), end="")
    return 0


def _effects(args: argparse.Namespace) -> int:
    params = None if args.parameters is None else [p.strip() for p in args.parameters.split(",") if p.strip()]
    result = analysis.analyse(args.results, paper=False, parameters=params)
    print(f"Detection (stored with the campaign): {result.rule.describe()}")
    print(stats.format_effects(result.parameter_effects), end="")
    for note in result.notes_on("parameter_effects"):
        print(f"note: {note}")
    return 0
