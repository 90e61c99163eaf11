"""The HTML report of a mutation campaign (``faultlab mutate report --html``).

Pages: an overview (what ran, the mutation score of each suite with its exact interval, the
suites compared by McNemar's test), the sortable, filterable table of mutants (status per suite),
the table of every (mutant, run, suite) outcome, and a page per mutant: its unified diff against
the unit's source, its status and effect in each suite, and the map errors of the cases that ran
it beside the baseline's on the same repetition.  The numbers come from the campaign's
:class:`~faultlab.analysis.mutation.MutationAnalysis` and its stored rows; the diff is made again
from the SLAM's current source (the mutant ids are stable while the source is).
"""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from faultlab.analysis.mutation import MutationAnalysis
from faultlab.errors import FaultlabError
from faultlab.mutation.outcome import SCREENED_OUT
from faultlab.report.html.site import Code, Links, Page, Site, Table, Text, page_slug, write_site
from faultlab.runner.store import load_metadata, load_results
from faultlab.vocabulary import BASELINE, POWER_TEXT

__all__ = ["mutation_pages", "write_mutation_html", "mutant_page_path", "NAV"]

#: Outcomes of the mutants screened out before the campaign (never run).
SCREENED = tuple(str(o) for o in SCREENED_OUT)

NAV = (("Overview", "index.html"), ("Mutants", "mutants.html"), ("Outcomes", "outcomes.html"))


def mutant_page_path(mutant: str) -> str:
    """The page of one mutant, relative to the site's root."""
    return f"mutants/{page_slug(mutant)}.html"


def write_mutation_html(analysis: MutationAnalysis, results: str | Path, out: str | Path) -> Site:
    """Write the site of the mutation campaign stored in ``results`` into ``out``; returns what was written."""
    pages = mutation_pages(analysis, Path(results))
    return write_site(out, pages, title="faultlab mutation report", nav=NAV)


def _diffs(results: Path, mutants: list[str]) -> tuple[dict[str, str], str]:
    """Unified diff of every mutant that can be made again from the SLAM's source, and a note."""
    from faultlab.mutation.mutant import generate_mutants
    from faultlab.slam.registry import build_slam

    meta = load_metadata(results)
    slam = ((meta.get("experiment") or {}).get("slam") or {}).get("name", "fastslam")
    try:
        made = generate_mutants(build_slam(slam, {}).steps)
    except (FaultlabError, AttributeError, TypeError) as exc:
        return {}, f"the diffs cannot be made again from the SLAM {slam!r} ({exc})"
    diffs = {m.id: m.diff for m in made if m.id in set(mutants)}
    return diffs, f"diffs made again from the current source of the SLAM {slam!r}"


def mutation_pages(analysis: MutationAnalysis, results: Path) -> list[Page]:
    """Every page of a mutation campaign's site (see the module docstring)."""
    from faultlab.report.mutation import score_table

    oc = analysis.outcomes
    ran = oc[~oc["outcome"].isin(SCREENED)]
    meta = analysis.meta
    mutants = list(dict.fromkeys(oc["mutant"]))
    diffs, diff_note = _diffs(results, mutants)
    status = (oc.groupby(["mutant", "suite"])["outcome"].agg(lambda o: "/".join(sorted(set(map(str, o)))))
              .unstack(fill_value=""))
    first = oc.drop_duplicates("mutant").set_index("mutant")
    table = pd.DataFrame({"mutant": mutants, "page": [mutant_page_path(m) for m in mutants],
                          "unit": first.loc[mutants, "unit"].to_numpy(),
                          "operator": first.loc[mutants, "operator"].to_numpy()})
    for suite in status.columns:
        table[suite] = status.reindex(mutants)[suite].fillna("").to_numpy()
    scores = score_table(analysis)
    overview = [
        Text("What ran", (f"{meta.get('n_mutants_run', '?')} mutants run, {meta.get('n_screened', '?')} screened out "
                          f"before the campaign (stillborn, equivalent, duplicate); K = {meta.get('repetitions', '?')} "
                          f"repetitions per case; alpha = {meta.get('alpha', '?')}, direction "
                          f"{meta.get('direction', '?')}.",
                          f"{meta.get('n_jobs', '?')} SLAM executions, {float(meta.get('runtime_s_sum', 0.0)):.0f} s of "
                          f"SLAM time; statuses: {meta.get('status_counts', {})}.")),
        Table("Mutation score per suite", scores.drop(columns="group"), key="scores",
              caption="Killed / judged mutants with the exact (Clopper-Pearson) 95 % interval; equivalent-as-observed "
                      "mutants leave the denominator."),
    ]
    if not analysis.mcnemar.empty:
        overview.append(Table("Suites compared on the same mutants (exact McNemar)", analysis.mcnemar, key="mcnemar"))
    overview.append(Links("Pages", (("All mutants", "mutants.html", "(status per suite, sortable, filterable)"),
                                    ("All outcomes", "outcomes.html", "(one row per mutant, run and suite)"))))
    pages = [Page("index.html", "Mutation analysis", tuple(overview)),
             Page("mutants.html", "Mutants", (Table("Mutants", table, key="mutants", links={"mutant": "page"},
                                                    caption="Status of each mutant per suite (killed, survived, "
                                                            "screened out, ...). Click a mutant for its diff and "
                                                            "cases."),)),
             Page("outcomes.html", "Outcomes",
                  (Table("Outcomes per mutant, run and suite of the mutants that ran",
                         ran.assign(page=[mutant_page_path(m) for m in ran["mutant"]]), key="outcomes",
                         links={"mutant": "page"},
                         caption=f"min_p: the smallest per-case p value; min_mde_mm: the smallest shift of the mean "
                                 f"error the most sensitive case could detect with {POWER_TEXT} power. The "
                                 f"{len(oc) - len(ran)} rows of mutants screened out before the campaign "
                                 f"({', '.join(SCREENED)}) are on the mutants page."),))]
    rows = _paired_rows(results)
    for mutant in mutants:
        pages.append(_mutant_page(mutant, oc[oc["mutant"] == mutant], diffs.get(mutant), diff_note,
                                  rows.get(mutant)))
    return pages


