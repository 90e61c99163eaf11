"""A mutation campaign of the reference FastSLAM: the mutants run with early stopping and statistical kills.

A mutation experiment is an ordinary experiment file plus a ``[mutation]`` table selecting the
mutants (``units``, ``operators``, ``ids``, ``sample``, ``seed``; all optional: every live
mutant), the family-wise level ``alpha`` (default :data:`~faultlab.vocabulary.DEFAULT_ALPHA`) and
the ``direction`` of the kill test (``"either"``, two-sided, default: a mutant is killed when its
map error changes, worse or better; ``"worse"``: the paper's one-sided notion).  Its variants are ``baseline`` and
``mutant:<id>`` for every selected live mutant (:mod:`faultlab.mutation.variants`); the campaign
is stored in the runner's results store (:class:`~faultlab.runner.store.ResultStore`), one row
per job, seeds as in any campaign (repetition k of a case uses the same SLAM seed for every
variant: common random numbers), so it resumes like ``faultlab run``.  Stillborn and equivalent
mutants never run; a duplicate is represented by the mutant it duplicates.

Statistical kill.  A *suite* is one (run, suite kind) with ``n`` cases.  A mutant is killed on a
case when the exact paired sign-flip test of :func:`faultlab.stats.verdict.case_verdicts`
(K repetitions, CRN pairs) rejects at ``alpha / n``, or when the mutant alone fails (crash or
timeout with the baseline usable: class ``crash``/``timeout``).  A mutant is killed by the suite
when some case kills it (:func:`faultlab.stats.killmatrix.suite_kills`).  The cases run in a fixed order, in rounds (case 1 of every suite,
then case 2, ...), and a mutant killed by a suite does not run its remaining cases (early
stopping).  Multiplicity: Bonferroni over the suite's cases.  Because the per-case level
``alpha / n`` does not depend on what was observed, the probability that a mutant with no effect
on the error is called killed is at most the sum of the levels of the cases actually tested, at
most ``alpha``, whatever the stopping; Holm's step-down would need every case's p value and is
not valid once cases are skipped.  K must be at least ``min_pairs(alpha / n)`` for the test's
sidedness (two-sided: one more than one-sided).

A mutant that survives a suite comes with the smallest shift of the mean map error it could
have detected (at :data:`~faultlab.vocabulary.DEFAULT_POWER`): the smallest per-case detectable shift ``mde_mm`` of the suite's
cases (estimated from the baseline's spread, :func:`~faultlab.stats.verdict.case_verdicts`).

Adaptive repetitions.  An ``[adaptive]`` table (``stages``, cumulative, the last equal to
``repetitions``; ``futility``, default 0.5; :class:`~faultlab.inference.sequential.StagedDesign`) runs
the K repetitions of each case round in stages, with the rule of
:mod:`faultlab.inference.sequential` (:func:`~faultlab.inference.sequential.interim_look`).  Stage 1 runs
the first ``stages[0]`` repetitions of the case's baseline and of every mutant the suite has not
killed.  Before each later stage, every (case, mutant) pair still running is looked at, from its
stored repetitions alone: it stops when the baseline failed, when the fixed-K test can no longer
reject (curtailment), or when its interim p value exceeds the futility bound; a pair whose mutant
failed (crash/timeout) continues.  The look uses exactly the kill test's level and sidedness:
``alpha / n`` of the case's suite and two-sided for ``direction = "either"``, ``"greater"`` for
``"worse"``.  The table's ``level`` and ``alternative`` are therefore derived (an explicit value
that differs is refused).  A later stage runs only the pairs still running and their case's
baseline, repetition by repetition (common random numbers).  The rule never stops with a
rejection, so the kill level stays the fixed-K test's; a futility stop can only lose kills
(power), and a stopped pair forgoes observing a mutant crash in its remaining repetitions.  With
``futility = 1`` only curtailment stops and every test decision equals the fixed-K one.

After the round the kills are the fixed-K kill test on the stored rows
(:func:`~faultlab.stats.killmatrix.suite_kills` with the round's stops): a stopped pair is
"not killed" on that case (its stored p value cannot reach the level), its verdict reason names
why it stopped, and its smallest detectable shift is computed from the pairs it actually used.
The stops are recorded in the store's metadata under :data:`~faultlab.runner.staging.STOPS_KEY`
(run, suite, case, variant, repetitions used, reason) as ``faultlab run`` records them; every
decision depends only on stored rows, so a campaign resumed after a kill, or rerun from the same
seed, reaches the same stops and the same rows.

The campaign's outcomes, scores and suite comparisons are computed from its store by
:func:`faultlab.analysis.mutation.analyse_mutation`.
"""

