"""Rendering a ``faultlab check``: a Markdown summary, JSON and JUnit XML (one testcase per case x oracle)."""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from pathlib import Path

from junitparser import Failure, JUnitXml, Skipped, TestCase, TestSuite

from faultlab.analysis.check import CheckSummary

__all__ = ["check_markdown", "write_check_reports"]


def _size(s: Mapping) -> str:
    return f"{s['steps']} steps, {s['landmarks']} landmarks"


def check_markdown(summary: CheckSummary, spec: Mapping) -> str:
    """The Markdown summary (fit for a CI job's summary or a pull-request comment)."""
    kind = {True: "deterministic (judged exactly, one run per case)", False:
            f"stochastic ({summary.repetitions} repetitions per case, one-sided sign tests)",
            None: "deterministic on some cases, stochastic on others"}[summary.deterministic]
    lines = [f"# faultlab check: {'FAIL' if summary.failed else 'pass'}", "",
             f"SLAM `{summary.slam}`, {kind}; suite `{spec['suite']}` (seed {spec['seed']}), {summary.n_cases} cases "
             f"of {spec['n_steps']} active steps; level alpha = {summary.alpha:g} per case, shared among the "
             f"oracles' tests (Bonferroni); reference SLAM `{spec['reference'] or 'none'}`.", "",
             "| oracle | pass | fail | not judged |", "|---|---:|---:|---:|"]
    for oracle, c in summary.counts.items():
        lines.append(f"| {oracle} | {c['pass']} | {c['fail']} | {c['skip']} |")
    lines += ["", f"Executions per case: {summary.executions_per_case:.1f} (mean).", ""]
    if summary.failures:
        lines += ["## Failures", "", "| case | oracle | what |", "|---|---|---|"]
        lines += [f"| {c} | {o} | {m.replace('|', '/')} |" for c, o, m in summary.failures]
        lines.append("")
    if summary.reductions:
        lines += ["## Minimal failing scenarios", "",
                  "| case | oracle | original | minimal | confirmed | reduction tests |", "|---|---|---|---|---|---:|"]
        lines += [f"| {c} | {o} | {_size(a)} | {_size(b)} | {'yes' if ok else 'no'} | {n} |"
                  for c, o, a, b, ok, n in summary.reductions]
        lines += ["", "Each is in `reproducers/<case>-<oracle>/`: the case file, `replay.txt` and a pytest file."]
    options = spec["options"]
    lines += ["", "Margins: floor `(1 + {floor_ratio:g}) x dead reckoning + {floor_margin_mm:g} mm`; differential "
              "`(1 + {differential_ratio:g}) x reference + {differential_margin_mm:g} mm`; exact metamorphic "
              "relations {rel} within {metamorphic_atol:g} m for a deterministic SLAM.".format(
                  rel=", ".join(options["relations"]), **{k: v for k, v in options.items() if k != "relations"})]
    budgets = [f"{options['budget_mm']:g} mm per case" if options.get("budget_mm") else ""]
    budgets += [f"{mm:g} mm in {cls}" for cls, mm in dict(options.get("budget_classes") or {}).items()]
    budgets += [f"{options['budget_step_ms']:g} ms per step" if options.get("budget_step_ms") else ""]
    if any(budgets):
        lines += ["", "Budgets declared: " + "; ".join(b for b in budgets if b) + " (the most lenient of a case's "
                  "classes applies)."]
    return "\n".join(lines) + "\n"


def _junit(records: Sequence, spec: Mapping) -> JUnitXml:
    suite = TestSuite(f"faultlab check {spec['slam'] or ' '.join(spec['command'])}")
    for rec in records:
        for r in rec.results:
            case = TestCase(f"{rec.case_id} {r['oracle']}", classname=f"faultlab.check.{r['oracle']}")
            if r["status"] == "fail":
                case.result = [Failure(r["message"])]
            elif r["status"] == "skip":
                case.result = [Skipped(r["message"])]
            suite.add_testcase(case)
    xml = JUnitXml()
    xml.add_testsuite(suite)
    return xml


def write_check_reports(summary: CheckSummary, records: Sequence, spec: Mapping, reports: str | Path) -> list[Path]:
    """Write ``check.md``, ``check.json`` and ``check-junit.xml`` into ``reports``; their paths."""
    reports = Path(reports)
    reports.mkdir(parents=True, exist_ok=True)
    md = reports / "check.md"
    md.write_text(check_markdown(summary, spec))
    js = reports / "check.json"
    js.write_text(json.dumps({"spec": spec, "failed": summary.failed, "counts": summary.counts,
                              "executions_per_case": summary.executions_per_case,
                              "cases": [{"case": r.case_id, "values": r.values, "steps": r.n_steps,
                                         "landmarks": r.n_landmarks, "deterministic": r.deterministic,
                                         "executions": r.executions, "results": list(r.results),
                                         "reduction": r.reduction} for r in records]}, indent=1, default=str))
    xml = reports / "check-junit.xml"
    _junit(records, spec).write(str(xml))
    return [md, js, xml]
