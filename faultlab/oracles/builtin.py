"""The built-in oracles of ``faultlab check``: execution, metamorphic, floor, differential.

============ ===================================================================================
oracle       a case fails when
============ ===================================================================================
execution    a run crashes (an exception, a malformed or non-finite estimate; a process SLAM's
             broken rule, death or timeout is an exception of its adapter)
metamorphic  a follow-up run of an exact metamorphic relation (rigid motion, id permutation, whole
             turns on bearings, plugins) departs from what the relation expects of the source run:
             for a deterministic SLAM by more than ``metamorphic_atol`` (rounding); for a stochastic
             one, in more repetitions than a fair coin explains, by more than the distance between
             the source run and a run with an independent seed (sign test)
floor        the map error exceeds dead reckoning's on the same scenario by more than the declared
             margin: ``error > (1 + floor_ratio) * dead_reckoning_error + floor_margin_mm``
differential the map error exceeds the reference SLAM's (default faultlab's EKF-SLAM) on the same
             scenario and seed by more than the declared margin: ``error > (1 + differential_ratio)
             * reference_error + differential_margin_mm``
============ ===================================================================================

Floor and differential judge the runs that finished (a crash is the execution oracle's); for a
stochastic SLAM a repetition "exceeds" when its error is above the bound, and the case fails by the
sign test of :mod:`faultlab.oracles.oracle`.  A statistical relation (``halved_noise``) holds only on
average over cases, so no single case can violate it: it is skipped with that reason.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from faultlab.metamorphic.registry import get_relation
from faultlab.oracles.budget import BUDGET_OPTIONS, BudgetOracle
from faultlab.oracles.consistency import ConsistencyOracle
from faultlab.oracles.oracle import FAIL, PASS, SKIP, CaseRuns, Oracle, OracleResult, map_error_mm, sign_test
from faultlab.slam.deadreckoning import DeadReckoning

__all__ = ["DEFAULT_OPTIONS", "ExecutionOracle", "MetamorphicOracle", "FloorOracle", "DifferentialOracle",
           "ConsistencyOracle", "BudgetOracle", "BUILTIN_ORACLES"]

#: The declared margins and tolerances (``faultlab check`` options of the same names).
DEFAULT_OPTIONS: dict[str, Any] = {
    "relations": ("rigid_motion", "id_permutation", "bearing_turn"),
    "metamorphic_atol": 1e-6,     # m: rounding of a deterministic SLAM on an exact relation
    "floor_ratio": 1.0,           # a SLAM may be twice as bad as dead reckoning ...
    "floor_margin_mm": 50.0,      # ... plus 50 mm, before it is called broken
    "differential_ratio": 2.0,    # three times the reference SLAM's error ...
    "differential_margin_mm": 100.0,  # ... plus 100 mm
    "consistency_stochastic": 0.0,  # 1: a stochastic SLAM's overconfidence fails the case (0: reported)
    **BUDGET_OPTIONS,  # budget_mm, budget_classes, budget_step_ms: none declared
}


def _opt(runs: CaseRuns, key: str):
    return runs.options.get(key, DEFAULT_OPTIONS[key])


def _fmt(x: float) -> str:
    return "inf" if math.isinf(x) else f"{x:.4g}"


class ExecutionOracle(Oracle):
    """Every run finishes with a well-formed, finite estimate."""

    name = "execution"
    description = "every run finishes with a well-formed, finite estimate (no crash, timeout or NaN)"
    stochastic_tests = 0

    def judge(self, runs: CaseRuns, *, alpha: float) -> OracleResult:
        outcomes = [runs.run(k) for k in (range(2) if runs.deterministic else range(len(runs.seeds)))]
        bad = [(k, o.error) for k, o in enumerate(outcomes) if not o.ok]
        if bad:
            k, error = bad[0]
            return OracleResult(self.name, runs.case_id, FAIL,
                                f"{len(bad)} of {len(outcomes)} runs failed; repetition {k}: {error}",
                                statistic=float(len(bad)), unit="runs", details={"errors": [e for _, e in bad]})
        return OracleResult(self.name, runs.case_id, PASS, f"all {len(outcomes)} runs finished",
                            statistic=0.0, unit="runs")


class _BoundOracle(Oracle):
    """An oracle that compares the SLAM's map error with a bound per repetition."""

    unit = "mm"

    def bound(self, runs: CaseRuns, k: int) -> float | None:
        """The bound of repetition ``k`` (mm), or None when it cannot be computed."""
        raise NotImplementedError

    def judge(self, runs: CaseRuns, *, alpha: float) -> OracleResult:
        reps = list(runs.reps)
        errors, bounds = [], []
        for k in reps:
            out = runs.run(k)
            b = self.bound(runs, k)
            if out.ok and b is not None:
                errors.append(map_error_mm(runs.scenario, out))
                bounds.append(b)
        if not errors:
            return OracleResult(self.name, runs.case_id, SKIP, "no run with a computable bound finished")
        exceed = [e > b for e, b in zip(errors, bounds)]
        details = {"error_mm": [_fmt(e) for e in errors], "bound_mm": [_fmt(b) for b in bounds]}
        worst = float(np.median(np.asarray(errors) - np.asarray(bounds)))
        if runs.deterministic:
            failed = exceed[0]
            rule = "deterministic SLAM: one run judged exactly"
            p = math.nan
        else:
            failed, p = sign_test(exceed, alpha=alpha)
            rule = (f"{sum(exceed)} of {len(exceed)} repetitions above the bound; one-sided sign test "
                    f"p = {p:.3g} vs alpha {alpha:.3g}")
        msg = (f"map error {_fmt(float(np.median(errors)))} mm vs bound {_fmt(float(np.median(bounds)))} mm "
               f"({self.bound_text(runs)}); {rule}")
        return OracleResult(self.name, runs.case_id, FAIL if failed else PASS, msg, statistic=worst, unit="mm",
                            p_value=p, details=details)

    def bound_text(self, runs: CaseRuns) -> str:
        raise NotImplementedError


