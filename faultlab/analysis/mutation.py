"""A mutation campaign of the reference FastSLAM: run with early stopping, statistical kills, scores.

Running (:func:`run_mutation`)
------------------------------
A mutation experiment is an ordinary experiment file plus a ``[mutation]`` table selecting the
mutants (``units``, ``operators``, ``ids``, ``sample``, ``seed``; all optional: every live
mutant) and the family-wise level ``alpha`` (default :data:`~faultlab.vocabulary.DEFAULT_ALPHA`).  Its variants are ``baseline`` and
``mutant:<id>`` for every selected live mutant (:mod:`faultlab.mutation.variants`); the campaign
is stored in the runner's results store (:class:`~faultlab.runner.store.ResultStore`), one row
per job, seeds as in any campaign (repetition k of a case uses the same SLAM seed for every
variant: common random numbers), so it resumes like ``faultlab run``.  Stillborn and equivalent
mutants never run; a duplicate is represented by the mutant it duplicates.

Statistical kill.  A *suite* is one (run, suite kind) with ``n`` cases.  A mutant is killed on a
case when the exact paired sign-flip test of :func:`faultlab.stats.verdict.case_verdicts`
(K repetitions, CRN pairs) rejects at ``alpha / n``, or when the mutant alone fails (crash or
timeout with the baseline usable: class ``crash``/``timeout``).  A mutant is killed by the suite
when some case kills it.  The cases run in a fixed order, in rounds (case 1 of every suite,
then case 2, ...), and a mutant killed by a suite does not run its remaining cases (early
stopping).  Multiplicity: Bonferroni over the suite's cases.  Because the per-case level
``alpha / n`` does not depend on what was observed, the probability that a mutant with no effect
on the error is called killed is at most the sum of the levels of the cases actually tested, at
most ``alpha``, whatever the stopping; Holm's step-down would need every case's p value and is
not valid once cases are skipped.  K must be at least ``min_pairs(alpha / n)``.

A mutant that survives a suite comes with the smallest shift of the mean map error it could
have detected (80 % power): the smallest per-case detectable shift ``mde_mm`` of the suite's
cases (estimated from the baseline's spread, :func:`~faultlab.stats.verdict.case_verdicts`).

Analysing (:func:`analyse_mutation`)
------------------------------------
:class:`MutationAnalysis` holds ``outcomes`` (one row per mutant and suite), ``scores`` (mutation
score per suite kind, per suite kind and operator, per suite kind and unit, with exact
Clopper-Pearson intervals) and ``mcnemar`` (suite kinds compared on the same mutant and run pairs
with the exact McNemar test, Holm-adjusted over the comparisons).  Score = killed (incl. crash and
timeout) / (killed + survived); mutants the baseline made unjudgeable are excluded and counted.
"""

from __future__ import annotations

import itertools
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from statsmodels.stats.multitest import multipletests
from statsmodels.stats.contingency_tables import mcnemar
from statsmodels.stats.proportion import proportion_confint

from faultlab.analysis.bundle import TableBundle
from faultlab.config import read_toml
from faultlab.data import resolve_experiment
from faultlab.errors import ConfigError, ResultsError
from faultlab.mutation.variants import MutantSelection, mutant_variant, select_mutants
from faultlab.mutation.outcome import MutantOutcome
from faultlab.runner.execute import _row, _stream, prepare_cases
from faultlab.runner.experiment import Experiment, parse_experiment
from faultlab.runner.jobs import batch_jobs, expand_jobs
from faultlab.runner.progress import progress as show_progress
from faultlab.runner.store import ResultStore, load_results, store_lock
from faultlab.stats.verdict import alternative_of, case_verdicts, min_pairs
from faultlab.vocabulary import BASELINE, DEFAULT_ALPHA, DEFAULT_DIRECTION, DIRECTIONS, PAPER_DIRECTION, JobStatus

__all__ = ["MUTATION_FILE", "MUTATION_TABLES", "MutationExperiment", "MutationAnalysis", "MutationRun",
           "load_mutation_experiment", "parse_selector", "selection_from_table", "run_mutation", "analyse_mutation", "suite_kills",
           "mutant_outcomes", "stored_direction", "OBSERVED_EQUIVALENT"]

