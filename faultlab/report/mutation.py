"""Report of a mutation campaign: score and comparison tables (CSV, Markdown), a mutant x suite
matrix figure and a PDF, rendered from one :class:`~faultlab.analysis.mutation.MutationAnalysis`."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure
from matplotlib.patches import Patch

from faultlab.analysis.mutation import MutationAnalysis, analyse_mutation
from faultlab.report.stryker import stryker_report
from faultlab.runner.store import MUTANTS_FILE
from faultlab.report.figures import PAGE_SIZE
from faultlab.report.pdf import table_pages, text_pages, write_pdf
from faultlab.stats.verdict import EQUIVALENCE_MARGIN_REL
from faultlab.vocabulary import PAPER_DIRECTION, POWER_TEXT, SUITE_ORDER, ordered

__all__ = ["STRYKER_FILE", "MATRIX_CLASSES", "markdown_table", "score_table", "matrix_figure", "write_mutation_report"]

#: The campaign on user code in the mutation-testing-report-schema (:mod:`faultlab.report.stryker`).
STRYKER_FILE = "mutation-report.json"
#: Outcome classes of the matrix, in legend order, with their colours.
MATRIX_CLASSES = {"killed": "#2b8cbe", "crash": "#e34a33", "timeout": "#fdbb84", "survived": "#f0f0f0",
                  "cannot_judge": "#bdbdbd", "incomplete": "#ffffb2", "equivalent_observed": "#a1d99b"}


def markdown_table(frame: pd.DataFrame) -> str:
    """A GitHub Markdown table of ``frame`` (cells as strings)."""
    cols = [str(c) for c in frame.columns]
    lines = ["| " + " | ".join(cols) + " |", "|" + "|".join("---" for _ in cols) + "|"]
    for row in frame.astype(str).itertuples(index=False):
        lines.append("| " + " | ".join(row) + " |")
    return "\n".join(lines) + "\n"


def score_table(analysis: MutationAnalysis, by: str = "all") -> pd.DataFrame:
    """Scores as display strings: ``killed/judged``, score % and the 95 % Clopper-Pearson interval."""
    s = analysis.scores[analysis.scores["by"] == by]
    return pd.DataFrame({
        "suite": s["suite"], "group": s["group"],
        "killed / judged": [f"{k}/{n}" for k, n in zip(s["killed"], s["judged"])],
        "crash / timeout": [f"{c}/{t}" for c, t in zip(s["crash"], s["timeout"])],
        "incomplete": s["incomplete"],
        "survived: equivalent / inconclusive": [f"{e}/{i}" for e, i in zip(s["survived_equivalent"],
                                                                          s["survived_inconclusive"])],
        "equivalent (observed, not scored)": s["equivalent_observed"],
        "score": [f"{100 * v:.1f} %" for v in s["score"]],
        "95 % CI": [f"{100 * lo:.1f}-{100 * hi:.1f} %" for lo, hi in zip(s["ci_low"], s["ci_high"])],
    })


def _mcnemar_table(analysis: MutationAnalysis) -> pd.DataFrame:
    m = analysis.mcnemar
    return pd.DataFrame({"suites": [f"{a} vs {b}" for a, b in zip(m["suite_a"], m["suite_b"])], "pairs": m["n"],
                         "both": m["both"], "only first": m["a_only"], "only second": m["b_only"],
                         "neither": m["neither"], "p (exact)": [f"{p:.3g}" for p in m["p"]],
                         "p (Holm)": [f"{p:.3g}" for p in m["p_holm"]],
                         "score difference (95 % CI)": [f"{100 * d:+.1f} ({100 * lo:+.1f} to {100 * hi:+.1f}) pp"
                                                        for d, lo, hi in zip(m["diff"], m["ci_low"], m["ci_high"])],
                         "equivalent within (TOST)": [f"+-{100 * e:.1f} pp" for e in m["equivalent_within"]]})


def matrix_figure(analysis: MutationAnalysis, *, figsize=PAGE_SIZE) -> Figure:
    """Mutants (rows, grouped by unit) x suites (columns), coloured by outcome; run mutants only."""
    o = analysis.outcomes[analysis.outcomes["outcome"].isin(MATRIX_CLASSES)]
    suites = ordered(list(dict.fromkeys(o["suite"])), SUITE_ORDER)
    o = o.assign(col=o["suite"] + np.where(o["run"].nunique() > 1, " r" + o["run"].astype(str), ""))
    cols = [c for s in suites for c in sorted(set(o.loc[o["suite"] == s, "col"]))]
    mutants = o.sort_values(["unit", "mutant"])["mutant"].drop_duplicates().tolist()
    codes = {c: i for i, c in enumerate(MATRIX_CLASSES)}
    grid = np.full((len(mutants), len(cols)), np.nan)
    ri = {m: i for i, m in enumerate(mutants)}
    ci = {c: j for j, c in enumerate(cols)}
    for m, c, out in zip(o["mutant"], o["col"], o["outcome"]):
        grid[ri[m], ci[c]] = codes[out]
    fig = Figure(figsize=figsize)
    ax = fig.add_axes([0.32, 0.06, 0.5, 0.88])
    ax.imshow(grid, aspect="auto", interpolation="nearest", cmap=ListedColormap(list(MATRIX_CLASSES.values())),
              vmin=-0.5, vmax=len(MATRIX_CLASSES) - 0.5)
    ax.set_xticks(range(len(cols)), cols)
    units = o.drop_duplicates("mutant").set_index("mutant").loc[mutants, "unit"].tolist()
    starts = [i for i, u in enumerate(units) if i == 0 or units[i - 1] != u]
    ax.set_yticks([s for s in starts], [units[s] for s in starts], fontsize=6)
    for s in starts[1:]:
        ax.axhline(s - 0.5, color="k", lw=0.4)
    ax.set_title(f"{len(mutants)} mutants x suites (rows grouped by unit)", fontsize=10)
    ax.legend(handles=[Patch(color=c, label=k) for k, c in MATRIX_CLASSES.items()], loc="upper left",
              bbox_to_anchor=(1.02, 1), fontsize=7)
    return fig


def survivor_table(analysis: MutationAnalysis) -> pd.DataFrame:
    """Each survived (mutant, suite): equivalent within the margin (TOST) or inconclusive, its smallest
    per-case p value, largest TOST p value and detectable shift (at :data:`~faultlab.vocabulary.DEFAULT_POWER`); "not testable" where a
    case had no usable pairs for that test, "none" where no case could detect any shift.

    An inconclusive survivor is not shown equivalent: its suite could only have detected a mean shift
    of the map error of at least ``mde_mm`` on its most sensitive case (:mod:`faultlab.analysis.mutation`).
    """
    rows = analysis.outcomes[analysis.outcomes["outcome"] == "survived"]
    table = rows[["mutant", "unit", "operator", "run", "suite", "survival", "min_p", "max_p_equivalence",
                  "min_mde_mm"]].copy()
    table["min_p"] = table["min_p"].map(lambda v: f"{v:.3g}" if np.isfinite(v) else "not testable")
    table["max_p_equivalence"] = table["max_p_equivalence"].map(lambda v: f"{v:.3g}" if np.isfinite(v)
                                                                else "not testable")
    table["min_mde_mm"] = table["min_mde_mm"].map(lambda v: f"{v:.0f}" if np.isfinite(v) else "none")
    return table.rename(columns={"min_p": "smallest p", "max_p_equivalence": "TOST p (largest)",
                                 "min_mde_mm": "detectable shift mm"}).reset_index(drop=True)


def observed_equivalent_table(analysis: MutationAnalysis) -> pd.DataFrame:
    """The mutants whose maps were bit-identical to the baseline's in every paired run (not scored)."""
    rows = analysis.outcomes[analysis.outcomes["outcome"] == "equivalent_observed"]
    return rows.drop_duplicates("mutant")[["mutant", "unit", "operator"]].reset_index(drop=True)


