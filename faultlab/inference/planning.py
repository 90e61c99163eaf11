"""Power before running: the scale at which a study can detect the differences it is asked about.

A study compares test-design strategies two at a time.  Its plan answers, before any SLAM runs,
how many pool cases per strategy, how many mutants and how many repetitions K it needs so that

* a difference of ``target_detection`` (e.g. 20 pp) in the **single-case detection probability**
  of a variant (the share of a strategy's pool cases that detect it) is found with ``power``;
* a difference of ``target_score`` (e.g. 10 pp) in **mutation score** between two strategies is
  found with ``power``;

using the tests the studies' analyses use for those comparisons, at the level of their families:

Detection probability
    Two-sample test of two proportions on Cohen's arcsine effect size
    ``h = 2 asin(sqrt(p_a)) - 2 asin(sqrt(p_b))``, two-sided, power from statsmodels
    ``NormalIndPower`` -- the test behind the strategies study's power table
    (:func:`faultlab.stats.cases.detectable_difference`).  The planned difference is centred on
    ``p_centre`` (default 0.5, where a proportion's variance and so the pool needed is largest).
Mutation score
    Exact McNemar test over the mutants (statsmodels ``mcnemar(exact=True)``: two-sided binomial
    test of the discordant counts), as the mutation study's ``mcnemar`` table and the strategies
    study's per-draw comparison.  Its power has no closed form; :func:`mcnemar_power` sums it
    exactly over the trinomial model below (no simulation needed: the discordant counts are
    enumerable).  Model: each mutant independently is killed by strategy a only with probability
    ``reverse + difference``, by b only with ``reverse``, by both or neither otherwise.
    ``reverse`` (the discordance against the direction of the effect) is an assumption the plan
    states; the larger it is, the more mutants a difference needs.
Multiplicity
    Holm over the strategy pairs compared (``comparisons``): the plan uses Holm's first step,
    ``alpha / comparisons``, the level at which the pair with the smallest p value is judged --
    a conservative (Bonferroni) power for any one pair.
Repetitions K
    A case of a suite of ``n`` cases is judged at ``alpha / n`` (Holm's first step); the exact
    sign-flip test with K pairs attains ``sides * 2^-K`` at the smallest
    (:func:`faultlab.inference.exact.min_p_value`), so K is the smallest value with
    ``sides * 2^-K <= alpha / n`` (:func:`min_repetitions`).  A deterministic SLAM (``exact``) is
    judged exactly: each case runs once (K = 1) and any change of its map error kills; repeating
    it would give identical runs, not evidence.

Cost: every pool case runs once per variant (baseline, faults, mutants) with K repetitions
(strategies study), or every case of every suite once per mutant plus the baseline (mutation
study, an upper bound: early stopping skips cases of killed mutants).  Executions times the
measured seconds per execution gives CPU hours; a plan fits a budget of ``hours`` on ``cores``
when CPU hours <= hours * cores.  When the needed scale does not fit, :func:`plan_study` also
gives the largest scale that fits, chosen to minimise the larger of the two detectable
differences relative to its target, and the differences it can detect.

Split design (strategies study with faults and mutants): the two targets need different things --
the detection difference needs pool cases (it is judged per variant over the pool), the score
difference needs mutants (judged over mutants) -- so crossing them (every pool case runs every
mutant) pays for pool cases x mutants.  :attr:`StudyPlan.split` costs the alternative: a *fault
half* (the needed pools, baseline and faults) and a *mutant half* (pools of the largest suite
judged, the smallest that can draw it, baseline and the needed mutants), each a study of its own
with the same protocol and seed.  Its mutation-score power is the McNemar power over mutants, as
for the crossed design: neither plan models the spread that a small pool adds to a drawn suite's
score, which the study's bootstrap over cases measures (:func:`faultlab.stats.killmatrix.compare_scores`).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np
from scipy.optimize import brentq
from scipy.stats import binom

from faultlab.errors import ConfigError
from faultlab.inference.exact import min_p_value
from faultlab.vocabulary import DEFAULT_ALPHA, DEFAULT_POWER

__all__ = ["file_scale", "mutation_file_scale", "STUDY_KINDS", "StudyScale", "StudyPlan", "min_repetitions", "detection_power", "detectable_detection",
           "pool_for_detection", "mcnemar_power", "detectable_score", "mutants_for_score", "study_executions",
           "plan_study"]

#: The studies a plan is made for: the strategies study (pools, faults and mutants) and the
#: mutation study (suites of fixed size, mutants only).
STUDY_KINDS = ("strategies", "mutation")
_MAX_MUTANTS = 5000
_MAX_POOL = 5000


def _check_level(x: float, name: str) -> float:
    if not 0 < x < 1:
        raise ConfigError(f"study plan: {name} must lie in (0, 1), got {x!r}")
    return float(x)


def min_repetitions(n_cases: int, *, alpha: float = DEFAULT_ALPHA, sides: int = 2) -> int:
    """Smallest K at which one case of a family of ``n_cases`` can reject at ``alpha / n_cases``.

    The exact sign-flip test's smallest p value is ``sides * 2^-K``; K is the smallest with
    ``sides * 2^-K <= alpha / n_cases`` (e.g. 45 cases, two-sided: K = 11).
    """
    _check_level(alpha, "alpha")
    if sides not in (1, 2) or n_cases < 1:
        raise ConfigError(f"study plan: sides must be 1 or 2 and n_cases >= 1, got {sides!r}, {n_cases!r}")
    k = 0
    while sides * min_p_value(k) > alpha / n_cases:
        k += 1
    return k


def _h(difference: float, centre: float) -> float:
    hi, lo = centre + difference / 2, centre - difference / 2
    if lo < 0 or hi > 1:
        raise ConfigError(f"study plan: a difference of {difference} centred on {centre} leaves [0, 1]")
    return 2 * math.asin(math.sqrt(hi)) - 2 * math.asin(math.sqrt(lo))


def detection_power(n_a: int, n_b: int, difference: float, *, centre: float = 0.5, alpha: float = DEFAULT_ALPHA) -> float:
    """Power of the two-sided arcsine two-proportion test (statsmodels ``NormalIndPower``).

    Pools of ``n_a`` and ``n_b`` cases, detection probabilities ``centre +- difference / 2``,
    level ``alpha`` (already divided by the comparisons of the family).
    """
    from statsmodels.stats.power import NormalIndPower

    _check_level(alpha, "alpha")
    if n_a < 1 or n_b < 1:
        return 0.0
    return float(NormalIndPower().power(effect_size=_h(difference, centre), nobs1=n_a, ratio=n_b / n_a,
                                        alpha=alpha, alternative="two-sided"))


def detectable_detection(n: int, *, centre: float = 0.5, alpha: float = DEFAULT_ALPHA, power: float = DEFAULT_POWER) -> float:
    """Smallest difference (centred on ``centre``) two pools of ``n`` cases detect with ``power``.

    ``inf`` when even the largest difference that stays in [0, 1] is not detected.
    """
    _check_level(power, "power")
    widest = 2 * min(centre, 1 - centre)
    if n < 1 or detection_power(n, n, widest, centre=centre, alpha=alpha) < power:
        return math.inf
    return float(brentq(lambda d: detection_power(n, n, d, centre=centre, alpha=alpha) - power, 1e-9, widest,
                        xtol=1e-7))


def pool_for_detection(difference: float, *, centre: float = 0.5, alpha: float = DEFAULT_ALPHA, power: float = DEFAULT_POWER) -> int:
    """Smallest pool per strategy (equal pools) with which ``difference`` is detected with ``power``."""
    from statsmodels.stats.power import NormalIndPower

    _check_level(power, "power")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        n = float(NormalIndPower().solve_power(effect_size=_h(difference, centre), nobs1=None, ratio=1.0,
                                               alpha=alpha, power=power, alternative="two-sided"))
    n = max(1, math.ceil(n - 1e-9))
    while detection_power(n, n, difference, centre=centre, alpha=alpha) < power:   # guard the solver's rounding
        n += 1
    return n


def _critical(d: np.ndarray, alpha: float) -> np.ndarray:
    """Per discordant total D, the largest count c with 2 * P(Bin(D, 1/2) <= c) <= alpha (-1 if none)."""
    c = binom.ppf(alpha / 2, d, 0.5)
    c = np.where(2 * binom.cdf(c, d, 0.5) <= alpha, c, c - 1)
    return np.where(d > 0, c, -1).astype(np.int64)


def mcnemar_power(n_mutants: int, only_a: float, only_b: float, *, alpha: float = DEFAULT_ALPHA) -> float:
    """Exact power of the two-sided exact McNemar test over ``n_mutants`` independent mutants.

    Each mutant is killed by a only with probability ``only_a``, by b only with ``only_b``.  The
    discordant total is ``D ~ Bin(n_mutants, only_a + only_b)`` and, given D, a's count is
    ``Bin(D, only_a / (only_a + only_b))``; the test rejects when ``2 P(Bin(D, 1/2) <= min) <=
    alpha`` (statsmodels' exact McNemar p value).  The power is summed exactly over D.
    """
    _check_level(alpha, "alpha")
    disc = only_a + only_b
    if only_a < 0 or only_b < 0 or disc > 1:
        raise ConfigError(f"study plan: discordance rates {only_a!r}, {only_b!r} are not probabilities")
    if n_mutants < 1 or disc == 0:
        return 0.0
    d = np.arange(n_mutants + 1)
    c = _critical(d, alpha)
    q = only_a / disc
    low = np.where(c >= 0, binom.cdf(c, d, q), 0.0)                # a's count <= c
    high = np.where(c >= 0, binom.sf(d - c - 1, d, q), 0.0)         # a's count >= D - c
    return float(np.sum(binom.pmf(d, n_mutants, disc) * (low + high)))


def detectable_score(n_mutants: int, *, reverse: float = 0.05, alpha: float = DEFAULT_ALPHA, power: float = DEFAULT_POWER) -> float:
    """Smallest score difference the exact McNemar test detects with ``power`` over ``n_mutants``.

    ``reverse`` is the rate of mutants killed only by the weaker strategy; ``inf`` when no
    difference up to ``1 - 2 reverse`` reaches ``power``.
    """
    _check_level(power, "power")
    widest = 1 - 2 * reverse
    if n_mutants < 1 or mcnemar_power(n_mutants, reverse + widest, reverse, alpha=alpha) < power:
        return math.inf
    lo, hi = 0.0, widest
    while hi - lo > 1e-5:   # power grows with the difference at fixed n_mutants and reverse
        mid = (lo + hi) / 2
        lo, hi = (lo, mid) if mcnemar_power(n_mutants, reverse + mid, reverse, alpha=alpha) >= power else (mid, hi)
    return hi


def mutants_for_score(difference: float, *, reverse: float = 0.05, alpha: float = DEFAULT_ALPHA, power: float = DEFAULT_POWER,
                      window: int = 25) -> int:
    """Smallest number of mutants from which the exact McNemar test keeps ``power`` for ``difference``.

    The exact test's power is not monotone in the number of mutants (its attainable levels
    jump with the discordant total); the answer is the smallest ``M`` whose power and that of the
    next ``window`` values all reach ``power``, so adding a few mutants does not lose it.
    """
    _check_level(power, "power")
    ok_run, m = 0, 0
    while m < _MAX_MUTANTS:
        m += 1
        ok_run = ok_run + 1 if mcnemar_power(m, reverse + difference, reverse, alpha=alpha) >= power else 0
        if ok_run > window:
            return m - window
    raise ConfigError(f"study plan: no number of mutants up to {_MAX_MUTANTS} detects a score difference of "
                      f"{difference} with power {power}")


def study_executions(kind: str, *, strategies: int, cases: int, faults: int, mutants: int, repetitions: int,
                     runs: int = 1) -> int:
    """SLAM executions of a study at a scale.

    ``strategies``: cases = pool per strategy, every case runs baseline + faults + mutants.
    ``mutation``: ``runs`` suites of ``cases`` cases per strategy, baseline + mutants (an upper
    bound: the campaign stops a mutant's suite at its first kill).
    """
    if kind == "strategies":
        return strategies * cases * (1 + faults + mutants) * repetitions
    if kind == "mutation":
        return strategies * runs * cases * (1 + mutants) * repetitions
    raise ConfigError(f"study plan: unknown study kind {kind!r}; known: {', '.join(STUDY_KINDS)}")


@dataclass(frozen=True)
class StudyScale:
    """One scale of a study and what it can detect.

    Attributes
    ----------
    cases : int
        Pool cases per strategy (strategies study) or cases per suite (mutation study).
    largest_suite : int
        Largest suite judged (sets K): the study's largest size, or a smaller pool's size.
    mutants : int
    repetitions : int
        K per case.
    detection_pp, score_pp : float
        Smallest differences (percentage points) detected with the plan's power; NaN where the
        study makes no such comparison, inf where none is detectable.
    executions : int
    cpu_hours : float
    """

    cases: int
    largest_suite: int
    mutants: int
    repetitions: int
    detection_pp: float
    score_pp: float
    executions: int
    cpu_hours: float


#: The scales a plan tabulates: pool cases per strategy, mutants, assumed reverse discordance.
TABULATED_POOLS = (20, 50, 100, 150, 200)
TABULATED_MUTANTS = (50, 100, 150, 200, 300)
TABULATED_REVERSE = (0.0, 0.02, 0.05, 0.10)


@dataclass(frozen=True)
class StudyPlan:
    """The scale a study needs for its target differences, its cost, and the largest scale that fits.

    ``needed`` detects the targets; ``fitting`` is ``needed`` when it fits the budget, otherwise
    the largest scale that does (None when not even the smallest scale fits).
    """

    kind: str
    strategies: int
    faults: int
    runs: int
    comparisons: int
    alpha: float
    comparison_alpha: float
    case_family: int
    sides: int
    power: float
    target_detection_pp: float
    target_score_pp: float
    centre: float
    reverse: float
    seconds_per_execution: float
    budget_hours: float
    cores: int
    needed: StudyScale
    fitting: StudyScale | None
    exact: bool = False

    @property
    def fits(self) -> bool:
        return self.needed.cpu_hours <= self.budget_hours * self.cores

    @property
    def cluster_cores(self) -> int:
        """Cores that run the needed scale within the budget's hours."""
        return max(1, math.ceil(self.needed.cpu_hours / self.budget_hours))

    @property
    def split(self) -> tuple[StudyScale, StudyScale] | None:
        """The needed scale as a fault half and a mutant half (see the module docstring), or None
        for a mutation study, or a study without faults or without mutants."""
        need = self.needed
        if self.kind != "strategies" or self.faults < 1 or need.mutants < 1:
            return None
        small = need.largest_suite  # the smallest pool that can draw the largest suite judged
        common = dict(strategies=self.strategies, repetitions=need.repetitions, runs=self.runs,
                      seconds=self.seconds_per_execution, largest_suite=need.largest_suite)
        faults = _scale("strategies", cases=need.cases, faults=self.faults, mutants=0, det_pp=need.detection_pp,
                        score_pp=math.inf, **common)
        mutants = _scale("strategies", cases=small, faults=0, mutants=need.mutants, score_pp=need.score_pp,
                         det_pp=100 * detectable_detection(small, centre=self.centre, alpha=self.comparison_alpha,
                                                           power=self.power), **common)
        return faults, mutants

    @property
    def split_fits(self) -> bool:
        halves = self.split
        return halves is not None and sum(h.cpu_hours for h in halves) <= self.budget_hours * self.cores

    def detection_by_pool(self, pools=TABULATED_POOLS) -> list[tuple[int, float]]:
        """(pool cases per strategy, detectable single-case detection difference in pp) at the plan's
        comparison level and power."""
        return [(n, 100 * detectable_detection(n, centre=self.centre, alpha=self.comparison_alpha, power=self.power))
                for n in pools]

    def score_by_mutants(self, mutants=TABULATED_MUTANTS) -> list[tuple[int, float]]:
        """(mutants, detectable mutation-score difference in pp) at the plan's reverse discordance."""
        return [(m, 100 * detectable_score(m, reverse=self.reverse, alpha=self.comparison_alpha, power=self.power))
                for m in mutants]

    def mutants_by_reverse(self, reverse=TABULATED_REVERSE) -> list[tuple[float, int]]:
        """(assumed reverse discordance, mutants needed for the target score difference)."""
        return [(r, mutants_for_score(self.target_score_pp / 100, reverse=r, alpha=self.comparison_alpha,
                                      power=self.power)) for r in reverse]


def _scale(kind, *, strategies, cases, faults, mutants, repetitions, runs, seconds, det_pp, score_pp,
           largest_suite) -> StudyScale:
    n = study_executions(kind, strategies=strategies, cases=cases, faults=faults, mutants=mutants,
                         repetitions=repetitions, runs=runs)
    largest = min(cases, largest_suite) if kind == "strategies" else cases
    return StudyScale(cases=cases, largest_suite=largest, mutants=mutants, repetitions=repetitions, detection_pp=det_pp, score_pp=score_pp,
                      executions=n, cpu_hours=n * seconds / 3600)


def plan_study(kind: str, *, strategies: int, faults: int = 0, suite_cases: int = 5, max_suite: int = 20,
               runs: int = 1, target_detection: float = 0.20, target_score: float = 0.10, power: float = DEFAULT_POWER,
               alpha: float = DEFAULT_ALPHA, sides: int = 2, centre: float = 0.5, reverse: float = 0.05,
               seconds_per_execution: float, budget_hours: float = 3.0, cores: int = 2,
               exact: bool = False) -> StudyPlan:
    """The scale a study needs, its cost and, if it does not fit, the largest scale that does.

    Parameters
    ----------
    kind : {"strategies", "mutation"}
    strategies : int
        Strategies compared (>= 2); the family is every pair, Holm over them.
    faults : int
        Built-in faults every pool case runs (strategies study).
    suite_cases : int
        Cases per suite (mutation study; the paper's suites have 5).
    max_suite : int
        Largest suite judged (strategies study: the largest size drawn from a pool, or a whole
        generated suite): sets K and the smallest pool.
    runs : int
        Evaluation runs (mutation study).
    target_detection, target_score : float
        Differences to detect (fractions: 0.2 = 20 pp).
    power, alpha : float
    sides : {1, 2}
        Sidedness of the per-case sign-flip verdict (sets K).
    centre : float
        Detection probability around which the planned difference lies.
    reverse : float
        Assumed rate of mutants killed only by the weaker strategy.
    seconds_per_execution : float
        Measured cost of one SLAM execution at the study's settings.
    budget_hours, cores : float, int
        The budget: ``budget_hours`` of wall time on ``cores``.
    exact : bool
        The SLAM is deterministic and judged exactly (mutation study only): K = 1.
    """
    if kind not in STUDY_KINDS:
        raise ConfigError(f"study plan: unknown study kind {kind!r}; known: {', '.join(STUDY_KINDS)}")
    if strategies < 2:
        raise ConfigError(f"study plan: a comparison needs two strategies, got {strategies}")
    if not seconds_per_execution > 0 or not budget_hours > 0 or cores < 1:
        raise ConfigError("study plan: seconds per execution, budget hours and cores must be positive")
    _check_level(power, "power")
    comparisons = strategies * (strategies - 1) // 2
    a = _check_level(alpha, "alpha") / comparisons
    family = max_suite if kind == "strategies" else suite_cases
    if exact and kind != "mutation":
        raise ConfigError("study plan: exact judgement (K = 1) is planned for a mutation study only")
    k = 1 if exact else min_repetitions(family, alpha=alpha, sides=sides)
    m_need = mutants_for_score(target_score, reverse=reverse, alpha=a, power=power)
    common = dict(strategies=strategies, faults=faults, repetitions=k, runs=runs, seconds=seconds_per_execution,
                  largest_suite=max_suite)

    def det(n):
        return 100 * detectable_detection(n, centre=centre, alpha=a, power=power) if kind == "strategies" else math.nan

    def sc(m):
        return 100 * detectable_score(m, reverse=reverse, alpha=a, power=power)

    if kind == "strategies":
        n_need = max(max_suite, pool_for_detection(target_detection, centre=centre, alpha=a, power=power))
    else:
        n_need = suite_cases
    needed = _scale(kind, cases=n_need, mutants=m_need, det_pp=det(n_need), score_pp=sc(m_need), **common)
    budget = budget_hours * cores
    fitting = needed if needed.cpu_hours <= budget else _largest_fitting(kind, n_need, m_need, budget, det, sc,
                                                                          target_detection, target_score,
                                                                          max_suite, suite_cases, sides, alpha,
                                                                          common, exact=exact)
    return StudyPlan(kind=kind, strategies=strategies, faults=faults, runs=runs, comparisons=comparisons, alpha=alpha,
                     comparison_alpha=a, case_family=family, sides=sides, power=power,
                     target_detection_pp=100 * target_detection, target_score_pp=100 * target_score, centre=centre,
                     reverse=reverse, seconds_per_execution=seconds_per_execution, budget_hours=budget_hours,
                     cores=cores, needed=needed, fitting=fitting, exact=exact)


def file_scale(plan: StudyPlan, *, pools, mutants: int, repetitions: int, largest_suite: int) -> StudyScale:
    """The scale a strategies study file actually sets, costed and powered like ``plan``'s scales.

    Parameters
    ----------
    plan : StudyPlan
        Gives the comparison level, power, centre, reverse discordance and cost per execution.
    pools : sequence of int
        Pool cases of every strategy (they may differ); every pool case runs the baseline, the
        plan's faults and ``mutants``, ``repetitions`` times each.
    mutants, repetitions, largest_suite : int

    Returns
    -------
    StudyScale
        ``cases`` is the smallest pool, whose detectable difference is stated (the largest of any
        pair); the executions count every pool.
    """
    pools = [int(n) for n in pools]
    if plan.kind != "strategies" or len(pools) < 2 or min(pools) < 1:
        raise ConfigError("study plan: a file's scale is that of a strategies study with two or more pools")
    n = min(pools)
    det = 100 * detectable_detection(n, centre=plan.centre, alpha=plan.comparison_alpha, power=plan.power)
    score = (100 * detectable_score(mutants, reverse=plan.reverse, alpha=plan.comparison_alpha, power=plan.power)
             if mutants > 0 else math.inf)
    executions = sum(pools) * (1 + plan.faults + int(mutants)) * int(repetitions)
    return StudyScale(cases=n, largest_suite=int(largest_suite), mutants=int(mutants), repetitions=int(repetitions),
                      detection_pp=det, score_pp=score, executions=executions,
                      cpu_hours=executions * plan.seconds_per_execution / 3600)


def mutation_file_scale(plan: StudyPlan, *, mutants: int) -> StudyScale:
    """The scale a mutation study file sets with ``mutants`` live mutants (its sample budget), costed
    and powered like ``plan``'s scales (the plan's cases per suite, runs and K)."""
    if plan.kind != "mutation" or isinstance(mutants, bool) or int(mutants) < 1:
        raise ConfigError("study plan: a mutation file's scale needs a mutation plan and at least one mutant")
    need = plan.needed
    return _scale("mutation", strategies=plan.strategies, cases=need.cases, faults=0, mutants=int(mutants),
                  repetitions=need.repetitions, runs=plan.runs, seconds=plan.seconds_per_execution,
                  det_pp=math.nan, largest_suite=need.largest_suite,
                  score_pp=100 * detectable_score(int(mutants), reverse=plan.reverse, alpha=plan.comparison_alpha,
                                                  power=plan.power))


def _largest_fitting(kind, n_need, m_need, budget, det, sc, target_detection, target_score, max_suite, suite_cases,
                     sides, alpha, common, exact=False) -> StudyScale | None:
    """Among the scales within the budget, the one whose worse detectable difference, relative to its
    target, is smallest; ties (e.g. no affordable number of mutants detects any score difference) go to
    the smaller detectable detection difference, then to fewer executions.  A strategies pool smaller
    than ``max_suite`` draws suites of at most its own size, which lowers K."""
    seconds = common["seconds"]
    cap = budget * 3600 / seconds
    pools = range(2, n_need + 1) if kind == "strategies" else [suite_cases]
    best, best_key = None, None
    sc_cache: dict = {}
    for n in pools:
        k = 1 if exact else min_repetitions(min(max_suite, n) if kind == "strategies" else n, alpha=alpha,
                                            sides=sides)
        args = dict(strategies=common["strategies"], cases=n, faults=common["faults"], repetitions=k,
                    runs=common["runs"])
        fixed = study_executions(kind, **args, mutants=0)
        per_mutant = study_executions(kind, **args, mutants=1) - fixed
        m = min(m_need, math.floor((cap - fixed) / per_mutant))
        if m < 0:
            continue
        if m not in sc_cache:
            sc_cache[m] = sc(m) if m > 0 else math.inf
        d = det(n)
        det_ratio = d / (100 * target_detection) if kind == "strategies" else 0.0
        key = (max(det_ratio, sc_cache[m] / (100 * target_score)), det_ratio, fixed + per_mutant * m)
        if best_key is None or key < best_key:
            best_key, best = key, (n, m, k, d, sc_cache[m])
    if best is None:
        return None
    n, m, k, d, s = best
    return _scale(kind, cases=n, mutants=m, det_pp=d, score_pp=s, **(common | {"repetitions": k}))