#: File in the output directory recording the selection and the level of a mutation campaign.
MUTATION_FILE = "mutation.json"
#: Tables of a :class:`MutationAnalysis`, saved as ``<name>.csv``.
MUTATION_TABLES = ("outcomes", "scores", "mcnemar")
OUTCOME_COLUMNS = ["mutant", "unit", "operator", "run", "suite", "outcome", "survival", "represented_by",
                   "killing_case", "direction", "median_diff_mm", "ratio", "n_cases_run", "n_cases", "min_p",
                   "max_p_equivalence", "min_mde_mm", "note"]
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


def suite_kills(results: pd.DataFrame, *, case_alpha: float, metric: str = "rms",
                direction: str = DEFAULT_DIRECTION) -> pd.DataFrame:
    """Per (run, suite, case, mutant variant): whether the case kills it, and how.

    Returns the :func:`case_verdicts` frame at level ``case_alpha`` (two-sided unless
    ``direction`` is the paper's ``"worse"``) with a column ``kill``: ``killed`` (test rejects),
    ``crash``/``timeout`` (the mutant alone failed), ``""`` otherwise.
    """
    v = case_verdicts(results, alpha=case_alpha, metric=metric, direction=direction)
    kill = np.where(v["verdict"] == "detected", MutantOutcome.KILLED.value, "").astype(object)
    crashed = (v["verdict"] == "crash_detected").to_numpy()
    if crashed.any():
        st = results[results["variant"] != BASELINE].groupby(["run", "suite", "case", "variant"])["status"]
        timeouts = st.apply(lambda s: (s.astype(str) == JobStatus.TIMEOUT.value).any())
        for i in np.flatnonzero(crashed):
            r = v.iloc[i]
            kill[i] = (MutantOutcome.TIMEOUT.value if timeouts.get((r["run"], r["suite"], r["case"], r["fault"]), False)
                       else MutantOutcome.CRASH.value)
    return v.assign(kill=kill)


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
    with store_lock(out), ResultStore.open(out, exp, force_new=force_new) as store:
        (out / MUTATION_FILE).write_text(json.dumps(_selection_json(mexp), indent=1))
        cases = prepare_cases(exp, out)
        info = {(c.run, c.suite, c.case): c for c in cases}
        n_cases = _n_cases(cases)
        specs = expand_jobs(exp, ((c.run, c.suite, c.case, c.path, c.cost) for c in cases))
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
            session = store.begin_session(jobs=jobs, backend=backend, n_todo=len(todo))
            state, n_round = "interrupted", 0
            try:
                with show_progress(len(round_specs), done=len(round_specs) - len(todo),
                                   desc=f"faultlab mutate case {r}", unit="job", enabled=progress) as bar:
                    # one job per batch: a mutant may couple the filters of a batch through a unit
                    for res in _stream(batch_jobs(todo, size=1), jobs=jobs, backend=backend):
                        k = res.key
                        store.write(_row(info[(k.run, k.suite, k.case)], res), session=session)
                        n_round += 1
                        bar.update(1)
                state = "complete"
            finally:
                store.end_session(session, state=state, n_new=n_round, wall_time_s=time.perf_counter() - t0)
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


def _selection_json(mexp: MutationExperiment) -> dict:
    s = mexp.selection
    return {"alpha": mexp.alpha, "direction": mexp.direction, "run": list(s.run), "screened": s.screened, "represented_by": s.represented_by,
            "unit": s.unit, "operator": s.operator}


# --------------------------------------------------------------------------- analysis

def clopper_pearson(k: int, n: int, alpha: float = DEFAULT_ALPHA) -> tuple[float, float]:
    """Exact two-sided (1 - alpha) interval of a binomial proportion (NaN, NaN for n = 0)."""
    if n == 0:
        return math.nan, math.nan
    lo, hi = proportion_confint(k, n, alpha=alpha, method="beta")
    return float(lo), float(hi)