def _test_text(meta: dict) -> str:
    if meta.get("direction", PAPER_DIRECTION) == PAPER_DIRECTION:
        return ("exact one-sided paired sign-flip test (the paper's notion: the mutant makes the map worse; the "
                "campaign's early stopping used it)")
    return "exact two-sided paired sign-flip test (the mutant changes the map error, worse or better)"


def _adaptive_text(adaptive: dict | None) -> str:
    """The report's sentence on adaptive repetitions ('' for a fixed-K campaign)."""
    if not adaptive:
        return ""
    why = ", ".join(f"{n} {r.replace('_', ' ')}" for r, n in sorted(adaptive["stop_reasons"].items())) or "none"
    fixed = adaptive["executions_fixed_k"]
    share = f" ({100 * adaptive['executions_saved'] / fixed:.1f} %)" if fixed else ""
    return (f" Adaptive repetitions in stages {adaptive['stages']} (interim look at the kill test's per-case level "
            f"and sidedness, futility bound {adaptive['futility']:g}): {adaptive['n_stops']} (case, mutant) pair(s) "
            f"stopped early ({why}) and count as not killed on that case; {adaptive['executions']} executions "
            f"instead of the {fixed} that all K repetitions of the same pairs need, {adaptive['executions_saved']} "
            f"saved{share}. The outcomes table lists the repetitions each case used (reps_used); a survivor's "
            f"detectable shift is computed from them.")


