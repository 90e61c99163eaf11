"""``python -m faultlab study run|report|k-report``: which test-design strategy detects faults with fewer cases."""

from __future__ import annotations

import argparse
from pathlib import Path

from faultlab.cli.options import add_examples, add_execution_options, add_verb_group, positive_int, print_paths
from faultlab.vocabulary import DEFAULT_POWER

__all__ = ["register"]

_HELP = "test-design strategies study: power plan, case pools, kill matrix, suites drawn from the pools"
_DESCRIPTION = ("Run a pool of cases of every strategy once per fault and sampled mutant (K repetitions, common "
                "random numbers), keep every case's exact p value (the kill matrix), then evaluate suites of each "
                "size drawn from the pools at no further SLAM cost.")


def register(subparsers) -> None:
    sub = add_verb_group(subparsers, "study", help=_HELP, description=_DESCRIPTION,
                         examples=["faultlab study plan study --reports reports/study",
                                   "faultlab study run --quick --out results/study-quick",
                                   "faultlab study report results/study-quick"])
    run = sub.add_parser("run", help="run (or resume) a study's case pools",
                         description="Run every pool case against the baseline, the file's faults and its "
                                     "[mutation] sample through the runner. Rerunning the same command resumes.")
    run.add_argument("experiment", nargs="?", default="study",
                     help="study file or a shipped name (default: study)")
    run.add_argument("--quick", action="store_true", help="the file's [study.quick] scale")
    run.add_argument("--out", default=None, help="output directory (default: results/<name>[-quick])")
    run.add_argument("--jobs", type=positive_int, default=2, help="worker processes (default: 2)")
    add_execution_options(run)
    add_examples(run, ["faultlab study run --quick --out results/study-quick",
                       "nice -n 10 faultlab study run study --out results/study"])
    run.set_defaults(func=_run)

    rep = sub.add_parser("report", help="kill matrix, detection probabilities, mutation scores, comparisons",
                         description="Read a study's results (runs nothing) and write kill_matrix.csv, "
                                     "detection.csv, scores.csv, comparisons.csv, power.csv, study.md and "
                                     "detection_vs_size.png.")
    rep.add_argument("results", help="output directory of `faultlab study run`")
    rep.add_argument("--reports", default=None, help="where to write (default: RESULTS/report)")
    rep.add_argument("--html", action="store_true",
                     help="also write the HTML report of the files written to REPORTS/html (tables sortable and "
                          "filterable, figures with their data; opens offline)")
    add_examples(rep, ["faultlab study report results/study --html", "faultlab study report reports/study/store --reports reports/study"])
    rep.set_defaults(func=_report)

    alloc = sub.add_parser("k-report", help="repetitions K against cases n at a fixed budget (one pool, runs nothing)",
                           description="Judge every case of a study's single pool again on its first K "
                                       "repetitions for each K, draw suites of n = budget / K cases and write "
                                       "allocation.csv, allocation_summary.csv, allocation_meta.json and "
                                       "allocation.md.")
    alloc.add_argument("results", help="output directory of `faultlab study run` (one suite kind)")
    alloc.add_argument("--budget", type=positive_int, required=True, help="paired executions K x n per suite")
    alloc.add_argument("--k", type=positive_int, nargs="+", required=True, help="repetitions compared")
    alloc.add_argument("--draws", type=positive_int, default=2000, help="suites drawn per allocation")
    alloc.add_argument("--seed", type=int, default=0, help="seed of the suite draws")
    alloc.add_argument("--reports", default=None, help="where to write (default: RESULTS/k-report)")
    add_examples(alloc, ["faultlab study k-report results/study-k --budget 72 --k 6 9 12 --reports reports/study-k"])
    alloc.set_defaults(func=_k_report)

    plan = sub.add_parser("plan", help="the scale a study needs to detect given differences, its cost, what fits",
                          description="Power before running: the pool cases per strategy, mutants and repetitions "
                                      "K at which the study's own tests (Holm over the strategy pairs) detect the "
                                      "target differences with the given power; the cost in SLAM executions and "
                                      "CPU hours from a store's measured runtimes; and, when that does not fit the "
                                      "budget, the largest scale that does. Runs nothing.")
    plan.add_argument("study", nargs="?", default="study",
                      help="a study file or a shipped name: 'study' (strategies) or 'mutation' (default: study)")
    plan.add_argument("--quick", action="store_true", help="the file's [study.quick] scale (strategies study)")
    plan.add_argument("--target-detection-pp", type=float, default=20.0,
                      help="difference in single-case detection probability to detect, pp (default: 20)")
    plan.add_argument("--target-score-pp", type=float, default=10.0,
                      help="difference in mutation score to detect, pp (default: 10)")
    plan.add_argument("--power", type=float, default=DEFAULT_POWER, help=f"power (default: {DEFAULT_POWER:g})")
    plan.add_argument("--reverse-discordance", type=float, default=0.05,
                      help="assumed share of mutants killed only by the weaker strategy (default: 0.05)")
    plan.add_argument("--budget-hours", type=float, default=3.0, help="wall-time budget, hours (default: 3)")
    plan.add_argument("--cores", type=positive_int, default=2, help="cores of the budget (default: 2)")
    plan.add_argument("--cost-store", default="reports/paper-k10/store",
                      help="store whose mean runtime per execution is the cost (default: reports/paper-k10/store)")
    plan.add_argument("--seconds-per-execution", type=float, default=None,
                      help="assume this cost of one SLAM execution instead of measuring it from --cost-store")
    plan.add_argument("--pilot", default=None,
                      help="a pilot study's saved analysis (kill_matrix.csv): plan the runs the study's declared "
                           "run-level analyses need from the pilot's run-level effect and spread instead")
    plan.add_argument("--reports", default=None, help="also write plan.md into this directory")
    add_examples(plan, ["faultlab study plan study --reports reports/study",
                        "faultlab study plan mutation --reports reports/mutation",
                        "faultlab study plan study-confirm --pilot reports/study-large-faults "
                        "--seconds-per-execution 0.016"])
    plan.set_defaults(func=_plan)