from __future__ import annotations

import dataclasses
import json
import math
import time
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from faultlab.config import read_toml
from faultlab.data import resolve_experiment
from faultlab.errors import ConfigError, FaultError, ResultsError
from faultlab.mutation.sourceselect import mutant_records, sample_order, screen_target, select_source_mutants
from faultlab.mutation.target import generate_source_mutants, parse_target
from faultlab.mutation.variants import MutantSelection, mutant_variant, select_mutants
from faultlab.runner import (Experiment, ResultStore, batch_jobs, check_backend, expand_jobs, load_results, parse_experiment,
                             prepare_cases, result_row, store_session, stream_results)
from faultlab.runner.progress import progress as show_progress
from faultlab.runner.staging import STOPS_KEY, look_before_stage, record_stops, stage_jobs
from faultlab.runner.store import (MUTANTS_FILE, MUTATION_FILE, check_store, job_metrics, load_metadata, results_path,
                                   store_lock)
from faultlab.scenario.suite import draw_suite, generate_case
from faultlab.seeds import slam_seed
from faultlab.stats.exactkill import exact_kills
from faultlab.stats.killmatrix import suite_kills
from faultlab.inference.sequential import StagedDesign
from faultlab.inference.exact import alternative_of, min_pairs
from faultlab.vocabulary import BASELINE, DEFAULT_ALPHA, DEFAULT_DIRECTION, DIRECTIONS

__all__ = ["MUTATION_FILE", "MUTANTS_FILE", "MutationExperiment", "MutationRun", "load_mutation_experiment", "parse_selector",
           "selection_from_table", "run_mutation"]

_MUTATION_KEYS = ("units", "operators", "ids", "sample", "seed", "alpha", "direction", "target", "functions", "lines",
                  "probes", "reuse")
#: Keys of a ``[mutation]`` table that only a campaign on faultlab's own units takes / only one on a target.
_UNIT_KEYS = ("units", "ids")
_TARGET_KEYS = ("functions", "lines", "probes", "reuse")
#: Probe scenarios a target's mutants are screened on, by default.
DEFAULT_PROBES = 3
#: Kill criteria: the exact paired sign-flip test over K repetitions, or exact comparison (K = 1).
KILL_SIGN_FLIP = "sign_flip"
KILL_EXACT = "exact"


@dataclass(frozen=True)
class MutationExperiment:
    """An experiment whose variants are baseline and the selected live mutants, with the selection."""

    experiment: Experiment
    selection: MutantSelection
    alpha: float = DEFAULT_ALPHA
    direction: str = DEFAULT_DIRECTION
    kill: str = KILL_SIGN_FLIP
    fixed_case_alpha: float | None = None
    records: dict | None = None

    def case_alpha(self, n_cases: int) -> float:
        """The level a case is judged at: ``alpha / n_cases`` (Bonferroni over the suite) for faultlab's
        units; for a target, one level for every case, ``alpha`` over the largest suite, so a suite's
        kill never depends on its size (adding a case never un-kills)."""
        return self.fixed_case_alpha if self.fixed_case_alpha is not None else self.alpha / n_cases

    def case_design(self, n_cases: int) -> StagedDesign | None:
        """The staged design of a suite of ``n_cases`` cases (None without ``[adaptive]``): the
        experiment's stages and futility bound at the kill test's level ``alpha / n_cases`` and
        sidedness."""
        design = self.experiment.adaptive
        if design is None:
            return None
        return _suite_design(design, level=self.case_alpha(n_cases), alternative=alternative_of(self.direction),
                             where=f"{self.experiment.source}: adaptive")


