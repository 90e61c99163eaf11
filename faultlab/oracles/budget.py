"""The budget oracle: declared accuracy (mm, optionally per Table I class) and time per step.

Options (``faultlab check --option`` and ``--budget``; 0 or empty: not declared):

* ``budget_mm``: the map error a case may reach, mm;
* ``budget_classes``: ``{"parameter.class": mm}``, a bound for the cases in that equivalence class
  of Table I (``{"map_size.large": 500}``); a case in several declared classes gets the most
  lenient of their bounds (a large map *and* outliers may err as much as either allows), and
  ``budget_mm`` where none is declared;
* ``budget_step_ms``: the wall-clock time per step, ms.

Accuracy is judged as the floor and differential oracles judge theirs: a deterministic SLAM on its one
run, exactly; a stochastic one by the one-sided sign test over its ``K`` repetitions.  Time is a
measurement of the machine as much as of the SLAM: the case fails when the *fastest* of its runs
(the one least disturbed by other load) took longer per step than the budget; no test.  A case with
no budget declared is not judged.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from faultlab.oracles.oracle import FAIL, PASS, SKIP, CaseRuns, Oracle, OracleResult, map_error_mm, sign_test

__all__ = ["BudgetOracle", "BUDGET_OPTIONS", "case_budget_mm"]

#: The budget options and their "not declared" values.
BUDGET_OPTIONS: dict[str, Any] = {"budget_mm": 0.0, "budget_classes": {}, "budget_step_ms": 0.0}


def case_budget_mm(options: Mapping[str, Any], classes: Mapping[str, str]) -> float | None:
    """The accuracy bound of a case in ``classes`` (parameter -> class), mm; None when none is declared."""
    per_class = dict(options.get("budget_classes") or {})
    matching = [float(mm) for key, mm in per_class.items()
                if "." in key and classes.get(key.split(".", 1)[0]) == key.split(".", 1)[1]]
    if matching:
        return max(matching)
    overall = float(options.get("budget_mm") or 0.0)
    return overall if overall > 0 else None


class BudgetOracle(Oracle):
    """Declared accuracy and time budgets hold (module docstring)."""

    name = "budget"
    description = "the map error stays within a declared bound (mm, per Table I class) and a step within a time budget"

    def tests(self, options: Mapping[str, Any]) -> int:
        """One sign test when an accuracy budget is declared (time is judged without a test)."""
        return 1 if (float(options.get("budget_mm") or 0) > 0 or options.get("budget_classes")) else 0

    def judge(self, runs: CaseRuns, *, alpha: float) -> OracleResult:
        bound = case_budget_mm(runs.options, runs.classes)
        step_ms = float(runs.options.get("budget_step_ms") or 0.0)
        if bound is None and step_ms <= 0:
            return OracleResult(self.name, runs.case_id, SKIP, "no budget declared (budget_mm, --budget, budget_step_ms)")
        outcomes = [runs.run(k) for k in runs.reps]
        done = [o for o in outcomes if o.ok]
        if not done:
            return OracleResult(self.name, runs.case_id, SKIP, "no run finished")
        parts, failed, details, p = [], False, {}, math.nan
        statistic, unit = math.nan, ""
        if bound is not None:
            errors = [map_error_mm(runs.scenario, o) for o in done]
            exceed = [e > bound for e in errors]
            if runs.deterministic:
                over, rule = exceed[0], "deterministic SLAM: one run judged exactly"
            else:
                over, p = sign_test(exceed, alpha=alpha)
                rule = f"{sum(exceed)} of {len(exceed)} repetitions above; one-sided sign test p = {p:.3g} vs alpha {alpha:.3g}"
            failed |= over
            statistic, unit = float(np.median(errors)), "mm"
            parts.append(f"map error {statistic:.4g} mm vs budget {bound:g} mm ({rule})")
            details["error_mm"] = [round(e, 3) if math.isfinite(e) else "inf" for e in errors]
            details["budget_mm"] = bound
        if step_ms > 0:
            steps = max(1, runs.scenario.n_steps)
            fastest = 1000.0 * min(o.seconds for o in done) / steps
            slow = fastest > step_ms
            failed |= slow
            parts.append(f"fastest run {fastest:.3g} ms per step vs budget {step_ms:g} ms (of {len(done)} runs)")
            details["ms_per_step"] = [round(1000.0 * o.seconds / steps, 4) for o in done]
            if bound is None:
                statistic, unit = fastest, "ms/step"
        return OracleResult(self.name, runs.case_id, FAIL if failed else PASS,
                            ("over budget: " if failed else "within budget: ") + "; ".join(parts),
                            statistic=statistic, unit=unit, p_value=p, details=details)
