"""``python -m faultlab effects design|run|report``: designed effect studies; ``effects RESULTS``: logistic view."""

from __future__ import annotations

import argparse
from pathlib import Path

from faultlab.cli.options import add_examples, add_execution_options, epilog, positive_int, print_paths

__all__ = ["register", "VERBS", "verb_parsers"]

#: The study's verbs; any other first argument is a results directory (the logistic regression).
VERBS: tuple[str, ...] = ("design", "run", "report")

_DESCRIPTION = """Per-parameter effect studies.

  faultlab effects design FILE [--quick] [--out DIR]   the designs' sizes and SLAM executions (writes
                                                         DIR/morris_design.csv with --out)
  faultlab effects run FILE [--quick] [--out DIR]      run (or resume) the Morris screening and the
                                                         Sobol stage through the runner
  faultlab effects report DIR [--reports DIR]          indices, figures and tables of a finished study
  faultlab effects RESULTS [--parameters A,B]          logistic regression of detection on the
                                                         parameters of a finished campaign

FILE is an effects file or a shipped name (default: effects); `faultlab effects VERB --help` describes
each verb."""


def register(subparsers) -> None:
    p = subparsers.add_parser("effects", help="per-parameter effect studies (Morris, Sobol) or the logistic view "
                                              "of a campaign",
                              description=_DESCRIPTION,
                              usage="%(prog)s {design,run,report} ... | %(prog)s RESULTS [--parameters A,B,...]",
                              **(epilog(["faultlab effects design effects --quick",
                                         "faultlab effects run effects --quick --out results/effects-quick",
                                         "faultlab effects report results/effects-quick"])
                                 | {"formatter_class": argparse.RawDescriptionHelpFormatter}))  # the verb table
    p.add_argument("--parameters", default=None, metavar="A,B,...",
                   help="with RESULTS: comma-separated predictors (default: every scenario parameter)")
    p.add_argument("argv", nargs=argparse.REMAINDER, metavar="VERB|RESULTS ...")
    p.set_defaults(func=_dispatch, effects_parser=p, verb_parsers=verb_parsers)


def verb_parsers(parent: str = "faultlab effects") -> dict[str, argparse.ArgumentParser]:
    """The parser of each verb (its own, since ``effects RESULTS`` shares the command): for the docs."""
    return {verb: _verb_parser(verb, parent) for verb in VERBS}


def _verb_parser(verb: str, parent: str = "faultlab effects") -> argparse.ArgumentParser:
    prog = f"{parent} {verb}"
    if verb == "report":
        v = argparse.ArgumentParser(prog=prog, description="Read an effects study (runs nothing) and write "
                                    "morris.csv, sobol.csv, regression.csv, cases.csv, partial.csv, effects.md, "
                                    "morris.png, sobol.png and partial.png.")
        v.add_argument("results", help="output directory of `faultlab effects run`")
        v.add_argument("--reports", default=None, help="where to write (default: RESULTS/report)")
        v.add_argument("--html", action="store_true",
                       help="also write the HTML report of the files written to REPORTS/html (tables sortable and "
                            "filterable, figures with their data; opens offline)")
        return add_examples(v, ["faultlab effects report results/effects-quick --html",
                                "faultlab effects report results/effects-quick --reports reports/effects"])
    v = argparse.ArgumentParser(prog=prog, description=(
        "Print the designs' sizes and the SLAM executions they cost." if verb == "design" else
        "Run the Morris design, screen, then the Sobol design over the kept parameters, each an ordinary "
        "resumable store under --out. Rerunning the same command resumes."))
    v.add_argument("experiment", nargs="?", default="effects", help="effects file or a shipped name (default: effects)")
    v.add_argument("--quick", action="store_true", help="the file's [effects.quick] scale")
    v.add_argument("--out", default=None, help="output directory (default: results/<name>[-quick])"
                   + ("; design writes morris_design.csv there" if verb == "design" else ""))
    if verb == "run":
        v.add_argument("--jobs", type=positive_int, default=2, help="worker processes (default: 2)")
        v.add_argument("--batch-size", type=positive_int, default=None,
                       help="at most this many repetitions of a case per batched SLAM (default: all)")
        add_execution_options(v)
        return add_examples(v, ["faultlab effects run effects --quick --out results/effects-quick",
                                "nice -n 10 faultlab effects run effects --out results/effects --jobs 2"])
    return add_examples(v, ["faultlab effects design effects --quick",
                            "faultlab effects design effects --quick --out results/effects-design"])


