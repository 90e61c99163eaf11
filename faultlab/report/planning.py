"""A study's power plan as Markdown (``faultlab study plan``): the scale it needs, its cost, what fits."""

from __future__ import annotations

import math

from faultlab.analysis.planning import ConfirmationPlan, ExecutionCost
from faultlab.inference.planning import StudyPlan, StudyScale

__all__ = ["PLAN_FILE", "plan_markdown", "confirmation_markdown"]

#: File name of a rendered plan.
PLAN_FILE = "plan.md"


def _pp(x: float) -> str:
    if math.isnan(x):
        return "-"
    return "none detectable" if math.isinf(x) else f"{x:.1f} pp"


def _scale_cells(plan: StudyPlan, scale: StudyScale) -> list[tuple[str, str]]:
    what = "pool cases per strategy" if plan.kind == "strategies" else "cases per suite"
    cells = [(what, f"{scale.cases}"), ("largest suite judged", f"{scale.largest_suite}"),
             ("mutants", f"{scale.mutants}"), ("repetitions K", f"{scale.repetitions}")]
    if plan.kind == "strategies":
        cells.append(("detectable single-case detection difference", _pp(scale.detection_pp)))
    cells += [("detectable mutation-score difference", _pp(scale.score_pp)),
              ("SLAM executions", f"{scale.executions:,}"), ("CPU hours", f"{scale.cpu_hours:,.1f}"),
              (f"wall hours on {plan.cores} cores", f"{scale.cpu_hours / plan.cores:,.1f}")]
    return cells


def _scale_rows(plan: StudyPlan, *scales: StudyScale) -> list[str]:
    """One Markdown row per figure, one column per scale."""
    columns = [_scale_cells(plan, s) for s in scales]
    return [f"| {label} | " + " | ".join(col[i][1] for col in columns) + " |"
            for i, (label, _) in enumerate(columns[0])]