@dataclass(frozen=True, eq=False)
class MutationAnalysis(TableBundle):
    """Outcomes, scores and suite comparisons of a mutation campaign (frozen; save/load as CSV + JSON).

    Attributes
    ----------
    outcomes : DataFrame
        One row per (mutant, run, suite) (``OUTCOME_COLUMNS``): ``outcome`` is a
        :class:`MutantOutcome` value or ``cannot_judge``; screened-out mutants have one row per
        suite with their class and ``represented_by`` for duplicates (which inherit nothing).
    scores, mcnemar : DataFrame
    meta : dict
        ``alpha``, run time, counts.
    """

    outcomes: pd.DataFrame
    scores: pd.DataFrame
    mcnemar: pd.DataFrame
    meta: dict = field(default_factory=dict)

    TABLES = MUTATION_TABLES
    META_FILE = "mutation_meta.json"
    WHAT = "mutation analysis"


def stored_direction(sel: dict) -> str:
    """The direction a stored campaign's kills (and so its early stopping) used: its ``direction``, or
    the paper's one-sided ``"worse"`` for a campaign recorded before the choice existed."""
    return str(sel.get("direction", PAPER_DIRECTION))


def mutant_outcomes(results: pd.DataFrame, sel: dict, metric: str = "rms", suites: dict | None = None) -> pd.DataFrame:
    """One row per (mutant, run, suite), :data:`OUTCOME_COLUMNS`, from a campaign's results and its
    ``mutation.json`` record ``sel`` (``alpha``, ``direction``, ``run``, ``screened``, ``unit``,
    ``operator``, ``represented_by``); see the module docstring."""
    alpha = float(sel["alpha"])
    direction = stored_direction(sel)
    ncases = results.groupby(["run", "suite"])["case"].max().to_dict()
    if suites:  # the experiment's case counts: an interrupted campaign has not reached the last cases
        ncases = {k: int(suites.get(k[1], n)) for k, n in ncases.items()}
    rows = []
    per_suite = {}
    for (run, suite), n in ncases.items():
        part = results[(results["run"] == run) & (results["suite"] == suite)]
        per_suite[(run, suite)] = suite_kills(part, case_alpha=alpha / n, metric=metric, direction=direction)
    for mid in sel["run"]:
        variant = mutant_variant(mid)
        mine = {rs: v[v["fault"] == variant].sort_values("case") for rs, v in per_suite.items()}
        # bit-identical to the baseline in every paired run of every case of every suite
        observed_equivalent = all(len(mv) == ncases[rs] and mv["identical"].all() for rs, mv in mine.items())
        for (run, suite), mv in mine.items():
            n = ncases[(run, suite)]
            base = dict(mutant=mid, unit=sel["unit"].get(mid, ""), operator=sel["operator"].get(mid, ""), run=run,
                        suite=suite, represented_by="", n_cases=n, n_cases_run=len(mv), note="", survival="",
                        direction="", median_diff_mm=math.nan, ratio=math.nan)
            kills = mv[mv["kill"] != ""]
            p = pd.to_numeric(mv["p"], errors="coerce")
            mde = pd.to_numeric(mv["mde_mm"], errors="coerce")
            pe = pd.to_numeric(mv["p_equivalence"], errors="coerce")
            base["min_p"] = float(p.min()) if p.notna().any() else math.nan
            base["min_mde_mm"] = float(mde.min()) if mde.notna().any() else math.nan
            base["max_p_equivalence"] = float(pe.max()) if len(pe) and pe.notna().all() else math.nan
            if len(kills):
                first = kills.iloc[0]
                effect = {} if first["kill"] != MutantOutcome.KILLED.value else dict(
                    direction=first["direction"], median_diff_mm=float(first["median_diff_mm"]),
                    ratio=float(first["ratio"]))
                rows.append(base | dict(outcome=first["kill"], killing_case=int(first["case"])) | effect)
            elif len(mv) < n:
                rows.append(base | dict(outcome=INCOMPLETE, killing_case=0,
                                        note=f"{len(mv)} of {n} cases run"))
            elif (mv["verdict"] == "cannot_judge").all():
                rows.append(base | dict(outcome="cannot_judge", killing_case=0,
                                        note="; ".join(sorted(set(mv["reason"].astype(str))))))
            elif observed_equivalent:
                rows.append(base | dict(outcome=OBSERVED_EQUIVALENT, killing_case=0,
                                        note="maps bit-identical to the baseline's in every paired run"))
            else:
                equivalent = bool(base["max_p_equivalence"] <= alpha)
                margin = pd.to_numeric(mv["margin_mm"], errors="coerce")
                note = (f"equivalent within +-{margin.min():.0f}-{margin.max():.0f} mm on every case (TOST, "
                        f"p <= {base['max_p_equivalence']:.2g})" if equivalent else
                        f"no difference shown; smallest detectable shift {base['min_mde_mm']:.0f} mm (80 % power)")
                rows.append(base | dict(outcome=MutantOutcome.SURVIVED.value, killing_case=0,
                                        survival=SURVIVED_EQUIVALENT if equivalent else SURVIVED_INCONCLUSIVE,
                                        note=note))
    for mid, cls in sel["screened"].items():
        for (run, suite), n in ncases.items():
            rows.append(dict(mutant=mid, unit=sel["unit"].get(mid, ""), operator=sel["operator"].get(mid, ""),
                             run=run, suite=suite, outcome=cls, survival="",
                             represented_by=sel["represented_by"].get(mid, ""), killing_case=0, direction="",
                             median_diff_mm=math.nan, ratio=math.nan, n_cases_run=0, n_cases=n, min_p=math.nan,
                             max_p_equivalence=math.nan, min_mde_mm=math.nan, note="not run (screened out)"))
    return pd.DataFrame(rows, columns=OUTCOME_COLUMNS)