def parse_selector(text: str) -> dict:
    """``--mutants`` text -> ``[mutation]`` keys: ``all``, or comma-separated ``unit=U``,
    ``operator=O``, ``sample=N`` and mutant ids (e.g. ``unit=motion_model,operator=arithmetic``)."""
    out: dict = {}
    if text.strip() in ("", "all"):
        return out
    for item in (t.strip() for t in text.split(",") if t.strip()):
        key, eq, value = item.partition("=")
        if not eq:
            out.setdefault("ids", []).append(item)
        elif key in ("unit", "operator"):
            out.setdefault(key + "s", []).append(value)
        elif key == "sample":
            out["sample"] = int(value)
        else:
            raise ConfigError(f"--mutants: unknown selector {key!r} in {item!r} (use unit=, operator=, sample= "
                              f"or mutant ids)")
    return out


def load_mutation_experiment(path: str | Path, *, mutants: str | None = None, repetitions: int | None = None,
                             target: str | None = None, slam: str | None = None, reuse: str | Path | None = None,
                             jobs: int = 1, screen: bool = True) -> MutationExperiment:
    """Read a mutation experiment file (or a shipped one by name, e.g. ``mutation``).

    ``mutants`` (a :func:`parse_selector` text) replaces the file's selection; ``repetitions``
    its K; ``target`` the ``[mutation]`` target (user code, :func:`~faultlab.mutation.target.parse_target`);
    ``slam`` the ``[slam]`` name (the factory that runs the target); ``reuse`` the ``[mutation]``
    reuse directory.  A campaign on a target screens its mutants here (``jobs`` processes; cached);
    ``screen=False`` skips that (and the selection: only the baseline), for what needs the
    experiment's settings alone (a power plan).
    ConfigError naming the file and key for anything malformed.
    """
    file = resolve_experiment(path, what="mutation experiment file")
    data, text = read_toml(file, what="mutation experiment file")
    data = dict(data)
    table = dict(data.pop("mutation", {}) or {})
    unknown = set(table) - set(_MUTATION_KEYS)
    if unknown:
        raise ConfigError(f"{path}: [mutation]: unknown key(s) {sorted(unknown)}; known: {', '.join(_MUTATION_KEYS)}")
    if mutants is not None:
        table = {k: v for k, v in table.items() if k in ("seed", "alpha", "direction", *_TARGET_KEYS[:3], "target",
                                                         "reuse")} | parse_selector(mutants)
    if target is not None:
        table["target"] = target
    if reuse is not None:
        table["reuse"] = str(reuse)
    if slam is not None:
        data["slam"] = dict(data.get("slam") or {}) | {"name": slam}
    if repetitions is not None:
        data["repetitions"] = repetitions
    if "target" in table:
        return _load_target_experiment(path, data, text, table, jobs=jobs, screen=screen)
    extra = sorted(set(table) & set(_TARGET_KEYS))
    if extra:
        raise ConfigError(f"{path}: [mutation]: {', '.join(extra)} need a target (user code to mutate)")
    alpha = float(table.get("alpha", DEFAULT_ALPHA))
    if not 0 < alpha < 1:
        raise ConfigError(f"{path}: [mutation].alpha must lie in (0, 1), got {alpha}")
    direction = table.get("direction", DEFAULT_DIRECTION)
    if direction not in DIRECTIONS:
        raise ConfigError(f"{path}: [mutation].direction must be one of {', '.join(map(repr, DIRECTIONS))}, "
                          f"got {direction!r}")
    selection = selection_from_table({k: v for k, v in table.items() if k != "direction"}, source=str(path))
    if "variants" in data:
        raise ConfigError(f"{path}: variants: a mutation experiment's variants come from [mutation]")
    data["variants"] = [BASELINE, *map(mutant_variant, selection.run)]
    if data.get("adaptive") is not None:
        data["adaptive"] = _adaptive_table(data["adaptive"], data.get("suites"), alpha=alpha, direction=direction,
                                           where=f"{path}: adaptive")
    exp = parse_experiment(data, source=str(path), text=text)
    mexp = MutationExperiment(experiment=exp, selection=selection, alpha=alpha, direction=direction)
    alternative = alternative_of(direction)
    for s in exp.suites:
        n = s.n_cases
        if n is not None and exp.repetitions < min_pairs(mexp.case_alpha(n), alternative=alternative):
            raise ConfigError(f"{path}: repetitions = {exp.repetitions} is too few: with alpha = {alpha} over "
                              f"{n} cases of suite {s.kind!r} a case is judged at {alpha / n:.4g}, which the exact "
                              f"{alternative} sign-flip test reaches only from K = "
                              f"{min_pairs(alpha / n, alternative=alternative)}")
        if n is not None:
            mexp.case_design(n)  # the futility bound must lie in [level, 1] at every suite's level
    return mexp