def plan_markdown(plan: StudyPlan, *, study: str, cost: ExecutionCost | None, cost_source: str,
                  settings: str, same_settings: bool = True, file_scale: StudyScale | None = None,
                  pools: str = "") -> str:
    """The plan of ``study`` (its name), with the cost's provenance and the study's SLAM ``settings``
    (``same_settings``: whether they are those the cost was measured at); ``cost`` None: the plan's
    seconds per execution are an assumption.  ``file_scale``: the scale the study file itself sets
    (:func:`faultlab.inference.planning.file_scale`; ``pools`` lists its pools), shown first."""
    a = plan.comparison_alpha
    side = "two-sided" if plan.sides == 2 else "one-sided"
    lines = [f"# Power plan: {study} ({plan.kind} study)", "",
             f"Targets: {plan.target_detection_pp:.0f} pp in single-case detection probability"
             if plan.kind == "strategies" else "Targets:",
             f"{'and ' if plan.kind == 'strategies' else ''}{plan.target_score_pp:.0f} pp in mutation score between "
             f"two strategies, power {plan.power:.0%}.", "",
             "## Tests and family", "",
             f"- {plan.strategies} strategies, {plan.comparisons} pairs; Holm over the pairs at alpha = "
             f"{plan.alpha}: planned at Holm's first step, alpha / {plan.comparisons} = {a:.4g}."]
    if plan.kind == "strategies":
        lines.append(f"- Detection probability: two-sided arcsine two-proportion test (statsmodels NormalIndPower) "
                     f"on the pool cases, difference centred on {plan.centre:.2f}.")
    lines += [f"- Mutation score: exact McNemar test over the mutants, discordance against the effect "
              f"(mutants killed only by the weaker strategy) assumed {plan.reverse:.0%}.",
              (f"- Repetitions: the SLAM is deterministic, so each case runs once and is judged exactly (any change "
               f"of its map error, or the mutant alone failing, kills): K = 1, no test over identical repetitions."
               if plan.exact else
               f"- Repetitions: a case of a family of {plan.case_family} cases is judged at alpha / "
               f"{plan.case_family}; the {side} exact sign-flip test reaches it from K = {plan.needed.repetitions}."),
              "", "## Cost", "",
              (f"- {cost.seconds:.2f} s per execution: mean of {cost.jobs} executions in `{cost_source}` "
               f"({cost.slam}, " + (f"{cost.particles} particles, " if cost.particles is not None else "") +
               f"{cost.n_steps} active steps; the machine's load when "
               f"they ran is not recorded, so this is a noisy figure)." if cost is not None else
               f"- {plan.seconds_per_execution:.2f} s per execution: a stated assumption, not measured here."),
              f"- The study's settings: {settings}."
              + ("" if same_settings else " They differ from the cost store's: the cost is that of the store's "
                 "settings, i.e. the plan is for a study run at them.")]
    lines.append("- K is the number of repetitions a case may need; a campaign with adaptive repetitions stops a "
                 "case earlier when its verdict is settled, so the executions are an upper bound.")
    if plan.kind == "mutation":
        lines.append("- Mutation executions are an upper bound: the campaign stops a mutant's suite at its first kill.")
    if file_scale is not None and plan.kind == "mutation":
        lines += ["", "## The file's scale", "",
                  f"The file sets {pools}: every case of every suite runs the baseline and each of them once"
                  + (", judged exactly." if plan.exact else ", K times each.") + " It "
                  + ("detects" if file_scale.score_pp <= plan.target_score_pp else "does **not** detect")
                  + f" a {plan.target_score_pp:.0f} pp score difference between two suites with power "
                  f"{plan.power:.0%} (the needed scale below has {plan.needed.mutants} live mutants).", "",
                  "| | |", "|---|---|", *_scale_rows(plan, file_scale)]
    elif file_scale is not None:
        lines += ["", "## The file's scale", "",
                  f"Pools: {pools}; the detectable difference of two pools of the smallest size is shown (a pair "
                  f"holding a larger pool detects a smaller one). Every pool case runs the baseline, {plan.faults} faults and the "
                  f"mutants, K times each.", "",
                  "| | |", "|---|---|", *_scale_rows(plan, file_scale)]
    lines += ["", "## Scale needed for the targets", "", "| | |", "|---|---|", *_scale_rows(plan, plan.needed), ""]
    budget = plan.budget_hours * plan.cores
    if plan.fits:
        lines.append(f"It fits the budget ({plan.budget_hours:g} h on {plan.cores} cores = {budget:g} CPU hours).")
    else:
        lines += [f"It does **not** fit the budget ({plan.budget_hours:g} h on {plan.cores} cores = {budget:g} CPU "
                  f"hours): in {plan.budget_hours:g} h it needs {plan.cluster_cores} cores (e.g. a dask cluster).", ""]
        if plan.fitting is None:
            lines.append("Not even the smallest scale fits the budget.")
        else:
            lines += ["## Largest scale that fits", "",
                      "Chosen to minimise the larger detectable difference relative to its target.", "",
                      "| | |", "|---|---|", *_scale_rows(plan, plan.fitting)]
    if plan.split is not None:
        halves = plan.split
        lines += ["", "## Split design", "",
                  "The detection target needs pool cases, the score target mutants; crossing them runs every mutant "
                  "on every pool case. The split design runs the needed pools on the baseline and the faults (fault "
                  "half) and the needed mutants on pools of the largest suite judged (mutant half), as two studies "
                  "with the same protocol and seed. Its score power is over mutants, as above; the spread a small "
                  "pool adds to a drawn suite's score is not modelled (the report's bootstrap over cases measures "
                  "it).", "",
                  "| | fault half | mutant half |", "|---|---|---|"]
        lines += _scale_rows(plan, *halves)
        total = sum(h.cpu_hours for h in halves)
        lines += ["", f"Both halves: {sum(h.executions for h in halves):,} executions, {total:,.1f} CPU hours, "
                      f"{total / plan.cores:,.1f} h on {plan.cores} cores: it "
                      + ("fits the budget." if plan.split_fits else
                         f"does **not** fit the budget: in {plan.budget_hours:g} h it needs "
                         f"{max(1, math.ceil(total / plan.budget_hours))} cores.")]
    lines += ["", "## Detectable differences by scale", ""]
    if plan.kind == "strategies":
        pools = plan.detection_by_pool()
        lines += ["| pool cases per strategy | " + " | ".join(str(n) for n, _ in pools) + " |",
                  "|---" * (len(pools) + 1) + "|",
                  "| detection difference | " + " | ".join(_pp(d) for _, d in pools) + " |", ""]
    scores, needed = plan.score_by_mutants(), plan.mutants_by_reverse()
    lines += ["| mutants | " + " | ".join(str(m) for m, _ in scores) + " |", "|---" * (len(scores) + 1) + "|",
              "| score difference | " + " | ".join(_pp(d) for _, d in scores) + " |", "",
              f"Mutants needed for {plan.target_score_pp:.0f} pp by the assumed reverse discordance:", "",
              "| reverse discordance | " + " | ".join(f"{r:.0%}" for r, _ in needed) + " |",
              "|---" * (len(needed) + 1) + "|",
              "| mutants | " + " | ".join(str(m) for _, m in needed) + " |", "",
              "Generated by `faultlab study plan`; see `faultlab.inference.planning` for the method.", ""]
    return "\n".join(lines)


