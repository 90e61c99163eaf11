"""Checking a metamorphic relation on a SLAM (with or without a fault), and the relation x fault matrix.

The decision rule
-----------------
For a relation, a source case and ``K`` repetitions (``rngs``, one generator each, K >= 2):

1. repetition ``k`` draws one integer from ``rngs[k]``; from it come the SLAM's seed (the same for
   the source and the follow-up run, and for the unmodified SLAM and the faulty one: common random
   numbers) and the transform's generator (so every variant sees the same follow-up cases);
2. the SLAM under test (``slam_factory()`` with ``fault`` applied) runs the source and the
   follow-up case; the relation's :meth:`~faultlab.metamorphic.relation.MetamorphicRelation.discrepancy`
   ``d_k`` measures how far the follow-up estimate is from what the relation expects.  The
   unmodified SLAM does the same: its discrepancies are ``b_k``;
3. the unmodified SLAM's source runs with the K seeds give the seed-to-seed **spread**: the
   relation's :meth:`~faultlab.metamorphic.relation.MetamorphicRelation.spread` over all
   ``K (K - 1) / 2`` pairs, ``s`` their median: how much the output moves when only the seed changes;
4. the relation **holds** if ``median_k d_k <= tolerance``, else it is **violated**, with

   * for an *exact* relation (rigid motion, id permutation, whole turns on bearings: a correct
     algorithm satisfies it up to rounding) checked on a fault:
     ``tolerance = max(atol, factor * max_k b_k)``: the faulty SLAM may deviate from the relation
     as much as the unmodified SLAM does on the same follow-up cases with the same seeds (its
     rounding, amplified by the filter), and ``atol`` (default 1 µm) absorbs the different rounding
     of a different computation;
   * for the unmodified SLAM itself, and for a *statistical* relation (``halved_noise``, which holds
     on average only): ``tolerance = max(atol, factor * s)``: the discrepancy must stay within what
     a change of seed does.

Why two yardsticks: with the same seed, a SLAM that satisfies an exact relation produces a
follow-up estimate that differs from the expected one by rounding only (the reference FastSLAM:
1e-16..1e-14 m), while a seed change moves its unaligned estimate by decimetres (the paper's 20°
turn noise rotates the whole map); a fault that breaks the relation typically moves the follow-up
by millimetres to metres.  The seed spread is therefore the right scale to judge the unmodified
SLAM by (does it respect the relation at all?) but far too lenient for faults, which are judged
against the unmodified SLAM's own deviation.  A statistical relation compares a change of the map
error between two different inputs, which varies like the map error does from seed to seed, so
the seed spread is its scale for every variant.

This is a screening rule, not a hypothesis test with a controlled false-alarm rate.  A faulty SLAM
that is so unstable that the rounding differences of a transformation decorrelate its two runs is
reported as violating an exact relation: true of its output, but it then says that the output is
not reproducible rather than which symmetry is broken.  And a statistical relation on a SLAM whose
error varies by metres from run to run is violated or not almost by chance (a median of K signed
differences).  The result therefore reports every discrepancy, the unmodified SLAM's
discrepancies and spread, the tolerance and its basis, not the verdict alone.

Sensor faults (:class:`~faultlab.faults.sensor.SensorFault`) leave the SLAM's code alone and
perturb the stream it is fed.  A stream fault is applied as the campaign runner applies it
(:func:`~faultlab.scenario.feed.fed_scenario`): in repetition ``k`` the faulty sensor delivers its
perturbation of the source case and of the follow-up case, both drawn from the fault's own stream
keyed by the repetition's seed (the same perturbation draws for both cases), while the relation's
discrepancy is measured against the unperturbed cases' ground truth.  For an *exact* relation this
is only meaningful when the fault and the relation's transform commute on the case (perturbing the
follow-up gives the transform of the perturbed source): otherwise even a correct SLAM would be
reported as violating the relation.  The check verifies that on every repetition before running a
SLAM and refuses a pair that does not commute, naming it (e.g. ``id_permutation`` re-sorts the
observations of a step, so a fault that drops observations by their position drops others).  A
statistical relation is judged on the perturbed follow-up as it is: the same faulty sensor in the
transformed world.  A hardware limit (a fault that changes a SLAM option) is refused: the check
receives a SLAM factory, not options; check the SLAM built with the limited option instead.

Repetitions in which the SLAM under test crashes (raises, or returns a non-finite estimate) on
exactly one of the two cases count as infinitely discrepant; those in which it crashes on both
are left out, and if that leaves none the verdict is ``crash``.  The unmodified SLAM must not crash
(:class:`~faultlab.errors.SlamOutputError` otherwise).
"""

