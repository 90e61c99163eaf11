"""The verdict of a ``faultlab check``: per oracle, how many cases passed, failed or could not be judged."""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

__all__ = ["CheckSummary", "summarise_check"]


@dataclass(frozen=True)
class CheckSummary:
    """Counts per oracle, the failing (case, oracle) pairs and the cost.

    Attributes
    ----------
    slam : str
    n_cases : int
    counts : mapping
        oracle -> {"pass": n, "fail": n, "skip": n}.
    failures : tuple of (case, oracle, message)
    reductions : tuple of (case, oracle, original size, minimal size, confirmed, tests)
    executions_per_case : float
        Mean SLAM executions per case (the K runs, the follow-ups, dead reckoning, the reference).
    deterministic : bool or None
        Whether the SLAM was deterministic on every case (None if mixed).
    """

    slam: str
    n_cases: int
    counts: Mapping[str, Mapping[str, int]]
    failures: tuple
    reductions: tuple
    executions_per_case: float
    deterministic: bool | None
    alpha: float
    repetitions: int

    @property
    def failed(self) -> bool:
        return bool(self.failures)


def summarise_check(spec: Mapping, records: Sequence) -> CheckSummary:
    """Summarise the case records of a check (``spec``: the check's ``to_dict()``)."""
    counts: dict[str, dict[str, int]] = {o: {"pass": 0, "fail": 0, "skip": 0} for o in spec["oracles"]}
    failures, reductions = [], []
    for rec in records:
        for r in rec.results:
            counts.setdefault(r["oracle"], {"pass": 0, "fail": 0, "skip": 0})[r["status"]] += 1
            if r["status"] == "fail":
                failures.append((rec.case_id, r["oracle"], r["message"]))
        for oracle, red in (rec.reduction or {}).items():
            reductions.append((rec.case_id, oracle, red["original"], red["minimal"], red["confirmed"], red["tests"]))
    kinds = {rec.deterministic for rec in records}
    label = " ".join(spec["command"]) if spec.get("command") else spec["slam"]
    return CheckSummary(slam=label, n_cases=len(records), counts=counts, failures=tuple(failures),
                        reductions=tuple(reductions),
                        executions_per_case=float(np.mean([r.executions for r in records])) if records else 0.0,
                        deterministic=kinds.pop() if len(kinds) == 1 else None, alpha=float(spec["alpha"]),
                        repetitions=int(spec["repetitions"]))
