"""``paper-table`` and ``effects`` commands."""

from __future__ import annotations

import argparse

from faultlab import stats

__all__ = ["register"]


def _rule_options(p: argparse.ArgumentParser) -> None:
    d = stats.DetectionRule()
    p.add_argument("--abs-mm", type=float, default=d.abs_mm, metavar="MM",
                   help=f"absolute RMS increase a detection must exceed (default {d.abs_mm:g} mm)")
    p.add_argument("--rel", type=float, default=d.rel,
                   help=f"relative RMS increase a detection needs at least (default {d.rel:g})")


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "paper-table", help="recompute Table II from the paper's raw data and compare with the printed one",
        description="Recompute the paper's Table II (detected cells, Detected Faults %, by Suite %) from "
                    "its raw RMS data with faultlab's detection rule and mark every cell where the "
                    "printed figure differs.")
    p.add_argument("--raw", default=None, metavar="PATH",
                   help="raw RMS CSV (default: the paper's raw data in paper_repro/, looked up in the "
                        "current directory, then in the copy shipped with faultlab)")
    p.add_argument("--reported", default=None, metavar="PATH",
                   help="printed percentages CSV (default: the paper's Table II percentages in paper_repro/)")
    _rule_options(p)
    p.set_defaults(func=_paper_table)

    e = subparsers.add_parser(
        "effects", help="logistic regression of detection on the scenario parameters, per fault",
        description="Per fault, a binomial GLM of detection on the standardised scenario parameters "
                    "(odds ratio per standard deviation, 95 % CI) from a results directory.")
    e.add_argument("results", metavar="RESULTS", help="results directory written by `faultlab run`")
    e.add_argument("--parameters", default=None, metavar="A,B,...",
                   help="comma-separated predictors (default: every scenario parameter)")
    _rule_options(e)
    e.set_defaults(func=_effects)


def _paper_table(args) -> int:
    rule = stats.DetectionRule(abs_mm=args.abs_mm, rel=args.rel)
    table = stats.paper_table(stats.resolve_data_path(args.raw, stats.RAW_CSV),
                              stats.resolve_data_path(args.reported, stats.REPORTED_CSV),
                              rule=rule)
    print(table.to_text(), end="")
    return 0


def _effects(args) -> int:
    from faultlab.runner import load_results  # helper E's runner; imported only when needed

    rule = stats.DetectionRule(abs_mm=args.abs_mm, rel=args.rel)
    params = None if args.parameters is None else [p.strip() for p in args.parameters.split(",") if p.strip()]
    table = stats.parameter_effects(load_results(args.results), rule=rule, parameters=params)
    print(f"Detection: {rule.describe()}")
    print(stats.format_effects(table), end="")
    return 0