def _run(args: argparse.Namespace) -> int:
    from faultlab.campaigns.study import load_study_experiment, run_study

    sexp = load_study_experiment(args.experiment, quick=args.quick)
    out = Path(args.out) if args.out else Path("results") / (Path(args.experiment).stem
                                                             + ("-quick" if args.quick else ""))
    print(run_study(sexp, out, jobs=args.jobs, backend=args.backend, force_new=args.force_new,
                    progress=not args.no_progress))
    return 0


def _report(args: argparse.Namespace) -> int:
    from faultlab.report.study import write_study_report

    reports = args.reports if args.reports is not None else Path(args.results) / "report"
    files = write_study_report(args.results, reports)
    print_paths(files)
    if args.html:
        from faultlab.report.html.bundle import write_files_html

        print(write_files_html(files, Path(reports) / "html", title="faultlab strategies study"))
    return 0


def _k_report(args: argparse.Namespace) -> int:
    from faultlab.report.allocation import write_allocation_report

    reports = args.reports if args.reports is not None else Path(args.results) / "k-report"
    return print_paths(write_allocation_report(args.results, reports, budget=args.budget, ks=args.k,
                                               draws=args.draws, seed=args.seed))

def _sides(exp) -> int:
    """Sides of the per-case sign-flip test of ``exp``'s detection rule (its declared direction)."""
    from faultlab.inference.exact import alternative_of

    return 2 if alternative_of(exp.detection.direction) == "two-sided" else 1