from __future__ import annotations

import enum
import math
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from faultlab.errors import ConfigError, SlamOutputError
from faultlab.metamorphic.relation import MetamorphicRelation
from faultlab.scenario.generator import fixed_case_scenario
from faultlab.scenario.feed import fed_scenario, perturbs_stream, sets_option
from faultlab.scenario.model import Scenario
from faultlab.slam.protocol import Estimate, SlamAdapter, run_slam
from faultlab.vocabulary import BASELINE

__all__ = [
    "DEFAULT_FACTOR",
    "DEFAULT_ATOL",
    "SCENARIO_OVERRIDES",
    "Verdict",
    "RelationResult",
    "RelationMatrix",
    "check_relation",
    "relation_matrix",
    "metamorphic_scenario",
]

#: Default multiple of the baseline's seed-to-seed spread a discrepancy may reach.
DEFAULT_FACTOR = 1.0
#: Default least tolerance, in the relation's unit (m): rounding of deterministic SLAMs.
DEFAULT_ATOL = 1e-6

#: Changes to :data:`faultlab.space.case.FIXED_VALUES` for :func:`metamorphic_scenario`: a small map
#: (4 m x 4 m, about 80 landmarks) so that short checks are fast.
SCENARIO_OVERRIDES: dict[str, float | str] = {"map_size": 16.0}


class Verdict(enum.StrEnum):
    """Outcome of one relation for one SLAM variant."""

    HOLDS = "holds"
    VIOLATED = "violated"
    CRASH = "crash"  # the SLAM under test crashed on both cases of every repetition


@dataclass(frozen=True)
class RelationResult:
    """One relation checked on one SLAM variant (see the module docstring for the rule).

    Attributes
    ----------
    relation : str
    variant : str
        ``"baseline"`` or the fault's name.
    discrepancies : tuple of float
        ``d_k`` per repetition, in :attr:`unit` (inf: crashed on exactly one case; NaN: on both).
    baseline_discrepancies : tuple of float
        ``b_k``: the unmodified SLAM's discrepancies on the same follow-up cases and seeds.
    spreads : tuple of float
        The unmodified SLAM's seed-to-seed spreads over pairs of repetitions.
    statistic : float
        Median of the discrepancies that are not NaN (NaN if none).
    spread : float
        Median of the spreads.
    factor, atol : float
        The rule's parameters.
    tolerance : float
    basis : str
        What the tolerance is a multiple of: ``"seed spread"`` or ``"baseline discrepancy"``.
    verdict : Verdict
    unit : str
    exact, uses_truth : bool
        The relation's kind (:class:`~faultlab.metamorphic.relation.MetamorphicRelation`).
    errors : tuple of str
        Crashes of the SLAM under test: ``"rep k source|follow-up: Type: message"``.
    """

    relation: str
    variant: str
    discrepancies: tuple[float, ...]
    baseline_discrepancies: tuple[float, ...]
    spreads: tuple[float, ...]
    statistic: float
    spread: float
    factor: float
    atol: float
    tolerance: float
    basis: str
    verdict: Verdict
    unit: str = "m"
    exact: bool = True
    uses_truth: bool = False
    errors: tuple[str, ...] = ()

    @property
    def holds(self) -> bool:
        return self.verdict is Verdict.HOLDS

    def summary(self) -> str:
        """One line: verdict, median discrepancy, the unmodified SLAM's yardsticks and the tolerance."""
        text = (f"{self.relation} on {self.variant}: {self.verdict.value} (median discrepancy "
                f"{_fmt(self.statistic)} {self.unit}; unmodified SLAM: largest discrepancy "
                f"{_fmt(max(self.baseline_discrepancies, default=math.nan))} {self.unit}, seed spread "
                f"{_fmt(self.spread)} {self.unit}; tolerance {_fmt(self.tolerance)} {self.unit} from the "
                f"{self.basis}; {len(self.discrepancies)} repetitions)")
        if self.errors:
            text += f"; {len(self.errors)} crash(es): {self.errors[0]}"
        return text


