"""Rendering a ``faultlab compare``: Markdown for a pull-request comment, JSON, JUnit XML (one testcase per case)."""

from __future__ import annotations

import json
import math
from pathlib import Path

from junitparser import Failure, JUnitXml, Skipped, TestCase, TestSuite

from faultlab.analysis.compare import CaseComparison, CompareResult
from faultlab.inference.equivalence import REGRESSION, Comparison, percent

__all__ = ["compare_markdown", "compare_json", "write_compare_reports"]


def _pct(e: float) -> str:
    return "—" if not math.isfinite(e) else f"{percent(e):+.1f} %"


def _mm(x: float) -> str:
    return "—" if not math.isfinite(x) else f"{x:.1f}"


def _p(p: float) -> str:
    return "—" if not math.isfinite(p) else f"{p:.3g}"


def _interval(c: Comparison | None) -> str:
    if c is None or not (math.isfinite(c.ci_low) and math.isfinite(c.ci_high)):
        return "— (exact)" if c is not None and math.isfinite(c.effect) else "—"
    return f"[{_pct(c.ci_low)}, {_pct(c.ci_high)}]"


def _headline(result: CompareResult) -> str:
    if result.regression:
        return "REGRESSION"
    return {"identical": "identical", "equivalent": f"equivalent within ±{100 * result.delta:g} %",
            "improvement": "improvement", "inconclusive": "no regression shown (inconclusive)"}[result.pooled.verdict]


def compare_markdown(result: CompareResult) -> str:
    """The Markdown summary (fit for a pull-request comment or a CI job summary)."""
    p = result.pooled
    s = result.suite
    lines = [f"# faultlab compare: {_headline(result)}", "",
             f"Candidate `{result.candidate}` against baseline `{result.baseline}` on suite `{s['suite']}` "
             f"(seed {s['seed']}, {len(result.cases)} cases of {s['n_steps']} active steps, up to "
             f"{s['repetitions']} repetitions per case; "
             + ("common random numbers" if result.common_random_numbers else "independent repetition seeds")
             + ").", "",
             "| effect on the map error | interval (1 − 2α) | verdict | p regression | p equivalence | test |",
             "|---:|---|---|---:|---:|---|",
             f"| {_pct(p.effect)} | {_interval(p)} | {p.verdict} | {_p(p.p_regression)} | {_p(p.p_equivalence)} "
             f"| {p.test} |", "",
             f"Declared before the run: equivalence margin δ = ±{100 * result.delta:g} % of the map error (TOST), "
             f"alpha = {result.alpha:g} for each one-sided test; the effect is the candidate's mean log error "
             f"ratio over the cases (repetitions averaged within a case), shown as a relative change.", ""]
    crashes = result.crash_regressions
    if crashes:
        lines += [f"**The candidate fails runs the baseline finished** on {len(crashes)} case(s) "
                  f"(exactly for a deterministic SLAM; otherwise one-sided Fisher exact test at alpha / cases):", ""]
        lines += [f"- `{c.case_id}`: {c.reason}" for c in crashes]
        lines.append("")
    not_judged = [c for c in result.cases if c.comparison is None and not c.crash_regression]
    if not_judged or result.missing:
        lines += ["Not judged: " + ", ".join([f"`{c.case_id}` ({c.reason})" for c in not_judged]
                                             + [f"`{m}` (recorded in one version only)" for m in result.missing]), ""]
    lines += ["<details><summary>Per case (each at level alpha, not adjusted for their number: they show where, "
              "the pooled verdict decides)</summary>", "",
              "| case | baseline mm | candidate mm | effect | interval | verdict | failed runs b / c |",
              "|---|---:|---:|---:|---|---|---|"]
    for c in result.cases:
        comp = c.comparison
        lines.append(f"| {c.case_id} | {_mm(c.baseline_mm)} | {_mm(c.candidate_mm)} | "
                     f"{_pct(comp.effect) if comp is not None else '—'} | {_interval(comp)} | {c.verdict} | "
                     f"{c.baseline_failed} of {c.runs[0]} / {c.candidate_failed} of {c.runs[1]} |")
    lines += ["", "</details>", ""]
    return "\n".join(lines)


def _case_dict(c: CaseComparison) -> dict:
    def num(x):
        return float(x) if isinstance(x, (int, float)) and math.isfinite(x) else None

    return {"case": c.case_id, "values": dict(c.values), "verdict": c.verdict, "baseline_mm": num(c.baseline_mm),
            "candidate_mm": num(c.candidate_mm), "runs": list(c.runs), "failed": [c.baseline_failed, c.candidate_failed],
            "deterministic": list(c.deterministic), "crash_regression": c.crash_regression,
            "crash_p": num(c.crash_p), "reason": c.reason,
            "comparison": c.comparison.to_dict() if c.comparison is not None else None}


def compare_json(result: CompareResult, *, require_equivalence: bool = False) -> dict:
    return {"baseline": result.baseline, "candidate": result.candidate, "suite": dict(result.suite),
            "delta": result.delta, "alpha": result.alpha, "common_random_numbers": result.common_random_numbers,
            "regression": result.regression, "equivalent": result.equivalent,
            "exit_status": result.exit_code(require_equivalence=require_equivalence),
            "pooled": {**result.pooled.to_dict(), "effect_percent": _num(percent(result.pooled.effect)),
                       "ci_percent": [_num(percent(result.pooled.ci_low)), _num(percent(result.pooled.ci_high))]},
            "cases": [_case_dict(c) for c in result.cases], "missing": list(result.missing)}


def _num(x: float):
    return float(x) if math.isfinite(x) else None


def _junit(result: CompareResult) -> JUnitXml:
    suite = TestSuite(f"faultlab compare {result.candidate} vs {result.baseline}")
    pooled = TestCase("pooled over the suite", classname="faultlab.compare")
    if result.pooled.verdict == REGRESSION:
        pooled.result = [Failure(f"regression: effect {_pct(result.pooled.effect)}, interval "
                                 f"{_interval(result.pooled)}; {result.pooled.test}")]
    suite.add_testcase(pooled)
    for c in result.cases:
        case = TestCase(c.case_id, classname="faultlab.compare.case")
        if c.crash_regression:
            case.result = [Failure(c.reason)]
        elif c.comparison is None:
            case.result = [Skipped(c.reason)]
        elif c.verdict == REGRESSION:
            # a per-case regression is reported, not gated (it is not adjusted for the number of cases)
            case.system_out = (f"regression on this case: effect {_pct(c.comparison.effect)}, interval "
                               f"{_interval(c.comparison)}; {c.comparison.test}")
        suite.add_testcase(case)
    xml = JUnitXml()
    xml.add_testsuite(suite)
    return xml


def write_compare_reports(result: CompareResult, reports: str | Path, *, require_equivalence: bool = False
                          ) -> list[Path]:
    """Write ``compare.md``, ``compare.json`` and ``compare-junit.xml`` into ``reports``; their paths."""
    reports = Path(reports)
    reports.mkdir(parents=True, exist_ok=True)
    md, js, xml = reports / "compare.md", reports / "compare.json", reports / "compare-junit.xml"
    md.write_text(compare_markdown(result))
    js.write_text(json.dumps(compare_json(result, require_equivalence=require_equivalence), indent=1))
    _junit(result).write(str(xml))
    return [md, js, xml]