def _dispatch(args: argparse.Namespace) -> int:
    argv = list(args.argv)
    if not argv:
        args.effects_parser.print_help()
        return 2
    if argv[0] not in VERBS:
        if args.parameters is None and "--parameters" in argv:
            i = argv.index("--parameters")
            if i + 1 >= len(argv):
                args.effects_parser.error("--parameters needs a value")
            args.parameters = argv[i + 1]
            del argv[i:i + 2]
        if len(argv) != 1:
            args.effects_parser.error(f"unrecognised arguments: {' '.join(argv[1:])}")
        return _logistic(argv[0], args.parameters)
    verb, rest = argv[0], argv[1:]
    vargs = _verb_parser(verb, args.effects_parser.prog).parse_args(rest)
    return {"design": _design, "run": _run, "report": _report}[verb](vargs)


def _out(args) -> Path:
    return Path(args.out) if args.out else Path("results") / (Path(args.experiment).stem
                                                             + ("-quick" if args.quick else ""))


def _design(args: argparse.Namespace) -> int:
    from faultlab.campaigns.effects import effects_plan, load_effects_experiment, stage_design

    eexp = load_effects_experiment(args.experiment, quick=args.quick)
    plan = effects_plan(eexp)
    print(f"Morris: {plan['morris_cases']} cases ({eexp.spec.trajectories} trajectories x ({plan['factors']} "
          f"parameters + 1)), {plan['executions_morris']} SLAM executions ({plan['variants']} variants x K = "
          f"{plan['repetitions']})")
    if eexp.spec.sobol_base:
        print(f"Sobol: at most {plan['sobol_cases_max']} cases (N = {eexp.spec.sobol_base} x ({plan['kept_max']} kept "
              f"+ 2)), at most {plan['executions_sobol_max']} SLAM executions")
    print(f"total: at most {plan['executions_morris'] + plan['executions_sobol_max']} SLAM executions of "
          f"{eexp.experiment.n_steps} steps")
    if args.out:
        design = stage_design(eexp, "morris")
        out = Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        import pandas as pd

        frame = pd.DataFrame(design.unit, columns=[f"u:{f}" for f in design.factors])
        frame.insert(0, "case", range(1, design.n_points + 1))
        values = pd.DataFrame([c.values for c in design.cases])
        path = out / "morris_design.csv"
        pd.concat([frame, values], axis=1).to_csv(path, index=False)
        print(path)
    return 0


def _run(args: argparse.Namespace) -> int:
    from faultlab.campaigns.effects import load_effects_experiment, run_effects

    eexp = load_effects_experiment(args.experiment, quick=args.quick)
    out = _out(args)
    summaries = run_effects(eexp, out, jobs=args.jobs, backend=args.backend,
                            force_new=args.force_new, progress=not args.no_progress, batch_size=args.batch_size)
    for stage, s in summaries.items():
        print(f"{stage}: {s}")
    print(f"results: {out}")
    return 0


def _report(args: argparse.Namespace) -> int:
    from faultlab.report.effects import write_effects_report

    reports = args.reports if args.reports is not None else Path(args.results) / "report"
    files = write_effects_report(args.results, reports)
    print_paths(files)
    if args.html:
        from faultlab.report.html.bundle import write_files_html

        print(write_files_html(files, Path(reports) / "html", title="faultlab effect study"))
    return 0


def _logistic(results: str, parameters: str | None) -> int:
    from faultlab import analysis, stats

    params = None if parameters is None else [p.strip() for p in parameters.split(",") if p.strip()]
    result = analysis.analyse(results, paper=False, parameters=params)
    print(f"Detection (stored with the campaign): {result.rule.describe()}")
    print(stats.format_effects(result.parameter_effects), end="")
    for note in result.notes_on("parameter_effects"):
        print(f"note: {note}")
    return 0