def _fmt(x: float) -> str:
    if math.isnan(x):
        return "nan"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return f"{x:.3g}"


# --------------------------------------------------------------------------- the checker

#: The arrays of a scenario that make up the stream a SLAM is fed.
_STREAM_FIELDS = ("controls", "obs_offsets", "obs_range", "obs_bearing", "obs_ids")


def _refuse_unjudgeable(checker: "_Checker", relations: Sequence[MetamorphicRelation], faults: Sequence) -> None:
    """Raise one :class:`ConfigError` naming every (relation, fault) pair that cannot be judged."""
    problems = [reason for fault in faults for relation in relations
                if (reason := checker.unjudgeable(relation, fault)) is not None]
    problems = list(dict.fromkeys(problems))
    if problems:
        raise ConfigError("metamorphic check refused: " + "; ".join(problems)
                          + " (leave these relations or faults out)")


class _Checker:
    """Runs and caches the SLAM runs that several checks on one source case share."""

    def __init__(self, slam_factory: Callable[[], SlamAdapter], scenario: Scenario,
                 rngs: Sequence[np.random.Generator]):
        if not callable(slam_factory):
            raise ConfigError(f"slam_factory must be callable () -> SlamAdapter, got {slam_factory!r}")
        rngs = list(rngs)
        if len(rngs) < 2:
            raise ConfigError(f"rngs: at least 2 repetitions are needed for the baseline's spread, got {len(rngs)}")
        if not all(isinstance(g, np.random.Generator) for g in rngs):
            raise ConfigError("rngs must be numpy.random.Generator instances, one per repetition")
        self.factory = slam_factory
        self.scenario = scenario
        self.seeds = [int(g.integers(2 ** 63)) for g in rngs]
        self._followups: dict[tuple[int, int], Scenario] = {}
        self._runs: dict[tuple[str, int, int], Estimate | str] = {}
        self._keep: list[MetamorphicRelation] = []  # keeps cached relations alive (ids stay unique)

    @property
    def n_reps(self) -> int:
        return len(self.seeds)

    def _rng(self, k: int, stream: int) -> np.random.Generator:
        return np.random.default_rng(np.random.SeedSequence([self.seeds[k], stream]))

    def followup(self, relation: MetamorphicRelation, k: int) -> Scenario:
        key = (id(relation), k)
        if key not in self._followups:
            self._keep.append(relation)
            self._followups[key] = relation.transform(self.scenario, self._rng(k, 1))
        return self._followups[key]

    def fed(self, fault, relation: MetamorphicRelation | None, k: int) -> Scenario:
        """The source (``relation`` None) or follow-up case as the SLAM with ``fault`` is fed it in repetition ``k``."""
        scenario = self.scenario if relation is None else self.followup(relation, k)
        return fed_scenario(fault, scenario, seed=self.seeds[k])

    def unjudgeable(self, relation: MetamorphicRelation, fault) -> str | None:
        """Why ``relation`` cannot be judged on the SLAM with ``fault``, or None (module docstring)."""
        if sets_option(fault):
            return (f"sensor fault {fault.name!r} is a hardware limit (it changes the SLAM option "
                    f"{fault.option!r}); the metamorphic check cannot set SLAM options: check the SLAM built "
                    f"with that option instead")
        if not perturbs_stream(fault) or not relation.exact:
            return None
        for k in range(self.n_reps):
            expected = relation.transform(self.fed(fault, None, k), self._rng(k, 1))
            actual = self.fed(fault, relation, k)
            for name in _STREAM_FIELDS:
                a, b = getattr(actual, name), getattr(expected, name)
                if a.shape != b.shape or not np.array_equal(a, b):
                    return (f"relation {relation.name!r} cannot be judged under sensor fault {fault.name!r}: "
                            f"the fault and the relation's transform do not commute on this case (repetition "
                            f"{k}: perturbing the follow-up case and transforming the perturbed source case "
                            f"give different {name}), so even a correct SLAM would violate this exact "
                            f"relation")
        return None

    def run(self, fault, relation: MetamorphicRelation | None, k: int) -> Estimate | str:
        """The estimate of the SLAM (with ``fault``) on the source (``relation`` None) or follow-up case."""
        variant = BASELINE if fault is None else fault.name
        key = (variant, 0 if relation is None else id(relation), k)
        if key not in self._runs:
            scenario = self.fed(fault, relation, k)
            slam = self.factory()
            if fault is not None:
                slam = fault.apply(slam)  # a fault that does not apply is the caller's error
            try:
                with np.errstate(all="ignore"):
                    self._runs[key] = run_slam(slam, scenario, rng=self._rng(k, 0))
            except Exception as exc:  # the SLAM under test's failure is a result
                self._runs[key] = f"{type(exc).__name__}: {exc}"
        return self._runs[key]

    def _baseline(self, relation: MetamorphicRelation | None, k: int) -> Estimate:
        r = self.run(None, relation, k)
        if isinstance(r, str):
            case = "source case" if relation is None else f"follow-up case of {relation.name}"
            raise SlamOutputError(f"metamorphic check: the unmodified SLAM failed on the {case} in repetition {k} "
                                  f"({r}); it is the yardstick of every check")
        return r

    def spreads(self, relation: MetamorphicRelation) -> tuple[float, ...]:
        """The unmodified SLAM's seed-to-seed spreads (relation's measure) over all pairs of repetitions."""
        runs = [self._baseline(None, k) for k in range(self.n_reps)]
        return tuple(float(relation.spread(runs[i], runs[j], scenario=self.scenario))
                     for i in range(self.n_reps) for j in range(i + 1, self.n_reps))

    def discrepancies(self, relation: MetamorphicRelation, fault) -> tuple[list[float], list[str]]:
        """``d_k`` of the SLAM (with ``fault``) and the crash messages."""
        discrepancies: list[float] = []
        errors: list[str] = []
        for k in range(self.n_reps):
            src, fu = self.run(fault, None, k), self.run(fault, relation, k)
            for what, r in (("source", src), ("follow-up", fu)):
                if isinstance(r, str):
                    errors.append(f"rep {k} {what}: {r}")
            if isinstance(src, str) and isinstance(fu, str):
                discrepancies.append(math.nan)
            elif isinstance(src, str) or isinstance(fu, str):
                discrepancies.append(math.inf)
            else:
                try:
                    with np.errstate(all="ignore"):
                        d = float(relation.discrepancy(src, fu, source_scenario=self.scenario,
                                                       followup=self.followup(relation, k)))
                except Exception as exc:  # e.g. a faulty estimate the comparison cannot read
                    errors.append(f"rep {k} comparison: {type(exc).__name__}: {exc}")
                    d = math.inf
                discrepancies.append(math.inf if math.isnan(d) else d)
        return discrepancies, errors

    def check(self, relation: MetamorphicRelation, fault, *, factor: float, atol: float) -> RelationResult:
        spreads = self.spreads(relation)
        for k in range(self.n_reps):
            self._baseline(relation, k)  # the unmodified SLAM must run the follow-ups too
        base, _ = self.discrepancies(relation, None)
        mine, errors = (base, []) if fault is None else self.discrepancies(relation, fault)
        return _decide(relation, BASELINE if fault is None else fault.name, mine, base, spreads,
                       factor=factor, atol=atol, errors=errors)