def _plan(args: argparse.Namespace) -> int:
    from faultlab.analysis.planning import execution_cost
    from faultlab.config import read_toml
    from faultlab.data import resolve_experiment
    from faultlab.errors import ConfigError
    from faultlab.report.planning import plan_markdown
    from faultlab.mutation.variants import is_mutant_variant
    from faultlab.inference.planning import file_scale, plan_study
    from faultlab.vocabulary import BASELINE

    data, _ = read_toml(resolve_experiment(args.study, what="study file"), what="study file")
    if args.seconds_per_execution is not None and not args.seconds_per_execution > 0:
        raise ConfigError(f"--seconds-per-execution must be positive, got {args.seconds_per_execution}")
    if args.pilot is not None:
        return _confirmation_plan(args)
    cost = execution_cost(args.cost_store) if args.seconds_per_execution is None else None
    seconds = cost.seconds if cost is not None else args.seconds_per_execution
    common = dict(target_detection=args.target_detection_pp / 100, target_score=args.target_score_pp / 100,
                  power=args.power, reverse=args.reverse_discordance, seconds_per_execution=seconds,
                  budget_hours=args.budget_hours, cores=args.cores)
    scale, pools = None, ""
    if args.quick and "study" not in data:
        raise ConfigError(f"{args.study}: --quick plans the quick scale of a strategies study, and this is not one")
    if "study" in data:
        from faultlab.campaigns.study import load_study_experiment

        sexp = load_study_experiment(args.study, quick=args.quick)
        exp = sexp.experiment
        faults = sum(1 for v in exp.variants if v != BASELINE and not is_mutant_variant(v))
        # the largest family of cases judged: the largest drawn size or a whole generated suite
        largest = max([*sexp.study.sizes, *(s.n_cases or 0 for s in exp.suites if s.kind in sexp.study.whole)])
        plan = plan_study("strategies", strategies=len(exp.suites), faults=faults, max_suite=largest,
                          alpha=sexp.study.alpha, sides=_sides(exp), **common)
        sizes = [exp.runs * (s.n_cases or 0) for s in exp.suites]
        scale = file_scale(plan, pools=sizes, mutants=sum(map(is_mutant_variant, exp.variants)),
                           repetitions=exp.repetitions, largest_suite=largest)
        pools = ", ".join(f"{s.kind} {n}" for s, n in zip(exp.suites, sizes))
    else:
        from faultlab.campaigns.mutation import load_mutation_experiment

        from faultlab.campaigns.mutation import KILL_EXACT
        from faultlab.inference.planning import mutation_file_scale

        mexp = load_mutation_experiment(args.study, screen=False)
        exp = mexp.experiment
        plan = plan_study("mutation", strategies=len(exp.suites), suite_cases=max(s.n_cases or 0 for s in exp.suites),
                          runs=exp.runs, alpha=mexp.alpha, sides=_sides(exp), exact=mexp.kill == KILL_EXACT,
                          **common)
        table = data.get("mutation") or {}
        budget = table.get("sample") if "target" in table else None  # a campaign on user code
        if isinstance(budget, int) and not isinstance(budget, bool) and budget >= 1:
            scale = mutation_file_scale(plan, mutants=budget)
            pools = f"a sample budget of {budget} live mutants"
    particles = dict(exp.slam.options).get("particles")
    settings = f"{exp.slam.name}, " + (f"{particles} particles, " if particles is not None else "") + \
        f"{exp.n_steps} active steps"
    text = plan_markdown(plan, study=Path(args.study).stem + (" --quick" if args.quick else ""), cost=cost, cost_source=str(args.cost_store),
                         settings=settings, same_settings=cost is None or (particles, exp.n_steps, exp.slam.name) ==
                         (cost.particles, cost.n_steps, cost.slam), file_scale=scale, pools=pools)
    _print_plan(text, args.reports)
    return 0


def _print_plan(text: str, reports: str | None) -> None:
    """Print a plan, and write it as ``reports``/PLAN_FILE when ``reports`` is given."""
    from faultlab.report.planning import PLAN_FILE

    print(text)
    if reports is not None:
        out = Path(reports)
        out.mkdir(parents=True, exist_ok=True)
        (out / PLAN_FILE).write_text(text)
        print(out / PLAN_FILE)


def _confirmation_plan(args: argparse.Namespace) -> int:
    from faultlab.analysis.planning import confirmation_plan
    from faultlab.campaigns.study import load_study_experiment
    from faultlab.report.planning import confirmation_markdown

    plan = confirmation_plan(load_study_experiment(args.study, quick=args.quick), args.pilot, power=args.power)
    text = confirmation_markdown(plan, study=Path(args.study).stem + (" --quick" if args.quick else ""),
                                 seconds_per_execution=args.seconds_per_execution)
    _print_plan(text, args.reports)
    return 0
