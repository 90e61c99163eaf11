"""Judging one test case by several oracles, with the check's level shared among their tests."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from faultlab.errors import ConfigError
from faultlab.oracles.oracle import CaseRuns, Oracle, OracleResult
from faultlab.scenario.model import Scenario
from faultlab.slam.protocol import SlamAdapter

__all__ = ["CaseJudgement", "judge_case", "repetition_seeds"]


@dataclass(frozen=True)
class CaseJudgement:
    """Every oracle's result on one case, the SLAM's kind and the executions it took."""

    case_id: str
    results: tuple[OracleResult, ...]
    deterministic: bool
    executions: int
    alpha_per_test: float

    @property
    def failed(self) -> bool:
        return any(r.failed for r in self.results)


def repetition_seeds(seed: int, case_id: str, repetitions: int) -> tuple[int, ...]:
    """The K SLAM seeds of a case: one SeedSequence per (check seed, case), independent of the others."""
    words = [int(seed), *case_id.encode()]
    state = np.random.SeedSequence(words).generate_state(repetitions, np.uint64)
    return tuple(int(s >> 1) for s in state)


def judge_case(case_id: str, scenario: Scenario, factory: Callable[[], SlamAdapter], *,
               oracles: Sequence[Oracle], seeds: Sequence[int], alpha: float,
               reference: Callable[[], SlamAdapter] | None = None,
               options: Mapping[str, Any] | None = None,
               classes: Mapping[str, str] | None = None,
               executor: Callable | None = None) -> CaseJudgement:
    """Judge ``scenario`` by every oracle.

    The level ``alpha`` is the chance that a correct stochastic SLAM fails the case: it is divided
    equally among the oracles' sign tests (Bonferroni).  A deterministic SLAM is judged exactly.
    ``classes`` (parameter -> class name) is the case's place in Table I, for per-class budgets;
    ``executor`` runs one execution (default :func:`faultlab.oracles.oracle.execute`).
    """
    if len(seeds) < 2:
        raise ConfigError(f"repetitions must be >= 2 (two seeds tell a deterministic SLAM), got {len(seeds)}")
    if not 0 < alpha < 1:
        raise ConfigError(f"alpha must lie in (0, 1), got {alpha!r}")
    options = dict(options or {})
    runs = CaseRuns(case_id=case_id, scenario=scenario, factory=factory, seeds=tuple(seeds), reference=reference,
                    options=options, classes=dict(classes or {}), **({"executor": executor} if executor else {}))
    n_tests = max(1, sum(o.tests(options) for o in oracles))
    per_test = alpha / n_tests
    results = tuple(o.judge(runs, alpha=per_test) for o in oracles)
    return CaseJudgement(case_id=case_id, results=results, deterministic=runs.deterministic,
                         executions=runs.executions, alpha_per_test=per_test)