def confirmation_markdown(plan: ConfirmationPlan, *, study: str, seconds_per_execution: float | None) -> str:
    """The plan of a confirmatory study's declared run-level analyses, as Markdown."""
    cost = ""
    if seconds_per_execution is not None:
        total = plan.runs * plan.executions_per_run
        cost = (f" At {seconds_per_execution:g} CPU s per execution, {plan.runs} runs cost {total:,} executions, "
                f"{total * seconds_per_execution / 60:.0f} CPU minutes; {plan.runs_needed} runs would cost "
                f"{plan.runs_needed * plan.executions_per_run * seconds_per_execution / 60:.0f}.")
    lines = [
        f"# Power plan: {study} (confirmatory, planned from a pilot)", "",
        f"Declared: {plan.strategy_a} - {plan.strategy_b}, the single-case detection probability averaged over the "
        f"faults, paired by evaluation run (t test over the runs' differences), level {plan.alpha} with Holm over "
        f"the declared analyses: planned at Holm's first step, {plan.level:g}.", "",
        f"Pilot: `{plan.pilot}`, {plan.pilot_runs} runs: mean difference {100 * plan.effect:+.2f} pp, standard "
        f"deviation of the runs' differences {100 * plan.sd:.2f} pp (effect size {plan.effect / plan.sd:.2f}). "
        f"The plan takes the pilot's estimates as the truth; a pilot's effect that was selected for being notable "
        f"tends to overstate the true one, so the power below is an upper bound in that sense.", "",
        f"- Runs needed for {100 * plan.power:.0f} % power at the pilot's effect: **{plan.runs_needed}** "
        f"({plan.executions_per_run:,} SLAM executions per run).",
        f"- Runs of the study file: **{plan.runs}**; power of the difference test there: "
        f"**{100 * plan.power_at_runs:.0f} %**.",
    ]
    if plan.margin is not None:
        lines.append(f"- Declared equivalence margin ±{100 * plan.margin:g} pp (declared, not derived from the data): "
                     f"power of two one-sided tests at {plan.level:g} to show it at {plan.runs} runs, if the true "
                     f"difference is the pilot's: **{100 * plan.equivalence_power_at_runs:.0f} %**.")
    return "\n".join(lines) + "\n" + (f"\n{cost.strip()}\n" if cost else "")
