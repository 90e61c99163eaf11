"""``faultlab compare BASELINE CANDIDATE``: a regression gate of one SLAM version against another."""

from __future__ import annotations

import argparse
import shlex
import sys
from pathlib import Path

from faultlab.cli.options import LazyText, add_examples, positive_int
from faultlab.errors import ConfigError, FaultlabError
from faultlab.vocabulary import DEFAULT_ALPHA

__all__ = ["register"]


def _default_delta() -> float:
    from faultlab.analysis.compare import DEFAULT_DELTA

    return DEFAULT_DELTA


def _default_timeout() -> float:
    from faultlab.campaigns.checkspec import DEFAULT_TIMEOUT_S

    return DEFAULT_TIMEOUT_S


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "compare", help="regression gate: a candidate SLAM against a recorded baseline on one coverage-driven suite "
                        "(regression, improvement, equivalent within delta, inconclusive)",
        description="Record the map errors of the BASELINE SLAM on a coverage-driven suite (default: the pairwise "
                    "suite over Table I, K repetitions per case) into a checksummed, resumable record, run the "
                    "CANDIDATE on the same scenarios, and judge the change of the map error per case and pooled "
                    "over the suite (cases are the unit: a one-sided t test for a regression, TOST for equivalence "
                    "within delta). BASELINE is a SLAM (built-in name or package.module:factory) or a directory "
                    "holding a recorded baseline, reused as is. Exit status 0 when no regression is shown, 1 on a "
                    "regression, 3 when --require-equivalence was asked and equivalence is not shown, 2 on a usage "
                    "or input error.")
    p.add_argument("baseline", nargs="?", default="", metavar="BASELINE",
                   help="baseline SLAM (built-in name or package.module:factory) or a recorded baseline directory")
    p.add_argument("candidate", nargs="?", default="", metavar="CANDIDATE",
                   help="candidate SLAM (built-in name or package.module:factory)")
    p.add_argument("--baseline-command", default="", metavar="'PROG ARGS'",
                   help="a baseline SLAM program speaking the process protocol, instead of BASELINE")
    p.add_argument("--candidate-command", default="", metavar="'PROG ARGS'",
                   help="a candidate SLAM program speaking the process protocol, instead of CANDIDATE")
    p.add_argument("--record-only", action="store_true",
                   help="record the baseline into --baseline-store and stop (no candidate)")
    p.add_argument("--path", action="append", default=[], metavar="DIR",
                   help="directory to put on the import path before importing a factory (repeatable)")
    p.add_argument("--suite", default=None, help="suite kind (default pairwise, as faultlab check)")
    p.add_argument("--space", default=None, metavar="FILE.toml",
                   help="override Table I's classes (format of experiments/space_table1.toml), e.g. smaller maps")
    p.add_argument("--cases", type=positive_int, default=None, metavar="N", help="suite size (default: the suite's)")
    p.add_argument("--steps", type=positive_int, default=200, metavar="N", help="active steps per case (default 200)")
    p.add_argument("--seed", type=int, default=1, help="seed of the suite and the baseline's repetitions (default 1)")
    p.add_argument("--candidate-seed", type=int, default=None,
                   help="seed of the candidate's repetitions (default: the baseline's, common random numbers)")
    p.add_argument("--repetitions", "-K", type=int, default=8, metavar="K",
                   help="runs per case, >= 2; a deterministic SLAM is run twice and judged exactly (default 8)")
    p.add_argument("--alpha", type=float, default=DEFAULT_ALPHA,
                   help=f"level of each one-sided test (default {DEFAULT_ALPHA:g})")
    p.add_argument("--delta", type=float, default=None,
                   help=LazyText(lambda: f"equivalence margin, a relative change of the map error in (0, 1) "
                                         f"(default {_default_delta():g}: see docs/how-to/compare-in-ci.md)"))
    p.add_argument("--require-equivalence", action="store_true",
                   help="exit 3 unless equivalence within delta is shown")
    p.add_argument("--html", action="store_true",
                   help="also write the HTML report (REPORTS/html: the verdict, every case in a sortable, filterable "
                        "table)")
    p.add_argument("--baseline-store", default=None, metavar="DIR",
                   help="where the baseline is recorded (default OUT/baseline; resumable, reusable)")
    p.add_argument("--out", default="results/compare", help="results directory (default results/compare; resumable)")
    p.add_argument("--reports", default=None, help="reports directory (default OUT/report)")
    p.add_argument("--timeout", type=float, default=None, metavar="S",
                   help=LazyText(lambda: f"wall-clock limit of one run of a SLAM, s; a run past it failed "
                                         f"(default {_default_timeout():g})"))
    p.add_argument("--jobs", type=positive_int, default=1, help="worker processes (default 1)")
    add_examples(p, ["faultlab compare mylab.v1:make mylab.v2:make --path .",
                     "faultlab compare fastslam --record-only --baseline-store baseline/",
                     "faultlab compare baseline/ --candidate-command './my_slam' --require-equivalence"])
    p.set_defaults(func=_handler)


