"""The oracle contract: a judgement of one test case that needs no injected fault.

``faultlab check`` runs a SLAM under test on a test case ``K`` times (one seed each) and asks each
oracle whether those runs show a bug.  An oracle (a subclass of :class:`Oracle`) gets the case's
:class:`CaseRuns` -- the scenario, the seeds, the SLAM's K outcomes and a way to run the SLAM, or
another SLAM, on any scenario -- and returns an :class:`OracleResult`: ``pass``, ``fail`` or
``skip`` with what it measured.

Deterministic and stochastic SLAMs
----------------------------------
A SLAM is *deterministic* on a case when its first two runs with different seeds give identical
estimates (:attr:`CaseRuns.deterministic`); its repetitions are then copies of one run, and an
oracle judges that one run exactly (no test over identical repetitions).  For a *stochastic* SLAM an
oracle that compares a quantity with a bound judges the K independent repetitions with a one-sided
sign test (:func:`sign_test`): the case fails when the bound is exceeded in more repetitions than a
fair coin explains at level ``alpha`` (the check's level divided by the number of such tests on the
case, Bonferroni, so a correct SLAM fails a case with probability at most ``alpha``).
"""

from __future__ import annotations

import math
import time
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, ClassVar

import numpy as np
from scipy.stats import binomtest

from faultlab.metrics.alignment import kabsch_rms
from faultlab.scenario.model import Scenario
from faultlab.slam.protocol import Estimate, SlamAdapter, run_slam

__all__ = ["PASS", "FAIL", "SKIP", "STATUSES", "Outcome", "OracleResult", "CaseRuns", "Oracle", "sign_test",
           "execute", "map_error_mm"]

PASS, FAIL, SKIP = "pass", "fail", "skip"
STATUSES = (PASS, FAIL, SKIP)


@dataclass(frozen=True, eq=False)
class Outcome:
    """One execution of a SLAM on a scenario: its estimate, or the error that ended it (``estimate`` None)."""

    estimate: Estimate | None
    error: str = ""
    seconds: float = math.nan  # wall-clock time of the whole run (reset, steps, estimate)

    @property
    def ok(self) -> bool:
        return self.estimate is not None


def execute(factory: Callable[[], SlamAdapter], scenario: Scenario, seed: int) -> Outcome:
    """Run a fresh ``factory()`` SLAM on ``scenario`` with generator ``default_rng(seed)``.

    Any exception of the SLAM (a crash, a malformed or non-finite estimate) is an outcome, not an error.
    """
    start = time.perf_counter()
    try:
        with np.errstate(all="ignore"):
            est = run_slam(factory(), scenario, rng=np.random.default_rng(seed))
    except Exception as exc:  # the SLAM under test's failure is a result
        return Outcome(None, f"{type(exc).__name__}: {exc}", time.perf_counter() - start)
    return Outcome(est, seconds=time.perf_counter() - start)


def map_error_mm(scenario: Scenario, outcome: Outcome) -> float:
    """Kabsch-aligned RMS map error, mm; ``inf`` for a failed execution or nothing mapped in common."""
    if not outcome.ok:
        return math.inf
    est = outcome.estimate
    try:
        rms = kabsch_rms(scenario.landmark_ids, scenario.landmarks, est.landmark_ids, est.landmarks).rms
    except Exception:  # e.g. no landmark in common with the truth
        return math.inf
    return math.inf if not math.isfinite(rms) else 1000.0 * rms


def sign_test(exceed: Sequence[bool], *, alpha: float) -> tuple[bool, float]:
    """One-sided exact sign test: do more than half the repetitions exceed the bound?

    ``exceed[k]`` is true when repetition ``k`` exceeds the oracle's bound.  Under the null
    hypothesis (a correct SLAM) each repetition exceeds it with probability at most 1/2, independently.
    Returns ``(rejected, p)`` with ``p`` the binomial tail probability of at least as many exceedances.
    """
    k, n = int(np.sum(exceed)), len(exceed)
    p = float(binomtest(k, n, 0.5, alternative="greater").pvalue) if n else 1.0
    return p <= alpha, p


