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
have detected (80 % power): the smallest per-case detectable shift ``mde_mm`` of the suite's
cases (estimated from the baseline's spread, :func:`~faultlab.stats.verdict.case_verdicts`).

The campaign's outcomes, scores and suite comparisons are computed from its store by
:func:`faultlab.analysis.mutation.analyse_mutation`.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass
from pathlib import Path

from faultlab.config import read_toml
from faultlab.data import resolve_experiment
from faultlab.errors import ConfigError, ResultsError
from faultlab.mutation.variants import MutantSelection, mutant_variant, select_mutants
from faultlab.runner import (Experiment, ResultStore, batch_jobs, expand_jobs, load_results, parse_experiment,
                             prepare_cases, result_row, store_session, stream_results)
from faultlab.runner.progress import progress as show_progress
from faultlab.runner.store import MUTATION_FILE, check_store, job_metrics, results_path, store_lock
from faultlab.stats.killmatrix import suite_kills
from faultlab.stats.verdict import alternative_of, min_pairs
from faultlab.vocabulary import BASELINE, DEFAULT_ALPHA, DEFAULT_DIRECTION, DIRECTIONS

__all__ = ["MUTATION_FILE", "MutationExperiment", "MutationRun", "load_mutation_experiment", "parse_selector",
           "selection_from_table", "run_mutation"]

_MUTATION_KEYS = ("units", "operators", "ids", "sample", "seed", "alpha", "direction")


@dataclass(frozen=True)
class MutationExperiment:
    """An experiment whose variants are baseline and the selected live mutants, with the selection."""

    experiment: Experiment
    selection: MutantSelection
    alpha: float = DEFAULT_ALPHA
    direction: str = DEFAULT_DIRECTION

    def case_alpha(self, n_cases: int) -> float:
        return self.alpha / n_cases


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


def load_mutation_experiment(path: str | Path, *, mutants: str | None = None,
                             repetitions: int | None = None) -> MutationExperiment:
    """Read a mutation experiment file (or a shipped one by name, e.g. ``mutation``).

    ``mutants`` (a :func:`parse_selector` text) replaces the file's selection; ``repetitions``
    its K.  ConfigError naming the file and key for anything malformed.
    """
    file = resolve_experiment(path, what="mutation experiment file")
    data, text = read_toml(file, what="mutation experiment file")
    data = dict(data)
    table = dict(data.pop("mutation", {}) or {})
    unknown = set(table) - set(_MUTATION_KEYS)
    if unknown:
        raise ConfigError(f"{path}: [mutation]: unknown key(s) {sorted(unknown)}; known: {', '.join(_MUTATION_KEYS)}")
    if mutants is not None:
        table = {k: v for k, v in table.items() if k in ("seed", "alpha", "direction")} | parse_selector(mutants)
    if repetitions is not None:
        data["repetitions"] = repetitions
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
    return mexp


def selection_from_table(table: dict, *, source: str) -> MutantSelection:
    """The mutants a ``[mutation]`` table selects (``units``, ``operators``, ``ids``, ``sample``,
    ``seed``; see :func:`~faultlab.mutation.variants.select_mutants`); ConfigError if none is live."""
    unknown = set(table) - set(_MUTATION_KEYS)
    if unknown:
        raise ConfigError(f"{source}: [mutation]: unknown key(s) {sorted(unknown)}; known: {', '.join(_MUTATION_KEYS)}")
    selection = select_mutants(units=table.get("units"), operators=table.get("operators"), ids=table.get("ids"),
                               sample=table.get("sample"), seed=int(table.get("seed", 0)))
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

    def __str__(self) -> str:
        return (f"{self.n_mutants} mutants: {self.n_jobs_run} of at most {self.n_jobs_max} jobs needed "
                f"({self.n_skipped_early} skipped by early stopping), {self.n_new} run now, "
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
    t0 = time.perf_counter()
    out = Path(out)
    n_new = 0
    _check_level(out, mexp, force_new=force_new)
    with store_lock(out), ResultStore.open(out, exp, force_new=force_new) as store:
        (out / MUTATION_FILE).write_text(json.dumps(_selection_json(mexp), indent=1))
        cases = prepare_cases(exp, out)
        info = {(c.run, c.suite, c.case): c for c in cases}
        n_cases = _n_cases(cases)
        specs = expand_jobs(exp, ((c.run, c.suite, c.case, c.path, c.cost) for c in cases),
                            metrics=job_metrics(exp.metrics, store.meta))
        by_case: dict = {}
        for s in specs:
            by_case.setdefault((s.key.run, s.key.suite, s.key.case), []).append(s)
        killed: dict = {rs: set() for rs in n_cases}
        n_needed = 0
        for r in range(1, max(n_cases.values()) + 1):
            todo, round_specs = [], []
            for (run, suite), n in n_cases.items():
                if r > n or len(killed[(run, suite)]) == len(mexp.selection.run):
                    continue  # no case left, or every mutant killed: the baseline is not needed either
                for s in by_case[(run, suite, r)]:
                    if s.key.variant in killed[(run, suite)]:
                        continue
                    round_specs.append(s)
            done = store.done_keys()
            todo = [s for s in round_specs if s.key.astuple() not in done]
            todo.sort(key=lambda s: (-s.cost, s.key))
            n_needed += len(round_specs)
            t_round = time.perf_counter()
            session = store.begin_session(jobs=jobs, backend=backend, n_todo=len(todo))
            n_round = 0
            with store_session(store, session, t0=t_round) as ended:
                with show_progress(len(round_specs), done=len(round_specs) - len(todo),
                                   desc=f"faultlab mutate case {r}", unit="job", enabled=progress) as bar:
                    # one job per batch: a mutant may couple the filters of a batch through a unit
                    for res in stream_results(batch_jobs(todo, size=1), jobs=jobs, backend=backend):
                        k = res.key
                        store.write(result_row(info[(k.run, k.suite, k.case)], res), session=session)
                        n_round += 1
                        ended["n_new"] = n_round
                        bar.update(1)
            n_new += n_round
            df = load_results(out)
            df = df[df["case"] == r]
            for (run, suite), n in n_cases.items():
                if r > n:
                    continue
                part = df[(df["run"] == run) & (df["suite"] == suite)]
                if part.empty:
                    continue
                k = suite_kills(part, case_alpha=mexp.case_alpha(n), metric=exp.metric, direction=mexp.direction)
                killed[(run, suite)].update(k.loc[k["kill"] != "", "fault"])
    return MutationRun(out=out, n_mutants=len(mexp.selection.run), n_jobs_max=len(specs), n_jobs_run=n_needed,
                       n_new=n_new, n_skipped_early=len(specs) - n_needed, wall_time_s=time.perf_counter() - t0)


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
    return {"alpha": mexp.alpha, "direction": mexp.direction, "run": list(s.run), "screened": s.screened, "represented_by": s.represented_by,
            "unit": s.unit, "operator": s.operator}