def _probes(exp: Experiment, n: int) -> tuple[list, list[int], str]:
    """``n`` probe scenarios drawn like a random suite in run 0 (no evaluation run uses it), their
    SLAM seeds, and a key naming them."""
    if isinstance(n, bool) or not isinstance(n, int) or n < 1:
        raise ConfigError(f"{exp.source}: [mutation].probes must be an integer >= 1, got {n!r}")
    cases = draw_suite("random", exp.parameter_space(), root_seed=exp.seed, run=0, n_cases=n)
    scenarios = [generate_case(c, n_steps=exp.n_steps, sensor_range=exp.sensor_range, min_distance=exp.min_distance,
                               fov_bug=exp.fov_bug) for c in cases]
    seeds = [slam_seed(exp.seed, 0, "probe", c.case, 0) for c in cases]
    key = json.dumps([exp.seed, n, exp.n_steps, exp.sensor_range, exp.min_distance, exp.fov_bug, exp.space],
                     sort_keys=True, default=str)
    return scenarios, seeds, key


def _comparable(experiment: dict) -> dict:
    """An experiment as its store records it (canonical form), less what a rerun may change."""
    return {k: v for k, v in experiment.items() if k not in ("description", "variants")}


def _reuse_map(exp: Experiment, reuse, *, where: str) -> dict:
    """Mutant id -> the earlier campaign directory whose verdict it can reuse (same experiment otherwise)."""
    if not reuse:
        return {}
    prev = Path(reuse)
    try:
        sel = json.loads((prev / MUTATION_FILE).read_text())
        meta = load_metadata(prev)
    except (OSError, ValueError, ResultsError) as exc:
        raise ConfigError(f"{where}: reuse = {str(prev)!r} is not a finished mutation campaign ({exc})") from None
    old = _comparable(dict(meta.get("experiment") or {}))
    new = _comparable(json.loads(exp.canonical_json()))
    differ = sorted(k for k in set(old) | set(new) if old.get(k) != new.get(k))
    if differ:
        raise ConfigError(f"{where}: reuse = {str(prev)!r} ran another experiment (differs in {', '.join(differ)}); "
                          f"its verdicts cannot be reused")
    out = {i: str(prev) for i in sel.get("run", [])}
    out.update({i: d for i, d in (sel.get("reused") or {}).items()})
    return out