def _error(message: str) -> int:
    print(f"faultlab compare: error: {message}", file=sys.stderr)
    return 2


def _handler(args: argparse.Namespace) -> int:
    from faultlab.analysis.compare import compare_records
    from faultlab.campaigns.compare import RECORD_FILE, RecordSpec, candidate_spec, read_record, record
    from faultlab.config import read_toml
    from faultlab.report.compare import write_compare_reports

    out = Path(args.out)
    store = Path(args.baseline_store) if args.baseline_store else out / "baseline"
    try:
        delta = _default_delta() if args.delta is None else args.delta
        if not 0 < delta < 1:
            raise ConfigError(f"--delta must lie in (0, 1) (a relative change), got {delta}")
        if not 0 < args.alpha < 0.5:
            raise ConfigError(f"--alpha must lie in (0, 0.5), got {args.alpha}")
        reuse = bool(args.baseline) and (Path(args.baseline) / RECORD_FILE).is_file()
        if reuse:
            store = Path(args.baseline)
            baseline = read_record(store)
            if not baseline.complete:
                raise ConfigError(f"{store}: the baseline record is incomplete ({len(baseline.cases)} of "
                                  f"{len(baseline.case_ids)} cases); rerun the command that recorded it to resume")
            base_spec, base_cases = baseline.spec, list(baseline.cases)
        else:
            base_spec = RecordSpec(slam=args.baseline, command=tuple(shlex.split(args.baseline_command)),
                                   suite=args.suite or RecordSpec.suite, n_cases=args.cases, n_steps=args.steps,
                                   seed=args.seed, repetitions=args.repetitions, paths=tuple(args.path),
                                   space=read_toml(args.space, what="--space")[0] if args.space else {},
                                   timeout_s=_default_timeout() if args.timeout is None else args.timeout
                                   ).validate()
        if not args.record_only:
            cand_spec = candidate_spec(base_spec, slam=args.candidate,
                                       command=tuple(shlex.split(args.candidate_command)),
                                       rep_seed=args.candidate_seed, paths=tuple(args.path)).validate()
        if not reuse:
            base_cases = record(base_spec, store, jobs=args.jobs)
        if args.record_only:
            print(f"baseline recorded: {store} ({len(base_cases)} cases)")
            return 0
        cand_cases = record(cand_spec, out / "candidate", jobs=args.jobs)
        result = compare_records(base_spec.to_dict(), base_cases, cand_spec.to_dict(), cand_cases, delta=delta,
                                 alpha=args.alpha)
    except (FaultlabError, OSError) as exc:  # a usage or input error, or a disk full: never exit 1 (regression)
        return _error(str(exc))
    paths = write_compare_reports(result, args.reports or out / "report",
                                  require_equivalence=args.require_equivalence)
    if args.html:
        from faultlab.report.html.compare import write_compare_html

        paths.append(write_compare_html(result, paths[0].parent / "html").index)
    print(paths[0].read_text(), end="")
    print("reports: " + ", ".join(map(str, paths)))
    return result.exit_code(require_equivalence=args.require_equivalence)