@dataclass
class CaseRuns:
    """A test case and the SLAM under test's runs on it, shared by every oracle that judges it.

    Attributes
    ----------
    case_id : str
    scenario : Scenario
    factory : callable
        ``() -> SlamAdapter``: a fresh SLAM under test.
    seeds : tuple of int
        One SLAM seed per repetition (K >= 2).
    reference : callable or None
        ``() -> SlamAdapter``: the reference SLAM of the differential oracle.
    options : mapping
        The check's options (margins, relations, alpha per test, ...), see :mod:`faultlab.oracles.builtin`.
    classes : mapping
        The case's Table I equivalence class of each parameter (name -> class name); empty when unknown
        (a saved case judged alone).
    executor : callable
        ``(factory, scenario, seed) -> Outcome``: one execution (default :func:`execute`; ``faultlab
        check`` passes one with a wall-clock limit).
    """

    case_id: str
    scenario: Scenario
    factory: Callable[[], SlamAdapter]
    seeds: tuple[int, ...]
    reference: Callable[[], SlamAdapter] | None = None
    options: Mapping[str, Any] = field(default_factory=dict)
    classes: Mapping[str, str] = field(default_factory=dict)
    executor: Callable[[Callable[[], SlamAdapter], Scenario, int], Outcome] = execute
    executions: int = 0
    _cache: dict = field(default_factory=dict, repr=False)

    def run(self, k: int, scenario: Scenario | None = None, *, key: str = "source",
            factory: Callable[[], SlamAdapter] | None = None, label: str = "sut", seed_stream: int = 0) -> Outcome:
        """The outcome of repetition ``k`` of the SLAM ``factory`` (default: the SLAM under test) on
        ``scenario`` (default: the case), cached under ``(label, key, k)``.

        ``seed_stream`` 0 runs with the repetition's seed; another value with an independent seed
        derived from it (``SeedSequence([seed, seed_stream])``).
        """
        cache_key = (label, key, k, seed_stream)
        if cache_key not in self._cache:
            self.executions += 1
            seed = self.seeds[k]
            if seed_stream:
                seed = int(np.random.SeedSequence([seed, seed_stream]).generate_state(1, np.uint64)[0] >> 1)
            self._cache[cache_key] = self.executor(factory or self.factory, scenario or self.scenario, seed)
        return self._cache[cache_key]

    @property
    def deterministic(self) -> bool:
        """The SLAM under test gave identical estimates with the first two seeds (module docstring)."""
        a, b = self.run(0), self.run(1)
        if not (a.ok and b.ok):
            return a.error == b.error and not a.ok and not b.ok
        return _same(a.estimate, b.estimate)

    @property
    def reps(self) -> range:
        """The repetitions to judge: one for a deterministic SLAM, all K otherwise."""
        return range(1 if self.deterministic else len(self.seeds))


def _same(a: Estimate, b: Estimate) -> bool:
    return (np.array_equal(a.pose, b.pose) and np.array_equal(a.landmark_ids, b.landmark_ids)
            and np.array_equal(a.landmarks, b.landmarks))


@dataclass(frozen=True)
class OracleResult:
    """One oracle's judgement of one case.

    Attributes
    ----------
    oracle, case_id : str
    status : str
        ``"pass"``, ``"fail"`` or ``"skip"`` (could not be judged; :attr:`message` says why).
    message : str
        One line: what was measured against what bound, and the rule.
    statistic : float
        The oracle's main figure (its unit in :attr:`unit`); NaN when none.
    p_value : float
        The sign test's p value for a stochastic SLAM; NaN when judged exactly.
    details : mapping
        Per-repetition figures (JSON-friendly).
    """

    oracle: str
    case_id: str
    status: str
    message: str
    statistic: float = math.nan
    unit: str = ""
    p_value: float = math.nan
    details: Mapping[str, Any] = field(default_factory=dict)

    @property
    def failed(self) -> bool:
        return self.status == FAIL

    def to_dict(self) -> dict:
        return {"oracle": self.oracle, "case": self.case_id, "status": self.status, "message": self.message,
                "statistic": _json_number(self.statistic), "unit": self.unit, "p_value": _json_number(self.p_value),
                "details": dict(self.details)}


def _json_number(x: float) -> float | None | str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return None
    if isinstance(x, float) and math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return float(x)


class Oracle(ABC):
    """An oracle of ``faultlab check``: judges a case from the SLAM under test's runs.

    Subclasses set :attr:`name` (lower-case snake_case, unique), :attr:`description` (one line) and
    :attr:`stochastic_tests` and implement :meth:`judge`.
    """

    name: ClassVar[str]
    description: ClassVar[str]
    #: How many sign tests the oracle makes on a case of a stochastic SLAM (the Bonferroni family
    #: share); 0 for an oracle that judges exactly.  May depend on the options: see :meth:`tests`.
    stochastic_tests: ClassVar[int] = 1

    def tests(self, options: Mapping[str, Any]) -> int:
        """Sign tests this oracle makes on a case with ``options`` (default :attr:`stochastic_tests`)."""
        return self.stochastic_tests

    @abstractmethod
    def judge(self, runs: CaseRuns, *, alpha: float) -> OracleResult:
        """Judge the case; ``alpha`` is the level of each of this oracle's sign tests."""

    def __repr__(self) -> str:
        return f"<oracle {self.name}>"