def _load_target_experiment(path, data: dict, text: str, table: dict, *, jobs: int,
                            screen: bool = True) -> MutationExperiment:
    """A mutation experiment on user code (``[mutation].target``): mutants generated from the target's
    source, screened on probes, sampled, reused; exact kills for K = 1 (a deterministic SLAM)."""
    where = f"{path}: [mutation]"
    extra = sorted(set(table) & set(_UNIT_KEYS))
    if extra:
        raise ConfigError(f"{where}: {', '.join(extra)} select faultlab's own units; with a target use functions "
                          f"and lines")
    if "variants" in data:
        raise ConfigError(f"{path}: variants: a mutation experiment's variants come from [mutation]")
    alpha = float(table.get("alpha", DEFAULT_ALPHA))
    if not 0 < alpha < 1:
        raise ConfigError(f"{where}.alpha must lie in (0, 1), got {alpha}")
    direction = table.get("direction", DEFAULT_DIRECTION)
    if direction not in DIRECTIONS:
        raise ConfigError(f"{where}.direction must be one of {', '.join(map(repr, DIRECTIONS))}, got {direction!r}")
    if data.get("adaptive") is not None:
        raise ConfigError(f"{path}: [adaptive] is not supported for a campaign on a target")
    exp0 = parse_experiment(dict(data) | {"variants": [BASELINE]}, source=str(path), text=text)
    if ":" not in exp0.slam.name:
        raise ConfigError(f"{path}: [slam].name = {exp0.slam.name!r}: a campaign on a target needs the factory that "
                          f"runs it, as package.module:factory")
    kill = KILL_EXACT if exp0.repetitions == 1 else KILL_SIGN_FLIP
    n_max = max((s.n_cases for s in exp0.suites if s.n_cases is not None), default=1)
    alternative = alternative_of(direction)
    if kill == KILL_SIGN_FLIP and exp0.repetitions < min_pairs(alpha / n_max, alternative=alternative):
        raise ConfigError(f"{path}: repetitions = {exp0.repetitions} is too few: a case is judged at alpha / "
                          f"{n_max} = {alpha / n_max:.4g}, which the exact {alternative} sign-flip test reaches only "
                          f"from K = {min_pairs(alpha / n_max, alternative=alternative)}; a deterministic SLAM "
                          f"runs with repetitions = 1 and is judged exactly")
    target = parse_target(table["target"], functions=table.get("functions", ()), lines=table.get("lines", ()),
                          where=f"{where}.target")
    if not screen:
        return MutationExperiment(experiment=exp0, selection=MutantSelection((), {}, {}, {}, {}), alpha=alpha,
                                  direction=direction, kill=kill, fixed_case_alpha=alpha / n_max)
    operators = table.get("operators")
    try:
        mutants = generate_source_mutants(target, operators=operators)
    except FaultError as exc:
        raise ConfigError(f"{where}.operators: {exc}") from None
    if not len(mutants):
        raise ConfigError(f"{where}: target {target} has no mutation point (functions skipped: "
                          f"{mutants.skipped or 'none'})")
    reuse = _reuse_map(exp0, table.get("reuse"), where=where)
    scenarios, seeds, probe_key = _probes(exp0, table.get("probes", DEFAULT_PROBES))
    sample = table.get("sample")
    try:
        order = sample_order(mutants, sample=sample, seed=int(table.get("seed", 0)))
    except ConfigError as exc:
        raise ConfigError(f"{path}: {exc}") from None
    screening = screen_target(mutants, exp0.slam, scenarios, seeds, probe_key=probe_key, order=order, budget=sample,
                              jobs=jobs)
    selection = select_source_mutants(mutants, screening, sample=sample, reuse=reuse)
    if not selection.run and not selection.reused:
        raise ConfigError(f"{where} selects no live mutant of {target}")
    exp = parse_experiment(dict(data) | {"variants": [BASELINE, *map(mutant_variant, selection.run)]},
                           source=str(path), text=text)
    mexp = MutationExperiment(experiment=exp, selection=selection, alpha=alpha, direction=direction, kill=kill,
                              fixed_case_alpha=alpha / n_max, records=mutant_records(mutants, screening))
    return mexp