def _effect(rows: pd.DataFrame, kill: str) -> str:
    """A survivor's effect over the cases that ran it."""
    n = int(rows["n_cases_run"].sum())
    if kill == "exact":
        return f"none: map error identical to the original's on all {n} cases (judged exactly)"
    mde = pd.to_numeric(rows["min_mde_mm"], errors="coerce")
    return (f"no difference shown on {n} cases; smallest detectable mean shift {mde.min():.0f} mm ({POWER_TEXT} power)"
            if mde.notna().any() else f"no difference shown on {n} cases")


def _target_markdown(analysis: MutationAnalysis, records: dict, all_scores: pd.DataFrame, counts) -> list[str]:
    meta = analysis.meta
    t = meta["target"]
    o = analysis.outcomes
    cls = t["classes"]
    inf = score_table(analysis, "informative")
    exact = meta.get("kill") == "exact"
    rule = ("A case kills a mutant when its map error differs from the original's at all, or the mutant alone "
            "fails (crash, non-finite map, timeout): the SLAM is deterministic, so each case runs once and is "
            "judged exactly, no test." if exact else
            f"A case kills a mutant when the {_test_text(meta)} over K = {meta['repetitions']} repetitions rejects "
            f"at the per-case level {meta['case_alpha']:.4g} (alpha = {meta['alpha']} over the largest suite), or "
            f"the mutant alone fails.")
    n_screened = int(t.get("n_screened", t["n_mutants"]))
    sampled = (f" A budget of {t['sample']} live mutants was drawn before screening: the {t['n_mutants']} mutants "
               f"were put in a seeded uniform random order and screened along it until {t['n_sampled']} live ones "
               f"were found. They are a uniform sample of the live mutants (about "
               f"{t['n_mutants'] * cls['live'] / n_screened:.0f} of the {t['n_mutants']}, at the live share of the "
               f"{n_screened} screened), so each score estimates the score of all live mutants and its exact "
               f"Clopper-Pearson interval covers the sampled fraction." if n_screened < t["n_mutants"] else
               f" The budget of {t['sample']} live mutants exceeds the {t['n_sampled']} the target has: every mutant "
               f"was screened and every live one ran (no sampling)." if t.get("sample") and t["n_sampled"] < t["sample"]
               else "")
    reused = meta.get("reused") or {}
    md = ["# Mutation analysis of user code", "",
          f"Target `{t['target']}` ({t['path']}, module digest {t['module_digest']}): {t['n_mutants']} mutants "
          f"generated; {'' if n_screened == t['n_mutants'] else f'{n_screened} of them '}screened on probe scenarios "
          f"before the campaign: {cls['live']} live, {cls['invalid']} invalid "
          f"(cannot be imported or built: neither killed nor survived), {cls['equivalent']} equivalent and "
          f"{cls['duplicate']} duplicate (estimates bit-identical to the original's, or to an earlier mutant's, on "
          f"every probe under common random numbers). Functions not mutated: "
          + (", ".join(f"{k} ({v})" for k, v in t["skipped_functions"].items()) or "none") + "." + sampled, "",
          f"{rule} A suite kills a mutant when one of its cases does; the kill on a case does not depend on the "
          f"other cases, so adding a case never un-kills a mutant. {meta['n_mutants_run']} mutants ran, "
          f"{meta.get('n_reused', 0)} verdicts reused from an earlier campaign (function unchanged), "
          f"{meta['n_jobs']} SLAM executions.", "",
          "## Mutation score per suite (95 % Clopper-Pearson)", "", markdown_table(all_scores.drop(columns="group")),
          "## Informative score per suite", "",
          f"Leaves out the {meta.get('n_trivial', 0)} mutants that screening declared, before the campaign, "
          f"trivially killed: they fail on every probe, so every case kills them.", "",
          markdown_table(inf.drop(columns="group")) if len(inf) else "No trivial mutant: the same as above.\n",
          "## Outcomes per suite", "", markdown_table(counts),
          "## Suites compared on the same mutants (exact McNemar)", "", markdown_table(_mcnemar_table(analysis))]
    if reused:
        md += ["## Reused verdicts", "", "These mutants did not run: their function is unchanged since the campaign "
               "named, whose verdict they keep.", "",
               markdown_table(pd.DataFrame({"mutant": list(reused), "from": list(reused.values())}))]
    surv = o[o["outcome"] == "survived"]
    md += ["## Survived mutants", ""]
    if not len(surv):
        md.append("None: every live mutant was killed by every suite.\n")
    for mid, g in surv.groupby("mutant", sort=False):
        rec = records["mutants"].get(mid, {})
        suites = ", ".join(f"{s} ({int(n)} cases)" for s, n in zip(g["suite"], g["n_cases_run"]))
        md += [f"### `{mid}`", "", f"{rec.get('function', '')}, line {rec.get('line', '')}: {rec.get('description', '')}",
               "", f"Survived: {suites}. Effect: {_effect(g, meta.get('kill'))}.", "", "```diff",
               rec.get("diff", "").rstrip("\n"), "```", ""]
    return md


