"""Minimal failing scenarios: a failing case reduced by delta debugging until it stops failing.

The reduction (each step keeps the case consistent, :mod:`faultlab.scenario.reduce`):

1. a shorter path: the shortest prefix of the steps that still fails (bisection over the prefix
   length, then a linear walk down while it still fails);
2. fewer landmarks (a smaller map): ``ddmin`` (Zeller and Hildebrandt, *Simplifying and isolating
   failure-inducing input*, TSE 2002) over the landmark ids, keeping a 1-minimal set: removing any
   single landmark makes the case pass;
3. the idle stretches cut out;
4. the prefix shortened again (fewer landmarks may need fewer steps).

"Still fails" means the oracle fails the reduced case by its own rule: exactly for a deterministic
SLAM; for a stochastic one by its sign test at the level it was judged at, with the same seeds.
The reduction makes many such tests, so some reduction step may accept a case that a correct run
would pass; the final minimal case is therefore **confirmed** by one more test with fresh,
independent seeds at the check's level ``alpha``: the chance that a reported minimal case is a
passing case is at most ``alpha`` per failure.  A minimal case that is not confirmed is not
reported as minimal (the original case is the reproducer then).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from faultlab.scenario.model import Scenario
from faultlab.scenario.reduce import drop_idle_steps, idle_steps, keep_landmarks, size, truncate

__all__ = ["ddmin", "shortest_failing_prefix", "Reduction", "reduce_scenario"]


def ddmin(items: Sequence, fails: Callable[[list], bool]) -> list:
    """A 1-minimal subsequence of ``items`` for which ``fails`` holds (``fails(items)`` must hold).

    Zeller's ddmin: try each of ``n`` chunks and each complement; on success recurse with coarser
    granularity, otherwise refine ``n`` until chunks are single items.
    """
    current = list(items)
    n = 2
    while len(current) >= 2:
        chunk = -(-len(current) // n)
        parts = [current[i:i + chunk] for i in range(0, len(current), chunk)]
        reduced = False
        for part in parts:
            if fails(part):
                current, n, reduced = part, 2, True
                break
        if not reduced:
            for i in range(len(parts)):
                complement = [x for j, p in enumerate(parts) if j != i for x in p]
                if fails(complement):
                    current, n, reduced = complement, max(n - 1, 2), True
                    break
        if not reduced:
            if n >= len(current):
                break
            n = min(len(current), 2 * n)
    if len(current) == 1 and fails([]):
        return []
    return current


def shortest_failing_prefix(n: int, fails: Callable[[int], bool]) -> int:
    """The smallest ``m`` in ``[1, n]`` found by bisection (then walking down) with ``fails(m)``;
    ``fails(n)`` is assumed."""
    lo, hi = 1, n  # hi fails
    while lo < hi:
        mid = (lo + hi) // 2
        if fails(mid):
            hi = mid
        else:
            lo = mid + 1
    while hi > 1 and fails(hi - 1):
        hi -= 1
    return hi


@dataclass
class Reduction:
    """What :func:`reduce_scenario` found: the minimal case, its size, the cost and the confirmation."""

    scenario: Scenario
    original: dict
    minimal: dict
    tests: int = 0
    confirmed: bool = True
    log: list = field(default_factory=list)


def reduce_scenario(scenario: Scenario, fails: Callable[[Scenario], bool], *,
                    confirm: Callable[[Scenario], bool] | None = None) -> Reduction:
    """Reduce ``scenario`` (which ``fails``) to a minimal failing case (module docstring).

    ``confirm`` (default ``fails``) re-tests the final case with independent seeds.
    """
    tests = 0

    def check(s: Scenario) -> bool:
        nonlocal tests
        tests += 1
        return fails(s)

    log = [("original", size(scenario))]
    cur = scenario

    def prefix(s: Scenario) -> Scenario:
        m = shortest_failing_prefix(s.n_steps, lambda k: k == s.n_steps or check(truncate(s, k)))
        return truncate(s, m) if m < s.n_steps else s

    cur = prefix(cur)
    log.append(("prefix", size(cur)))
    ids = [int(i) for i in cur.landmark_ids]
    if ids:
        kept = ddmin(ids, lambda sub: check(keep_landmarks(cur, sub)))
        if len(kept) < len(ids):
            cur = keep_landmarks(cur, kept)
        log.append(("landmarks", size(cur)))
    if idle_steps(cur).size:
        candidate = drop_idle_steps(cur)
        if check(candidate):
            cur = candidate
        log.append(("idle", size(cur)))
    cur = prefix(cur)
    log.append(("prefix again", size(cur)))
    confirmed = (confirm or fails)(cur)
    return Reduction(scenario=cur if confirmed else scenario, original=size(scenario),
                     minimal=size(cur if confirmed else scenario), tests=tests + 1, confirmed=confirmed, log=log)