INCOMPLETE = "incomplete"
#: A live mutant whose maps were bit-identical to the baseline's in every paired run: equivalent as
#: observed on these cases; it leaves the score's denominator and is listed apart.
OBSERVED_EQUIVALENT = "equivalent_observed"
#: How a survivor survived: shown equivalent within the margin on every case (TOST), or not.
SURVIVED_EQUIVALENT = "equivalent"
SURVIVED_INCONCLUSIVE = "inconclusive"
KILL_CLASSES = (MutantOutcome.KILLED.value, MutantOutcome.CRASH.value, MutantOutcome.TIMEOUT.value)


def mutation_scores(outcomes: pd.DataFrame, *, alpha: float = DEFAULT_ALPHA) -> pd.DataFrame:
    """Mutation score per suite kind, per (suite kind, operator) and per (suite kind, unit).

    Score = killed / (killed + survived + incomplete) over the (mutant, run) rows that ran
    (``crash`` and ``timeout`` count as killed), with a Clopper-Pearson ``1 - alpha`` interval.
    An ``incomplete`` mutant (not killed by the cases run so far of an interrupted campaign)
    counts as not killed, so the score of an interrupted campaign is a lower bound.  Survivors
    split into ``equivalent`` (TOST on every case) and ``inconclusive``; mutants observed
    equivalent (bit-identical maps) leave the denominator and are counted in
    ``equivalent_observed``.
    """
    judged = outcomes[outcomes["outcome"].isin((*KILL_CLASSES, MutantOutcome.SURVIVED.value, INCOMPLETE))]
    observed = outcomes[outcomes["outcome"] == OBSERVED_EQUIVALENT]
    rows = []
    for by in (None, "operator", "unit"):
        keys = ["suite"] + ([by] if by else [])
        n_observed = observed.groupby(keys).size().to_dict() if len(observed) else {}
        for key, g in judged.groupby(keys, sort=True):
            key = key if isinstance(key, tuple) else (key,)
            k = int(g["outcome"].isin(KILL_CLASSES).sum())
            n = len(g)
            lo, hi = clopper_pearson(k, n, alpha)
            rows.append(dict(suite=key[0], by=by or "all", group=key[1] if by else "all", killed=k, judged=n,
                             crash=int((g["outcome"] == "crash").sum()), timeout=int((g["outcome"] == "timeout").sum()),
                             incomplete=int((g["outcome"] == INCOMPLETE).sum()),
                             survived_equivalent=int((g["survival"] == SURVIVED_EQUIVALENT).sum()),
                             survived_inconclusive=int((g["survival"] == SURVIVED_INCONCLUSIVE).sum()),
                             equivalent_observed=int(n_observed.get(key if by else key[0], 0)),
                             score=k / n, ci_low=lo, ci_high=hi))
    return pd.DataFrame(rows, columns=["suite", "by", "group", "killed", "judged", "crash", "timeout", "incomplete",
                                       "survived_equivalent", "survived_inconclusive", "equivalent_observed",
                                       "score", "ci_low", "ci_high"])