def write_mutation_report(results: str | Path, reports: str | Path) -> list[Path]:
    """Analyse the campaign in ``results`` and write tables, Markdown and ``mutation.pdf`` to ``reports``."""
    analysis = analyse_mutation(results)
    out = Path(reports)
    analysis.save(out)
    meta = analysis.meta
    all_scores, ops, units = score_table(analysis), score_table(analysis, "operator"), score_table(analysis, "unit")
    counts = analysis.outcomes.drop_duplicates(["mutant", "run", "suite"]).groupby(["suite", "outcome"]).size()
    counts = counts.unstack(fill_value=0).reset_index()
    survivors = survivor_table(analysis)
    observed = observed_equivalent_table(analysis)
    md = ["# Mutation analysis", "",
          f"{meta['n_mutants_run']} mutants run, {meta['n_screened']} screened out before the campaign "
          f"(stillborn, equivalent, duplicate); K = {meta['repetitions']} repetitions per case; a suite kills a "
          f"mutant when one case's {_test_text(meta)} rejects at alpha / n_cases (alpha = {meta['alpha']}, "
          f"Bonferroni over the suite's cases, valid under early stopping) or the mutant alone crashes or times out. "
          f"A survivor is 'equivalent' when two one-sided tests (TOST, the exact sign-flip test on the differences "
          f"shifted by the margin, {100 * EQUIVALENCE_MARGIN_REL:g} % of the baseline's median error on the case) "
          f"show its effect within the "
          f"margin on every case of the suite at alpha, else 'inconclusive'. A mutant whose maps are bit-identical "
          f"to the baseline's in every paired run is 'equivalent (observed)' and leaves the score's denominator. "
          f"{meta['n_jobs']} SLAM executions, {meta['runtime_s_sum']:.0f} s of SLAM time."
          + _adaptive_text(meta.get("adaptive"))
          + (" The campaign is INCOMPLETE: 'incomplete' mutants were not killed by the cases run so far and count "
             "as not killed, so every score is a lower bound." if (analysis.outcomes["outcome"] == "incomplete").any()
             else ""), "",
          "## Mutation score per suite (95 % Clopper-Pearson)", "", markdown_table(all_scores.drop(columns="group")),
          "## Outcomes per suite", "", markdown_table(counts),
          "## Suites compared on the same mutants (exact McNemar)", "",
          "The score difference is the first suite's minus the second's on the pairs both judged, with a 95 % "
          "interval (the two discordant shares, each within its exact Clopper-Pearson interval at 97.5 %: "
          "conservative); 'equivalent within' is the smallest "
          "margin d for which two one-sided tests at 5 % show the difference inside +-d (the largest magnitude "
          "of the 90 % interval): no difference larger than d, at that level.", "",
          markdown_table(_mcnemar_table(analysis)),
          "## Score per operator", "", markdown_table(ops), "## Score per unit", "", markdown_table(units),
          "## Equivalent as observed (bit-identical maps, not scored)", "",
          markdown_table(observed) if len(observed) else "None.\n",
          "## Survived mutants: equivalent within the margin, or the smallest shift each suite could have detected",
          "",
          "Per survived (mutant, suite): 'equivalent' (TOST on every case) or 'inconclusive', the smallest "
          "per-case p value, the largest TOST p value and the smallest mean shift of the map error (mm) its most "
          f"sensitive case could have detected with {POWER_TEXT} power at the case's level and sidedness: an inconclusive "
          "survivor is a change below that size or one the suite's cases do not exercise, not shown equivalent.",
          "", markdown_table(survivors)]
    paths = [out / f"{n}.csv" for n in ("outcomes", "scores", "mcnemar")]
    if "target" in meta:  # a campaign on user code: its own account, the schema JSON and the survivors' diffs
        records = json.loads((Path(results) / MUTANTS_FILE).read_text())
        md = _target_markdown(analysis, records, all_scores, counts)
        (out / STRYKER_FILE).write_text(json.dumps(stryker_report(analysis.outcomes, records, meta=meta), indent=1))
        paths.append(out / STRYKER_FILE)
    (out / "mutation.md").write_text("\n".join(md))
    paths.append(out / "mutation.md")
    pages = text_pages("Mutation analysis", [md[2]])
    pages += table_pages("Mutation score per suite", all_scores)
    pages += table_pages("Outcomes per suite", counts.astype(str))
    pages += table_pages("Suites compared (exact McNemar)", _mcnemar_table(analysis))
    pages.append(matrix_figure(analysis))
    pages += table_pages("Score per operator", ops)
    pages += table_pages("Score per unit", units)
    if len(observed):
        pages += table_pages("Equivalent as observed (bit-identical maps, not scored)", observed)
    pages += table_pages(f"Survived mutants: equivalent or smallest detectable shift ({POWER_TEXT} power)", survivors)
    write_pdf(out / "mutation.pdf", pages, title="faultlab mutation report")
    paths.append(out / "mutation.pdf")
    return paths