def _suite_design(design: StagedDesign, *, level: float, alternative: str, where: str) -> StagedDesign:
    try:
        return dataclasses.replace(design, level=level, alternative=alternative)
    except ConfigError as exc:
        raise ConfigError(f"{where}: {exc}") from None


def _adaptive_table(table, suites, *, alpha: float, direction: str, where: str):
    """The ``[adaptive]`` table with ``level`` and ``alternative`` those of the kill test.

    The per-case level is ``alpha / n`` of each suite; the table records the smallest (a suite
    with fewer cases looks at its own, larger level: :meth:`MutationExperiment.case_design`).  An
    explicit ``level`` must equal every suite's per-case level, an explicit ``alternative`` the
    direction's sidedness.
    """
    if not isinstance(table, dict):
        return table  # parse_experiment names the type error
    table = dict(table)
    alternative = alternative_of(direction)
    if "alternative" in table and table["alternative"] != alternative:
        raise ConfigError(f"{where}.alternative = {table['alternative']!r} contradicts [mutation].direction = "
                          f"{direction!r}, whose kill test is {alternative}; omit it (it is derived)")
    counts = sorted({int(n) for n in (suites or {}).values() if isinstance(n, int) and not isinstance(n, bool)
                     and n >= 1}) if isinstance(suites, dict) else []
    levels = [alpha / n for n in counts]
    if "level" in table:
        level = table["level"]
        if (isinstance(level, bool) or not isinstance(level, (int, float))
                or not levels or any(not math.isclose(level, lv, rel_tol=1e-9) for lv in levels)):
            want = " and ".join(f"{lv:.4g} (alpha / {n})" for lv, n in zip(levels, counts)) or "alpha / n"
            raise ConfigError(f"{where}.level = {level!r} differs from the kill test's per-case level {want} "
                              f"(alpha = {alpha} Bonferroni-split over a suite's cases); omit it (it is derived)")
    table["level"] = min(levels) if levels else alpha
    table["alternative"] = alternative
    return table


def selection_from_table(table: dict, *, source: str) -> MutantSelection:
    """The mutants a ``[mutation]`` table selects (``units``, ``operators``, ``ids``, ``sample``,
    ``seed``; see :func:`~faultlab.mutation.variants.select_mutants`); ConfigError if none is live."""
    unknown = set(table) - set(_MUTATION_KEYS)
    if unknown:
        raise ConfigError(f"{source}: [mutation]: unknown key(s) {sorted(unknown)}; known: {', '.join(_MUTATION_KEYS)}")
    try:
        selection = select_mutants(units=table.get("units"), operators=table.get("operators"), ids=table.get("ids"),
                                   sample=table.get("sample"), seed=int(table.get("seed", 0)))
    except ConfigError as exc:
        raise (exc if str(exc).startswith(f"{source}:") else ConfigError(f"{source}: {exc}")) from None
    if not selection.run:
        raise ConfigError(f"{source}: [mutation] selects no live mutant")
    return selection


@dataclass(frozen=True)
class MutationRun:
    """What :func:`run_mutation` did."""

    out: Path
    n_mutants: int
    n_jobs_max: int
    n_jobs_run: int
    n_new: int
    n_skipped_early: int
    wall_time_s: float
    n_saved_adaptive: int = 0
    n_stops: int = 0

    def __str__(self) -> str:
        adaptive = (f", {self.n_saved_adaptive} saved by adaptive repetitions ({self.n_stops} (case, mutant) "
                    f"pair(s) stopped early)" if self.n_stops or self.n_saved_adaptive else "")
        return (f"{self.n_mutants} mutants: {self.n_jobs_run} of at most {self.n_jobs_max} jobs needed "
                f"({self.n_skipped_early} skipped by early stopping{adaptive}), {self.n_new} run now, "
                f"{self.wall_time_s:.0f} s; results in {self.out}")