def _paired_rows(results: Path) -> dict[str, pd.DataFrame]:
    """Per mutant id: its jobs beside the baseline's job of the same run, suite, case and repetition."""
    from faultlab.mutation.variants import is_mutant_variant, mutant_id_of

    jobs = load_results(results)
    keys = ["run", "suite", "case", "rep"]
    base = jobs[jobs["variant"] == BASELINE][keys + ["rms_mm", "status"]].rename(
        columns={"rms_mm": "baseline RMS mm", "status": "baseline status"})
    mutated = jobs[jobs["variant"].map(is_mutant_variant)]
    paired = mutated[keys + ["variant", "rms_mm", "status"]].merge(base, on=keys, how="left").rename(
        columns={"rms_mm": "mutant RMS mm", "status": "mutant status"})
    paired["difference mm"] = paired["mutant RMS mm"] - paired["baseline RMS mm"]
    return {mutant_id_of(v): g.drop(columns="variant").sort_values(keys).reset_index(drop=True)
            for v, g in paired.groupby("variant")}


def _mutant_page(mutant: str, outcomes: pd.DataFrame, diff: str | None, diff_note: str,
                 paired: pd.DataFrame | None) -> Page:
    first = outcomes.iloc[0]
    sections = [Text("The mutant", (f"{mutant}: unit {first['unit']}, operator {first['operator']}; "
                                    f"status per suite: " + ", ".join(f"{s} {o}" for s, o in
                                                                     zip(outcomes["suite"], outcomes["outcome"])) + ".",))]
    if diff:
        sections.append(Code("Diff against the unit's source", diff, caption=diff_note + "; applies with patch -p1."))
    else:
        sections.append(Text("Diff", (f"Not shown: {diff_note or 'the mutant is not among those of the SLAM now'}.",)))
    sections.append(Table("Status and effect per run and suite", outcomes.drop(columns=["mutant", "unit", "operator"]),
                          key="mutant-outcomes", interactive=False,
                          caption="outcome: killed, survived (equivalent or inconclusive), screened out or cannot "
                                  "judge; killing_case: the case that killed it; median_diff_mm and ratio: the effect "
                                  "on that case; min_mde_mm: the smallest shift a survivor's cases could detect."))
    if paired is not None and len(paired):
        sections.append(Table("Cases that ran it: map error per repetition beside the baseline", paired,
                              key="mutant-cases", digits=1, interactive=False,
                              caption="One row per (run, suite, case, repetition): the mutant's RMS map error, the "
                                      "baseline's on the same seed, and their difference (mm)."))
    else:
        sections.append(Text("Cases that ran it", ("None: the mutant was screened out before the campaign.",)))
    return Page(mutant_page_path(mutant), f"Mutant {mutant}", tuple(sections))
