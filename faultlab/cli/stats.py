"""``paper-table`` and ``stats adaptive`` commands (``effects`` lives in :mod:`faultlab.cli.effects`)."""

from __future__ import annotations

import argparse

from faultlab import analysis, stats  # both load their submodules (statsmodels, ...) on first use
from faultlab.cli.options import LazyChoices, LazyText, add_examples, add_verb_group, epilog, print_paths
from faultlab.errors import ConfigError, ResultsError

__all__ = ["register"]


def _alternatives() -> tuple[str, ...]:
    from faultlab.inference.exact import ALTERNATIVES

    return ALTERNATIVES


def _design():
    """The staged design's defaults (read when shown: the inference package is slow to import)."""
    from faultlab.inference.sequential import StagedDesign

    return StagedDesign


def register(subparsers) -> None:
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
                   help=LazyText(lambda: f"absolute RMS increase a detection must exceed "
                                         f"(default {stats.DetectionRule().abs_mm:g} mm)"))
    p.add_argument("--rel", type=float, default=None,
                   help=LazyText(lambda: f"relative RMS increase a detection needs at least "
                                         f"(default {stats.DetectionRule().rel:g})"))
    add_examples(p, ["faultlab paper-table", "faultlab paper-table results/paper", "faultlab paper-table --abs-mm 200"])
    p.set_defaults(func=_paper_table)

    sub = add_verb_group(
        subparsers, "stats", help="statistics of a finished campaign: 'adaptive' replays adaptive repetitions",
        description="'adaptive' replays an [adaptive] design (stages, level, sidedness, futility bound) on a "
                    "complete fixed-K store with the runner's own stopping rule, and reports the SLAM executions "
                    "it would have saved, where each (case, variant) stops and which per-case verdicts change, "
                    "and why. It runs no SLAM.",
        examples=["faultlab stats adaptive results/paper-k10 --stages 5,10",
                  "faultlab stats adaptive results/paper-k10 --stages 6,11 --alternative two-sided "
                  "--reports reports/adaptive"])
    a = sub.add_parser(
        "adaptive", help="replay adaptive repetitions on a fixed-K store: executions saved, stops, verdicts",
        description="Replay adaptive repetitions on a complete fixed-K store: the rows an adaptive campaign "
                    "would have run (repetition r has the same seed in both designs), judged by the store's "
                    "detection rule, against all K. Prints the Markdown page, or with --reports writes "
                    "summary.csv, pairs.csv, verdicts.csv, replay_meta.json and adaptive_replay.md there.",
        **epilog(["faultlab stats adaptive results/paper-k10 --stages 5,10",
                  "faultlab stats adaptive results/paper-k10 --stages 6,11 --alternative two-sided "
                  "--reports reports/adaptive"]))
    a.add_argument("results", metavar="STORE", help="results directory of a finished fixed-K campaign")
    a.add_argument("--stages", default=None, metavar="K1,K2,...",
                   help="cumulative repetitions after each stage, the last the store's K (default: the stored "
                        "experiment's [adaptive] stages)")
    a.add_argument("--level", type=float, default=None,
                   help=LazyText(lambda: f"per-case level of the looks (default {_design().level:g})"))
    a.add_argument("--alternative", default=None, choices=LazyChoices(_alternatives), metavar="SIDE",
                   help=LazyText(lambda: f"sidedness of the looks: {', '.join(_alternatives())} "
                                         f"(default {_design().alternative})"))
    a.add_argument("--futility", type=float, default=None,
                   help=LazyText(lambda: f"futility bound in [level, 1] (default {_design().futility:g})"))
    a.add_argument("--reports", default=None, metavar="DIR", help="write the tables and the page here")
    a.set_defaults(func=_adaptive)


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


def _adaptive(args: argparse.Namespace) -> int:
    from faultlab.analysis.replay import replay_adaptive
    from faultlab.report.replay import replay_markdown, write_replay

    given = {k: v for k, v in (("level", args.level), ("alternative", args.alternative),
                               ("futility", args.futility)) if v is not None}
    design = None
    if args.stages is not None:
        try:
            design = {"stages": [int(k) for k in args.stages.split(",")], **given}
        except ValueError:
            raise ConfigError(f"--stages: expected cumulative repetitions such as 5,10, got {args.stages!r}") \
                from None
    elif given:
        raise ConfigError("stats adaptive: --level, --alternative and --futility need --stages")
    replay = replay_adaptive(args.results, design)
    if args.reports is None:
        print(replay_markdown(replay), end="")
        return 0
    return print_paths(write_replay(replay, args.reports))