def _decide(relation: MetamorphicRelation, variant: str, discrepancies: Sequence[float],
            baseline: Sequence[float], spreads: Sequence[float], *, factor: float, atol: float,
            errors: Sequence[str]) -> RelationResult:
    counted = [d for d in discrepancies if not math.isnan(d)]
    statistic = float(np.median(counted)) if counted else math.nan
    spread = float(np.median(spreads))
    if relation.exact and variant != BASELINE:
        basis, scale = "baseline discrepancy", max(float(np.max(baseline)), 0.0)
    else:
        basis, scale = "seed spread", spread
    tolerance = max(factor * scale, atol)
    if not counted:
        verdict = Verdict.CRASH
    else:
        verdict = Verdict.HOLDS if statistic <= tolerance else Verdict.VIOLATED
    return RelationResult(relation=relation.name, variant=variant, discrepancies=tuple(map(float, discrepancies)),
                          baseline_discrepancies=tuple(map(float, baseline)), spreads=tuple(spreads),
                          statistic=statistic, spread=spread, factor=float(factor), atol=float(atol),
                          tolerance=float(tolerance), basis=basis, verdict=verdict, unit=relation.unit,
                          exact=relation.exact, uses_truth=relation.uses_truth, errors=tuple(errors))


def _check_options(factor: float, atol: float) -> None:
    for name, value in (("factor", factor), ("atol", atol)):
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value) or value < 0:
            raise ConfigError(f"{name} must be a finite number >= 0, got {value!r}")


