"""The verdict of ``faultlab compare``: a candidate SLAM against a recorded baseline, per case and pooled.

The gate
--------
The question a CI job asks is whether the candidate is worse on the suite, whose cases are drawn
independently from the parameter space: the **pooled** verdict
(:func:`faultlab.inference.equivalence.compare_paired`, cases as units, each case's repetitions
averaged) answers it.  A candidate is a **regression** when

* the pooled verdict is ``regression`` (one-sided t test at ``alpha``, and not equivalent within
  ``delta``), or
* it fails runs (crash, timeout, non-finite or unscorable map) that the baseline finished: exactly,
  when both are deterministic on the case; for a stochastic SLAM when more of its runs fail than
  chance explains (one-sided Fisher exact test per case at ``alpha / cases``, Bonferroni over the
  suite, so the family of crash tests keeps the level ``alpha``).

The per-case verdicts (Welch within a case; exact for a case on which both are deterministic) are
reported so a developer sees *where* the change acts; each is at level ``alpha`` and they are not
adjusted for their number, so they do not gate.

Default margin
--------------
``DEFAULT_DELTA`` = 10 %: a change of the map error within +-10 % of its level is "equivalent".
It is the equivalence margin of faultlab's per-case verdicts
(:data:`faultlab.stats.verdict.EQUIVALENCE_MARGIN_REL`, the same number): a change a user would not
act on, and about what a stochastic SLAM's mean error over a suite of ~20 cases can resolve
against itself at compare's default ``K`` = 8 (measured in ``benchmarks/compare-calibration.md``;
with fewer repetitions equivalence is shown less often).  Declare another with ``--delta`` before
the run.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import fisher_exact

from faultlab.inference.equivalence import (
    EQUIVALENT,
    IDENTICAL,
    REGRESSION,
    Comparison,
    compare_exact,
    compare_paired,
    compare_samples,
    relative_margin,
)
from faultlab.stats.verdict import EQUIVALENCE_MARGIN_REL
from faultlab.vocabulary import DEFAULT_ALPHA

__all__ = ["DEFAULT_DELTA", "EXIT_OK", "EXIT_REGRESSION", "EXIT_USAGE", "EXIT_NOT_EQUIVALENT", "CaseComparison",
           "CompareResult", "compare_records"]

#: Default equivalence margin: a relative change of the map error (module docstring: why 10 %).
DEFAULT_DELTA = EQUIVALENCE_MARGIN_REL
#: Exit statuses of ``faultlab compare``.
EXIT_OK, EXIT_REGRESSION, EXIT_USAGE, EXIT_NOT_EQUIVALENT = 0, 1, 2, 3


@dataclass(frozen=True)
class CaseComparison:
    """One case: each version's geometric-mean error over its finished runs, failures, and the verdict.

    ``comparison`` is None when the case could not be judged (``reason`` says why); ``crash_p`` is
    the Fisher exact p value of "the candidate fails more runs" (NaN when judged exactly or no run failed).
    """

    case_id: str
    values: Mapping
    baseline_mm: float
    candidate_mm: float
    baseline_failed: int
    candidate_failed: int
    runs: tuple[int, int]
    deterministic: tuple[bool, bool]
    comparison: Comparison | None
    crash_regression: bool
    crash_p: float
    reason: str = ""

    @property
    def verdict(self) -> str:
        if self.crash_regression:
            return REGRESSION
        return self.comparison.verdict if self.comparison is not None else "not judged"


@dataclass(frozen=True)
class CompareResult:
    """The comparison of a candidate with a baseline on one suite."""

    baseline: str
    candidate: str
    suite: Mapping
    delta: float
    alpha: float
    pooled: Comparison
    cases: tuple[CaseComparison, ...]
    missing: tuple[str, ...]
    common_random_numbers: bool

    @property
    def crash_regressions(self) -> tuple[CaseComparison, ...]:
        return tuple(c for c in self.cases if c.crash_regression)

    @property
    def regression(self) -> bool:
        return self.pooled.verdict == REGRESSION or bool(self.crash_regressions)

    @property
    def equivalent(self) -> bool:
        return self.pooled.verdict in (IDENTICAL, EQUIVALENT) and not self.regression and not self.missing

    def exit_code(self, *, require_equivalence: bool = False) -> int:
        if self.regression:
            return EXIT_REGRESSION
        if require_equivalence and not self.equivalent:
            return EXIT_NOT_EQUIVALENT
        return EXIT_OK


def _mean_log(errors: np.ndarray) -> float:
    ok = errors[np.isfinite(errors)]
    return float(np.mean(np.log(ok))) if ok.size else math.nan


def _case(b, c, *, margin: float, alpha: float, n_cases: int) -> CaseComparison:
    eb, ec = np.asarray(b.errors_mm, dtype=float), np.asarray(c.errors_mm, dtype=float)
    fb, fc = int(np.sum(~np.isfinite(eb))), int(np.sum(~np.isfinite(ec)))
    deterministic = (bool(b.deterministic), bool(c.deterministic))
    lb, lc = _mean_log(eb), _mean_log(ec)
    crash, crash_p, comparison, reason = False, math.nan, None, ""
    exact = all(deterministic) or (eb.size == 1 and ec.size == 1)
    if exact:
        crash = fc > 0 and fb == 0
    elif fc > 0:
        crash_p = float(fisher_exact([[fc, ec.size - fc], [fb, eb.size - fb]], alternative="greater")[1])
        crash = crash_p <= alpha / max(1, n_cases)
    if crash:
        reason = f"candidate failed {fc} of {ec.size} runs, baseline {fb} of {eb.size}"
        comparison = compare_exact(math.inf, margin=margin, alpha=alpha, what="candidate failed runs") \
            if exact else None
    elif not (math.isfinite(lb) and math.isfinite(lc)):
        reason = "no finished run of " + ("either version" if not (math.isfinite(lb) or math.isfinite(lc))
                                          else "the baseline" if not math.isfinite(lb) else "the candidate")
    elif exact:
        comparison = compare_exact(lc - lb, margin=margin, alpha=alpha, what="both deterministic on the case")
    else:
        comparison = compare_samples(np.log(eb[np.isfinite(eb)]), np.log(ec[np.isfinite(ec)]), margin=margin,
                                     alpha=alpha)
    return CaseComparison(case_id=b.case_id, values=dict(b.values), baseline_mm=math.exp(lb) if math.isfinite(lb)
                          else math.nan, candidate_mm=math.exp(lc) if math.isfinite(lc) else math.nan,
                          baseline_failed=fb, candidate_failed=fc, runs=(int(eb.size), int(ec.size)),
                          deterministic=deterministic, comparison=comparison, crash_regression=crash,
                          crash_p=crash_p, reason=reason)


def compare_records(baseline_spec: Mapping, baseline: Sequence, candidate_spec: Mapping, candidate: Sequence, *,
                    delta: float = DEFAULT_DELTA, alpha: float = DEFAULT_ALPHA) -> CompareResult:
    """Compare two records of one suite (:func:`faultlab.campaigns.compare.read_record`'s cases).

    ``*_spec`` are the records' ``to_dict()``; cases recorded in only one of them are ``missing``.
    """
    margin = relative_margin(delta)
    by_id = {c.case_id: c for c in candidate}
    common = [b for b in baseline if b.case_id in by_id]
    missing = tuple(sorted({b.case_id for b in baseline} ^ set(by_id)))
    cases = tuple(_case(b, by_id[b.case_id], margin=margin, alpha=alpha, n_cases=len(common)) for b in common)
    usable = [c for c in cases if not c.crash_regression and math.isfinite(c.baseline_mm)
              and math.isfinite(c.candidate_mm)]
    pooled = compare_paired(np.log([c.baseline_mm for c in usable]), np.log([c.candidate_mm for c in usable]),
                            margin=margin, alpha=alpha)

    def label(spec):
        return " ".join(spec["command"]) if spec.get("command") else spec["slam"]

    return CompareResult(baseline=label(baseline_spec), candidate=label(candidate_spec),
                         suite={k: baseline_spec[k] for k in ("suite", "n_cases", "n_steps", "seed", "repetitions")},
                         delta=float(delta), alpha=float(alpha), pooled=pooled, cases=cases, missing=missing,
                         common_random_numbers=baseline_spec["rep_seed"] == candidate_spec["rep_seed"])