def _n_cases(cases) -> dict:
    n: dict = {}
    for c in cases:
        n[(c.run, c.suite)] = max(n.get((c.run, c.suite), 0), c.case)
    return n


def run_mutation(mexp: MutationExperiment | str | Path, out: str | Path, *, jobs: int = 2, backend: str = "loky",
                 force_new: bool = False, progress: bool = True) -> MutationRun:
    """Run (or resume) a mutation campaign with early stopping (see the module docstring)."""
    if not isinstance(mexp, MutationExperiment):
        mexp = load_mutation_experiment(mexp)
    exp = mexp.experiment
    if isinstance(jobs, bool) or not isinstance(jobs, int) or jobs < 1:
        raise ConfigError(f"jobs must be an integer >= 1, got {jobs!r}")
    check_backend(backend, jobs=jobs)
    t0 = time.perf_counter()
    out = Path(out)
    n_new = 0
    _check_level(out, mexp, force_new=force_new)
    check_store(out, exp, force_new=force_new)  # a refusal writes nothing, not even the lock file
    with store_lock(out), ResultStore.open(out, exp, force_new=force_new) as store:
        (out / MUTATION_FILE).write_text(json.dumps(_selection_json(mexp), indent=1))
        if mexp.records is not None:
            (out / MUTANTS_FILE).write_text(json.dumps(mexp.records, indent=1))
        cases = prepare_cases(exp, out)
        info = {(c.run, c.suite, c.case): c for c in cases}
        n_cases = _n_cases(cases)
        designs = {rs: mexp.case_design(n) for rs, n in n_cases.items()}
        specs = expand_jobs(exp, ((c.run, c.suite, c.case, c.path, c.cost) for c in cases),
                            metrics=job_metrics(exp.metrics, store.meta))
        by_case: dict = {}
        for s in specs:
            by_case.setdefault((s.key.run, s.key.suite, s.key.case), []).append(s)
        killed: dict = {rs: set() for rs in n_cases}
        stopped: dict = {}  # (run, suite, case, variant) -> why the pair stopped early
        n_needed = n_full = 0
        n_stages = 1 if exp.adaptive is None else len(exp.adaptive.stages)
        for r in range(1, max(n_cases.values()) + 1):
            round_specs = []
            for (run, suite), n in n_cases.items():
                if r > n or (mexp.selection.run and len(killed[(run, suite)]) == len(mexp.selection.run)):
                    continue  # no case left, or every mutant killed: the baseline is not needed either
                for s in by_case[(run, suite, r)]:
                    if s.key.variant in killed[(run, suite)]:
                        continue
                    round_specs.append(s)
            n_full += len(round_specs)
            running = None
            for stage in range(n_stages):
                if stage > 0:
                    running = _look(store, out, round_specs, designs, stage=stage, metric=exp.metric,
                                    running=running, stopped=stopped)
                todo_specs = (round_specs if exp.adaptive is None
                              else stage_jobs(round_specs, design=exp.adaptive, stage=stage, running=running))
                n_needed += len(todo_specs)
                desc = f"faultlab mutate case {r}" + (f" stage {stage + 1}/{n_stages}" if n_stages > 1 else "")
                n_new += _run_round(store, todo_specs, info, jobs=jobs, backend=backend, progress=progress, desc=desc)
            df = load_results(out)
            df = df[df["case"] == r]
            for (run, suite), n in n_cases.items():
                if r > n:
                    continue
                part = df[(df["run"] == run) & (df["suite"] == suite)]
                if part.empty:
                    continue
                k = (exact_kills(part, metric=exp.metric) if mexp.kill == KILL_EXACT else
                     suite_kills(part, case_alpha=mexp.case_alpha(n), metric=exp.metric, direction=mexp.direction,
                                 stopped=stopped))
                killed[(run, suite)].update(k.loc[k["kill"] != "", "fault"])
    return MutationRun(out=out, n_mutants=len(mexp.selection.run), n_jobs_max=len(specs), n_jobs_run=n_needed,
                       n_new=n_new, n_skipped_early=len(specs) - n_full, wall_time_s=time.perf_counter() - t0,
                       n_saved_adaptive=n_full - n_needed, n_stops=len(stopped))