def check_relation(slam_factory: Callable[[], SlamAdapter], relation: MetamorphicRelation, scenario: Scenario, *,
                   rngs: Sequence[np.random.Generator], fault=None, factor: float = DEFAULT_FACTOR,
                   atol: float = DEFAULT_ATOL) -> RelationResult:
    """Check ``relation`` on the SLAM ``slam_factory()`` (with ``fault`` applied) on one source case.

    Parameters
    ----------
    slam_factory : callable
        ``() -> SlamAdapter``, a fresh unmodified SLAM per call.
    relation : MetamorphicRelation
    scenario : Scenario
        The source case.
    rngs : sequence of numpy.random.Generator
        One per repetition (K >= 2); one integer is drawn from each.
    fault : Fault or SensorFault, optional
        A code fault is applied with ``fault.apply(slam)``, a stream fault perturbs both cases the
        SLAM is fed (module docstring); None checks the unmodified SLAM.
    factor, atol : float
        The decision rule's parameters (module docstring).

    Returns
    -------
    RelationResult

    Raises
    ------
    ConfigError
        A hardware limit, or an exact relation whose transform does not commute with the stream fault.
    """
    _check_options(factor, atol)
    if relation.uses_truth:
        scenario.require_truth(f"relation {relation.name!r}")
    checker = _Checker(slam_factory, scenario, rngs)
    _refuse_unjudgeable(checker, [relation], [] if fault is None else [fault])
    return checker.check(relation, fault, factor=factor, atol=atol)


# --------------------------------------------------------------------------- the matrix