def compare_suites(outcomes: pd.DataFrame, suites) -> pd.DataFrame:
    """Exact McNemar test (statsmodels ``mcnemar(exact=True)``) of every pair of suite kinds on the
    (mutant, run) pairs both judged; Holm-adjusted over the pairs."""
    judged = outcomes[outcomes["outcome"].isin((*KILL_CLASSES, MutantOutcome.SURVIVED.value))]
    kill = judged.assign(k=judged["outcome"].isin(KILL_CLASSES)).pivot_table(
        index=["mutant", "run"], columns="suite", values="k", aggfunc="first")
    rows = []
    for a, b in itertools.combinations([s for s in suites if s in kill.columns], 2):
        both = kill[[a, b]].dropna().astype(bool)
        ka, kb = both[a].to_numpy(), both[b].to_numpy()
        t = np.array([[np.sum(ka & kb), np.sum(ka & ~kb)], [np.sum(~ka & kb), np.sum(~ka & ~kb)]])
        p = float(mcnemar(t, exact=True).pvalue) if len(both) else math.nan
        rows.append(dict(suite_a=a, suite_b=b, n=len(both), both=int(t[0, 0]), a_only=int(t[0, 1]),
                         b_only=int(t[1, 0]), neither=int(t[1, 1]), p=p))
    df = pd.DataFrame(rows, columns=["suite_a", "suite_b", "n", "both", "a_only", "b_only", "neither", "p"])
    ok = df["p"].notna().to_numpy()
    df["p_holm"] = math.nan
    if ok.any():
        df.loc[ok, "p_holm"] = multipletests(df.loc[ok, "p"].to_numpy(), method="holm")[1]
    return df


def analyse_mutation(out: str | Path, *, alpha: float = DEFAULT_ALPHA) -> MutationAnalysis:
    """The :class:`MutationAnalysis` of the campaign saved in ``out`` (runs nothing)."""
    out = Path(out)
    try:
        sel = json.loads((out / MUTATION_FILE).read_text())
    except OSError as exc:
        raise ResultsError(f"{out}: no {MUTATION_FILE}: not a mutation campaign ({exc})") from exc
    from faultlab.runner.store import load_metadata

    meta = load_metadata(out)
    exp = meta.get("experiment", {})
    results = load_results(out)
    metric = exp.get("metric", "rms") if isinstance(exp, dict) else "rms"
    spec = exp.get("suites", {}) if isinstance(exp, dict) else {}
    pairs = spec.items() if isinstance(spec, dict) else (tuple(p) for p in spec)  # stored as [[kind, n], ...]
    outcomes = mutant_outcomes(results, sel, metric, {k: v for k, v in pairs if isinstance(v, int)})
    suites = list(dict.fromkeys(results["suite"]))
    info = dict(alpha=sel["alpha"], direction=stored_direction(sel), n_mutants_run=len(sel["run"]), n_screened=len(sel["screened"]),
                n_jobs=len(results), runtime_s_sum=float(results["runtime_s"].sum()),
                status_counts={k: int(v) for k, v in results["status"].value_counts().items()},
                repetitions=int(results["rep"].max()) + 1, suites=suites,
                outcome_counts={f"{s}:{o}": int(n) for (s, o), n in
                                outcomes.groupby(["suite", "outcome"]).size().items()})
    return MutationAnalysis(outcomes=outcomes, scores=mutation_scores(outcomes, alpha=alpha),
                            mcnemar=compare_suites(outcomes, suites), meta=info)