class FloorOracle(_BoundOracle):
    """The SLAM's map is not worse than dead reckoning's by more than the declared margin."""

    name = "floor"
    description = "the map error does not exceed dead reckoning's on the same scenario by more than a declared margin"

    def bound(self, runs: CaseRuns, k: int) -> float | None:
        dr = runs.run(0, factory=DeadReckoning, label="dead_reckoning")  # deterministic: one run
        e = map_error_mm(runs.scenario, dr)
        if not math.isfinite(e):
            return None
        return (1.0 + _opt(runs, "floor_ratio")) * e + _opt(runs, "floor_margin_mm")

    def bound_text(self, runs: CaseRuns) -> str:
        return (f"(1 + {_opt(runs, 'floor_ratio'):g}) x dead reckoning + {_opt(runs, 'floor_margin_mm'):g} mm")


class DifferentialOracle(_BoundOracle):
    """The SLAM's map is not worse than a reference SLAM's by more than the declared margin."""

    name = "differential"
    description = "the map error does not exceed a reference SLAM's on the same scenario by more than a declared margin"

    def bound(self, runs: CaseRuns, k: int) -> float | None:
        if runs.reference is None:
            return None
        ref = runs.run(k, factory=runs.reference, label="reference")
        e = map_error_mm(runs.scenario, ref)
        if not math.isfinite(e):
            return None
        return (1.0 + _opt(runs, "differential_ratio")) * e + _opt(runs, "differential_margin_mm")

    def bound_text(self, runs: CaseRuns) -> str:
        return (f"(1 + {_opt(runs, 'differential_ratio'):g}) x reference + "
                f"{_opt(runs, 'differential_margin_mm'):g} mm")


class MetamorphicOracle(Oracle):
    """Exact metamorphic relations hold (module docstring)."""

    name = "metamorphic"
    description = "exact metamorphic relations hold (rigid motion, id permutation, whole turns on bearings)"

    def tests(self, options: Mapping[str, Any]) -> int:
        return len(options.get("relations", DEFAULT_OPTIONS["relations"]))

    def judge(self, runs: CaseRuns, *, alpha: float) -> OracleResult:
        relations = [get_relation(r) for r in _opt(runs, "relations")]
        atol = _opt(runs, "metamorphic_atol")
        deterministic = runs.deterministic
        verdicts, details, p_min, worst = [], {}, math.nan, 0.0
        for rel in relations:
            if not rel.exact:
                details[rel.name] = "statistical relation: holds on average over cases, not judged per case"
                continue
            d, s = [], []
            for k in runs.reps:
                src = runs.run(k)
                if not src.ok:
                    continue
                fu_scenario = rel.transform(runs.scenario, np.random.default_rng(np.random.SeedSequence(
                    [runs.seeds[k], 1])))
                fu = runs.run(k, fu_scenario, key=rel.name)
                if not fu.ok:
                    d.append(math.inf)
                else:
                    try:
                        with np.errstate(all="ignore"):
                            x = float(rel.discrepancy(src.estimate, fu.estimate, source_scenario=runs.scenario,
                                                      followup=fu_scenario))
                    except Exception:  # e.g. the SLAM mapped an id the case does not have: the relation cannot hold
                        x = math.inf
                    d.append(math.inf if math.isnan(x) else x)
                if not deterministic:
                    other = runs.run(k, key="independent seed", seed_stream=2)
                    s.append(float(rel.spread(src.estimate, other.estimate, scenario=runs.scenario))
                             if other.ok else math.inf)
            if not d:
                details[rel.name] = "no source run finished"
                continue
            if deterministic:
                failed, p = d[0] > atol, math.nan
                details[rel.name] = f"discrepancy {_fmt(d[0])} m vs rounding tolerance {atol:g} m"
            else:
                failed, p = sign_test([a > b for a, b in zip(d, s)], alpha=alpha)
                details[rel.name] = (f"discrepancy above the independent-seed distance in "
                                     f"{sum(a > b for a, b in zip(d, s))} of {len(d)} repetitions "
                                     f"(median {_fmt(float(np.median(d)))} m vs {_fmt(float(np.median(s)))} m); "
                                     f"sign test p = {p:.3g} vs alpha {alpha:.3g}")
                p_min = p if math.isnan(p_min) else min(p_min, p)
            worst = max(worst, float(np.median(d)))
            verdicts.append((rel.name, failed))
        if not verdicts:
            return OracleResult(self.name, runs.case_id, SKIP, "; ".join(f"{k}: {v}" for k, v in details.items()),
                                details=details)
        broken = [n for n, f in verdicts if f]
        how = "deterministic SLAM, judged exactly" if deterministic else "stochastic SLAM, sign test per relation"
        msg = (f"violated: {', '.join(broken)}" if broken else f"{len(verdicts)} relations hold") + f" ({how}); " + \
            "; ".join(f"{k}: {v}" for k, v in details.items())
        return OracleResult(self.name, runs.case_id, FAIL if broken else PASS, msg, statistic=worst, unit="m",
                            p_value=p_min, details={"violated": broken, **details})


#: The built-in oracles, in the order ``faultlab check`` applies them.
BUILTIN_ORACLES: tuple[Oracle, ...] = (ExecutionOracle(), MetamorphicOracle(), FloorOracle(), DifferentialOracle(),
                                       ConsistencyOracle(), BudgetOracle())
