"""The HTML report of a ``faultlab check``: the verdict per oracle, every (case, oracle) result in one
sortable, filterable table, and each minimal failing scenario with its replay command and reproducer."""

from __future__ import annotations

import os
from collections.abc import Mapping, Sequence
from pathlib import Path

import pandas as pd

from faultlab.analysis.check import CheckSummary
from faultlab.report.check import check_markdown
from faultlab.report.html.site import Code, Links, Page, Site, Table, Text, write_site

__all__ = ["check_pages", "write_check_html"]


def _results_frame(records: Sequence) -> pd.DataFrame:
    """One row per (case, oracle): the case's size and parameters, the oracle's status and message."""
    rows = [dict(case=rec.case_id, oracle=r["oracle"], status=r["status"], message=r["message"],
                 steps=rec.n_steps, landmarks=rec.n_landmarks,
                 judged="exactly" if rec.deterministic else "statistically", executions=rec.executions,
                 **{str(k): str(v) for k, v in rec.values.items()})
            for rec in records for r in rec.results]
    return pd.DataFrame(rows, columns=None if rows else ["case", "oracle", "status", "message"])


def check_pages(summary: CheckSummary, records: Sequence, spec: Mapping, out: Path) -> list[Page]:
    """The overview (verdict, counts per oracle, minimal failing scenarios) and the table of results."""
    counts = pd.DataFrame([dict(oracle=o, passed=c["pass"], failed=c["fail"], not_judged=c["skip"])
                           for o, c in summary.counts.items()])
    verdict = (f"FAIL: {len(summary.failures)} (case, oracle) results failed on "
               f"{len({c for c, _, _ in summary.failures})} of {summary.n_cases} cases."
               if summary.failed else f"pass: no oracle failed on any of the {summary.n_cases} cases.")
    sections = [Text("Verdict", (verdict,)),
                Table("Results per oracle", counts, key="oracles", interactive=False,
                      caption="Cases each oracle passed, failed or could not judge (its reason is in the results)."),
                Links("Pages", (("All results", "results.html", "(one row per case and oracle; sortable, filterable)"),))]
    reproducers = []
    for rec in records:
        for oracle, red in (rec.reduction or {}).items():
            target = Path(os.path.relpath(Path(red["directory"]).resolve(), out.resolve())).as_posix()
            reproducers.append((f"{rec.case_id} / {oracle}", target,
                                f"{red['original']['steps']} steps, {red['original']['landmarks']} landmarks -> "
                                f"{red['minimal']['steps']} steps, {red['minimal']['landmarks']} landmarks"
                                f"{'' if red['confirmed'] else ' (not confirmed on fresh seeds)'}; "
                                f"replay: {red['replay']}"))
    if reproducers:
        sections.append(Links(f"Minimal failing scenarios ({len(reproducers)})", tuple(reproducers),
                              caption="Each folder holds the minimal case file, replay.txt and a generated pytest file "
                                      "that fails on this SLAM and passes once the bug is fixed."))
    sections.append(Code("The summary, as written to check.md", check_markdown(summary, spec)))
    results = _results_frame(records)
    table = Table("Every (case, oracle) result", results, key="results",
                  caption="status: pass, fail or skip (not judged, with the reason); judged exactly for a "
                          "deterministic SLAM, statistically over the repetitions otherwise; the remaining columns "
                          "are the case's Table I classes.")
    return [Page("index.html", "Overview", tuple(sections)), Page("results.html", "Results", (table,))]


def write_check_html(summary: CheckSummary, records: Sequence, spec: Mapping, out: str | Path) -> Site:
    """Write the check's site into ``out`` (created)."""
    out = Path(out)
    slam = spec.get("slam") or " ".join(spec.get("command", ()))
    return write_site(out, check_pages(summary, records, spec, out), title=f"faultlab check: {slam}",
                      nav=(("Overview", "index.html"), ("Results", "results.html")))