@dataclass(frozen=True)
class RelationMatrix:
    """Relations x SLAM variants (the unmodified SLAM first): the result of :func:`relation_matrix`.

    Attributes
    ----------
    relations : tuple of str
    variants : tuple of str
        ``"baseline"`` then the faults, in the order given.
    results : mapping
        ``(variant, relation) -> RelationResult``.
    scenario : str
        One line describing the source case.
    n_reps : int
    skipped : tuple of str
        Notes on faults left out (e.g. not applicable to the SLAM).
    """

    relations: tuple[str, ...]
    variants: tuple[str, ...]
    results: Mapping[tuple[str, str], RelationResult]
    scenario: str = ""
    n_reps: int = 0
    skipped: tuple[str, ...] = field(default=())

    def violations(self) -> dict[str, list[str]]:
        """Relation -> the faults (not the baseline) that violate it."""
        return {r: [v for v in self.variants if v != BASELINE and self.results[(v, r)].verdict is Verdict.VIOLATED]
                for r in self.relations}

    def format(self) -> str:
        """A plain-text matrix: one row per variant, one column per relation; a cell gives the verdict
        and the median discrepancy (in the relation's unit, m)."""
        def cell(res: RelationResult) -> str:
            if res.verdict is Verdict.CRASH:
                return "crash"
            return f"{'VIOLATED' if res.verdict is Verdict.VIOLATED else 'holds'} {res.statistic:.2g}"

        base = {r: self.results[(BASELINE, r)] for r in self.relations} if BASELINE in self.variants else {}
        header = ("variant", *(f"{r} ({self.results[(self.variants[0], r)].unit})" for r in self.relations))
        rows = [(v, *(cell(self.results[(v, r)]) for r in self.relations)) for v in self.variants]
        extra = []
        if base:
            extra.append(("seed spread", *(f"{base[r].spread:.2g}" for r in self.relations)))
            extra.append(("fault tolerance", *(f"{self._fault_tolerance(base[r]):.2g}" for r in self.relations)))
        table = [header, *extra, *rows]
        widths = [max(len(row[i]) for row in table) for i in range(len(header))]
        lines = [f"metamorphic relations on {self.scenario}; {self.n_reps} repetitions (median discrepancy "
                 f"per cell)"]
        for j, row in enumerate(table):
            lines.append("  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(row, widths))))
            if j == 0:
                lines.append("  ".join("-" * w for w in widths))
        if base:
            first = next(iter(base.values()))
            lines.append(f"seed spread: median distance between the unmodified SLAM's runs with different seeds; "
                         f"fault tolerance: max({first.atol:g}, {first.factor:g} x the unmodified SLAM's largest "
                         f"discrepancy) for exact relations, max({first.atol:g}, {first.factor:g} x seed spread) "
                         f"for statistical ones")
        for r in self.relations:
            res = self.results[(self.variants[0], r)]
            kind = "exact" if res.exact else "statistical"
            truth = ", compares with the ground truth" if res.uses_truth else ""
            faults = self.violations()[r]
            lines.append(f"{r} ({kind}{truth}): violated by {', '.join(faults) if faults else 'no fault'}")
        if base and any(not res.holds for res in base.values()):
            lines.append("WARNING: the unmodified SLAM violates a relation: the relation or the SLAM is wrong")
        lines += list(self.skipped)
        return "\n".join(lines)

    @staticmethod
    def _fault_tolerance(base: RelationResult) -> float:
        if base.exact:
            return max(base.factor * max(max(base.baseline_discrepancies), 0.0), base.atol)
        return base.tolerance

    def __str__(self) -> str:
        return self.format()


def relation_matrix(slam_factory: Callable[[], SlamAdapter], relations: Iterable[MetamorphicRelation],
                    faults: Iterable, scenario: Scenario, *, rngs: Sequence[np.random.Generator],
                    factor: float = DEFAULT_FACTOR, atol: float = DEFAULT_ATOL, description: str = "",
                    skipped: Sequence[str] = ()) -> RelationMatrix:
    """Check every relation on the unmodified SLAM and on each fault; runs are shared between relations.

    Parameters are those of :func:`check_relation`; ``faults`` are :class:`~faultlab.faults.Fault`
    objects that apply to the SLAM, ``description`` names the source case in the output and
    ``skipped`` adds notes (e.g. faults left out because they do not apply).
    """
    _check_options(factor, atol)
    relations = list(relations)
    faults = list(faults)
    for relation in relations:
        if relation.uses_truth:
            scenario.require_truth(f"relation {relation.name!r}")
    checker = _Checker(slam_factory, scenario, rngs)
    _refuse_unjudgeable(checker, relations, faults)
    results: dict[tuple[str, str], RelationResult] = {}
    for fault in [None, *faults]:
        for relation in relations:
            res = checker.check(relation, fault, factor=factor, atol=atol)
            results[(res.variant, res.relation)] = res
    variants = (BASELINE, *(f.name for f in faults))
    return RelationMatrix(relations=tuple(r.name for r in relations), variants=variants, results=results,
                          scenario=description or "the given case", n_reps=checker.n_reps, skipped=tuple(skipped))


def metamorphic_scenario(*, seed: int = 0, n_steps: int = 150) -> Scenario:
    """A short source case for metamorphic checks: the fixed suite's values on a 4 m x 4 m map.

    Parameters
    ----------
    seed : int
        Entropy of the generator's SeedSequence.
    n_steps : int
        Active steps.
    """
    return fixed_case_scenario(SCENARIO_OVERRIDES, seed=seed, n_steps=n_steps)