def _look(store, out: Path, round_specs: list, designs: dict, *, stage: int, metric: str,
          running: set | None, stopped: dict) -> set:
    """The interim look before ``stage`` of a case round, suite by suite at its own per-case level:
    records the new stops (store metadata :data:`STOPS_KEY` and ``stopped``) and returns the
    (run, suite, case, variant) pairs that go on."""
    df = load_results(out)
    pairs = {(s.key.run, s.key.suite, s.key.case, s.key.variant) for s in round_specs}
    mine = df[pd.MultiIndex.from_frame(df[["run", "suite", "case", "variant"]]).isin(list(pairs))]
    go_on: set = set()
    for (run, suite), design in designs.items():
        part = mine[(mine["run"] == run) & (mine["suite"] == suite)]
        if part.empty:
            continue
        before = None if running is None else {p for p in running if p[:2] == (run, suite)}
        decisions, cont = look_before_stage(part, design=design, stage=stage, metric=metric,
                                            running=before)
        store.set_meta(STOPS_KEY, record_stops(decisions, design=design, stage=stage,
                                               previous=store.meta.get(STOPS_KEY, [])))
        stopped.update({k: d for k, d in decisions.items() if d != "continue"})
        go_on |= cont
    return go_on


def _run_round(store, todo_specs: list, info: dict, *, jobs: int, backend: str, progress: bool, desc: str) -> int:
    """Run the jobs of ``todo_specs`` missing from ``store`` in one session; the rows written."""
    done = store.done_keys()
    todo = [s for s in todo_specs if s.key.astuple() not in done]
    todo.sort(key=lambda s: (-s.cost, s.key))
    t_round = time.perf_counter()
    session = store.begin_session(jobs=jobs, backend=backend, n_todo=len(todo))
    n_round = 0
    with store_session(store, session, t0=t_round) as ended:
        with show_progress(len(todo_specs), done=len(todo_specs) - len(todo), desc=desc, unit="job",
                           enabled=progress) as bar:
            # one job per batch: a mutant may couple the filters of a batch through a unit
            for res in stream_results(batch_jobs(todo, size=1), jobs=jobs, backend=backend):
                k = res.key
                store.write(result_row(info[(k.run, k.suite, k.case)], res), session=session)
                n_round += 1
                ended["n_new"] = n_round
                bar.update(1)
    return n_round


def _check_level(out: Path, mexp: MutationExperiment, *, force_new: bool) -> None:
    """Refuse, before anything is written, to resume a campaign at another ``alpha``: the level decides
    which cases ran (early stopping), so the stored rows belong to the level they were run at."""
    check_store(out, mexp.experiment, force_new=force_new)
    if force_new or not results_path(out).exists():
        return
    try:
        old = json.loads((out / MUTATION_FILE).read_text())
    except (OSError, ValueError):
        return
    if old.get("alpha") is not None and float(old["alpha"]) != mexp.alpha:
        raise ResultsError(f"{out} holds a mutation campaign at alpha = {old['alpha']}, not {mexp.alpha}; changed: "
                           f"mutation.alpha. Rerun with the original level to resume, or use --force-new "
                           f"(force_new=True) to start a new store (the old one is moved aside, not deleted)")


def _selection_json(mexp: MutationExperiment) -> dict:
    s = mexp.selection
    out = {"alpha": mexp.alpha, "direction": mexp.direction, "run": list(s.run), "screened": s.screened, "represented_by": s.represented_by,
           "unit": s.unit, "operator": s.operator}
    if mexp.records is not None:  # a campaign on a target
        out |= {"kill": mexp.kill, "case_alpha": mexp.fixed_case_alpha, "trivial": list(s.trivial),
                "reused": s.reused, "target": s.info}
    return out
