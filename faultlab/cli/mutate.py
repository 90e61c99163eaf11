"""``python -m faultlab mutate list|show|run|report``: mutants of a SLAM's units, screened, run and scored."""

from __future__ import annotations

import argparse
from pathlib import Path

from faultlab.cli.options import add_examples, add_execution_options, add_verb_group, positive_int, print_paths

__all__ = ["register"]


def register(subparsers) -> None:
    sub = add_verb_group(
        subparsers, "mutate", help="mutation analysis: list the mutants of a SLAM's units, show one",
        description="Generate mutants of the replaceable units of a SLAM from their source (one small "
                    "change per mutant, classic and numpy-aware operators) and screen them at the unit "
                    "level: stillborn (does not compile or always raises), equivalent (same bytecode or "
                    "bit-identical unit outputs) and duplicate mutants never need a campaign.",
        examples=["faultlab mutate list --unit motion_model", "faultlab mutate show motion_model:arithmetic:9",
                  "faultlab mutate run mutation --out results/mutation"])

    ls = sub.add_parser("list", help="list the mutants (by default only the live ones) and count each class",
                        description="One line per mutant: id, unit, line, operator and the changed line; then "
                                    "a count line per class. By default stillborn, equivalent and duplicate "
                                    "mutants are only counted; --all lists them too, with their class.")
    _common(ls)
    ls.add_argument("--unit", default=None, metavar="U", help="only the mutants of this unit")
    ls.add_argument("--operator", default=None, metavar="O", help="only the mutants of this operator")
    ls.add_argument("--all", action="store_true", dest="all_mutants",
                    help="list every mutant with its class, not only the live ones")
    ls.add_argument("--target", default=None, metavar="TARGET",
                    help="list the mutants of user code instead (package.module[:function] or file.py[:lines]; "
                         "not screened: `mutate run` screens them on probe scenarios)")
    add_examples(ls, ["faultlab mutate list", "faultlab mutate list --all --operator arithmetic",
                      "faultlab mutate list --target odometry_mapper.mapper:OdometryMapper.update"])
    ls.set_defaults(func=_list)

    show = sub.add_parser("show", help="show one mutant: its unified diff and its class",
                          description="Print a mutant's record, its screening class (with the reason, and "
                                      "the mutant it duplicates or the duplicates it stands for) and the "
                                      "unified diff of its file (applies with `patch -p1` from the directory "
                                      "holding the package).")
    show.add_argument("mutant_id", metavar="ID", help="mutant id, e.g. ekf_update:arithmetic:3")
    _common(show)
    add_examples(show, ["faultlab mutate show motion_model:arithmetic:9"])
    show.set_defaults(func=_show)

    run = sub.add_parser(
        "run", help="run (or resume) a mutation campaign with statistical kills and early stopping",
        description="Run the selected live mutants of the reference FastSLAM and the baseline on the "
                    "experiment's suites, K repetitions per case with common random numbers. A suite kills a "
                    "mutant when the exact paired sign-flip test rejects on one of its cases at alpha / "
                    "n_cases (Bonferroni, valid under early stopping) or the mutant alone crashes or times "
                    "out; cases run in rounds and a killed mutant skips the suite's remaining cases. "
                    "Rerunning the same command resumes.")
    run.add_argument("experiment", help="mutation experiment file (an experiment with a [mutation] table) or "
                                        "a shipped name (mutation)")
    run.add_argument("--out", default=None, help="output directory (default: results/<experiment name>)")
    run.add_argument("--jobs", type=positive_int, default=2, help="worker processes (default: 2)")
    run.add_argument("--mutants", default=None, metavar="SELECTOR",
                     help="replace the file's selection: 'all' or comma-separated unit=U, operator=O, "
                          "sample=N and mutant ids (with a target: operator=O and sample=N)")
    run.add_argument("--repetitions", type=positive_int, default=None, metavar="K",
                     help="repetitions per case (default: the file's)")
    run.add_argument("--target", default=None, metavar="TARGET",
                     help="mutate user code instead of faultlab's units: package.module, package.module:function "
                          "(Class.method) or path/file.py[:10-40,55-60] (replaces [mutation].target)")
    run.add_argument("--slam", default=None, metavar="FACTORY",
                     help="the SLAM factory, package.module:factory, that runs the target (replaces [slam].name)")
    run.add_argument("--reuse", default=None, metavar="DIR",
                     help="incremental rerun: reuse the verdicts of mutants whose function is unchanged from the "
                          "campaign in DIR (replaces [mutation].reuse)")
    add_execution_options(run)
    add_examples(run, ["nice -n 10 faultlab mutate run mutation --out results/mutation",
                       "faultlab mutate run mutation --mutants unit=motion_model,sample=5 --repetitions 6 --out results/m5"])
    run.set_defaults(func=_run)

    rep = sub.add_parser("report", help="mutation scores, suite comparison and mutant x suite matrix of a campaign",
                         description="Read a mutation campaign's results (runs nothing) and write outcomes.csv, "
                                     "scores.csv/.md, mcnemar.csv/.md and mutation.pdf.")
    rep.add_argument("results", help="output directory of `faultlab mutate run`")
    rep.add_argument("--reports", default=None, help="where to write (default: RESULTS/report)")
    rep.add_argument("--html", action="store_true",
                     help="also write the HTML report to REPORTS/html (a page per mutant with its diff, status and "
                          "cases; sortable, filterable tables; opens offline)")
    add_examples(rep, ["faultlab mutate report results/mutation --html",
                       "faultlab mutate report results/mutation --reports reports/mutation"])
    rep.set_defaults(func=_report)


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--slam", default="fastslam", metavar="NAME",
                   help="SLAM whose units are mutated: a built-in name or package.module:factory "
                        "(default: fastslam, the reference FastSLAM 1.0)")
    p.add_argument("--no-cache", action="store_true",
                   help="screen afresh instead of reading the cached screening results")


def _list(args: argparse.Namespace) -> int:
    # imported when the command runs: libcst and the scenario generator take a second to import
    from faultlab.mutation import list_mutants

    if args.target is not None:
        from faultlab.mutation.target import list_source_mutants

        print(list_source_mutants(args.target, operator=args.operator))
        return 0
    print(list_mutants(args.slam, unit=args.unit, operator=args.operator, all_mutants=args.all_mutants,
                       cache=not args.no_cache))
    return 0


def _show(args: argparse.Namespace) -> int:
    from faultlab.mutation import show_mutant

    print(show_mutant(args.mutant_id, args.slam, cache=not args.no_cache))
    return 0


def _run(args: argparse.Namespace) -> int:
    from faultlab.campaigns.mutation import load_mutation_experiment, run_mutation

    mexp = load_mutation_experiment(args.experiment, mutants=args.mutants, repetitions=args.repetitions,
                                    target=args.target, slam=args.slam, reuse=args.reuse, jobs=args.jobs)
    out = Path(args.out) if args.out else Path("results") / Path(args.experiment).stem
    print(run_mutation(mexp, out, jobs=args.jobs, backend=args.backend, force_new=args.force_new,
                       progress=not args.no_progress))
    return 0


def _report(args: argparse.Namespace) -> int:
    from faultlab.report.mutation import write_mutation_report

    reports = args.reports if args.reports is not None else Path(args.results) / "report"
    print_paths(write_mutation_report(args.results, reports))
    if args.html:
        from faultlab.analysis.mutation import MutationAnalysis
        from faultlab.report.html.mutation import write_mutation_html

        print(write_mutation_html(MutationAnalysis.load(reports), args.results, Path(reports) / "html"))
    return 0
