"""The mutants of a user's target that a campaign runs: sampled, screened on probes (cached), reused.

A ``sample`` budget of ``n`` is drawn *before* any screening: the target's mutants are put in a
seeded uniform random order (:func:`sample_order`) and :func:`screen_target` screens them on probe
scenarios (:mod:`faultlab.mutation.probes`) along that order until ``n`` live ones are found.  The
first ``n`` live mutants of a uniform random order are a uniform sample of ``n`` of the live
mutants, so the scores estimate those of all live mutants with an exact interval, while the
screening costs about ``n`` divided by the live share, not the whole target.  Without a budget
every mutant is screened, in generation order.

Each mutant's probe fingerprints are cached on disk like the unit catalogue
(:func:`faultlab.mutation.catalogue.cache_dir`), keyed by everything they depend on: the faultlab,
Python and numpy versions, the target module's and the SLAM factory module's source, the SLAM and
its options, the probes and the time limit.  :func:`select_source_mutants` turns the screening
into a :class:`~faultlab.mutation.variants.MutantSelection`: the live mutants screened run, the
others are recorded with their class, and mutants whose verdict an earlier campaign already holds
(same id: same function source, operator and position) are *reused* instead of run.
"""

from __future__ import annotations

import hashlib
import json
import math
import sys
from collections import Counter
from collections.abc import Mapping, Sequence

import numpy as np

import faultlab
from faultlab.cache import write_cache_json
from faultlab.errors import ConfigError
from faultlab.mutation.catalogue import cache_dir
from faultlab.mutation.outcome import MutantOutcome
from faultlab.mutation.probes import (PROBE_TIME_LIMIT_S, ProbeScreening, classify_probes, probe_coverage,
                                     probe_fingerprints, probe_runs)
from faultlab.mutation.target import SourceMutants, factory_module, module_source
from faultlab.mutation.variants import MutantSelection
from faultlab.seeds import mutant_draw

__all__ = ["screen_target", "sample_order", "select_source_mutants", "mutant_records", "SCREEN_LABELS", "UNSAMPLED"]

_FORMAT = "faultlab-source-probes-1"
#: Screening classes of mutants of user source, in report order.
SCREEN_LABELS = ("live", "invalid", "equivalent", "duplicate")
#: Most mutants a screening batch gives each process: the cache is written after every batch.
_BATCH_PER_JOB = 8
#: The record class of a mutant the sample budget left unscreened.
UNSAMPLED = "unsampled"


def _key(mutants: SourceMutants, slam_spec, probe_key: str, limit: float | None) -> str:
    h = hashlib.sha256()
    factory = factory_module(slam_spec.name)
    parts = [_FORMAT, faultlab.__version__, sys.version, np.__version__, mutants.module.text,
             module_source(factory).text if factory else "", repr(slam_spec.to_dict()), probe_key, repr(limit)]
    for part in parts:
        h.update(f"{part}\0".encode())
    return h.hexdigest()[:32]


def sample_order(mutants: SourceMutants, *, sample: int | None, seed: int = 0) -> list[str]:
    """The order in which mutants are screened: generation order without a budget; with one, a
    seeded uniform random order (each mutant's :func:`~faultlab.seeds.mutant_draw`, so a mutant
    keeps its place among the others whatever else the target generates)."""
    ids = [m.id for m in mutants]
    if sample is None:
        return ids
    if isinstance(sample, bool) or not isinstance(sample, int) or sample < 1:
        raise ConfigError(f"[mutation] sample must be an integer >= 1, got {sample!r}")
    return sorted(ids, key=lambda i: (mutant_draw(seed, i), i))


def _read_cache(path, key: str) -> tuple[tuple | str | None, frozenset | None, dict]:
    try:
        data = json.loads(path.read_text())
        if data.get("key") == key:
            fix = (lambda f: f if isinstance(f, str) else tuple(f))
            return (fix(data["original"]), frozenset(int(x) for x in data["covered"]),
                    {i: fix(f) for i, f in data["fingerprints"].items()})
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        pass  # absent, or a damaged cache file: ignored and rewritten
    return None, None, {}


def screen_target(mutants: SourceMutants, slam_spec, probes: Sequence, seeds: Sequence[int], *, probe_key: str,
                  order: Sequence[str] | None = None, budget: int | None = None, jobs: int = 1, cache: bool = True,
                  limit: float | None = PROBE_TIME_LIMIT_S) -> dict[str, ProbeScreening]:
    """Mutant id -> :class:`ProbeScreening` of the mutants of ``mutants`` screened, in ``order``
    (default: generation order); with a ``budget``, only as far along ``order`` as its ``budget``-th
    live mutant: a sample drawn first is screened, not the whole target.

    The original runs the probes once under a profile hook (:func:`~faultlab.mutation.probes.probe_coverage`):
    a mutant whose change lies in the body of a function the original never calls on them is
    equivalent on the probes without running.  The others run in batches sized from the live share
    seen so far (at most ``8 * jobs`` mutants), and every mutant's probe fingerprints are cached on
    disk after each batch (keyed by everything they depend on), so an interrupted screening
    resumes and a rerun of the same target screens only mutants it has not screened.  The classes
    depend only on ``order`` and ``budget``, not on the batches or ``jobs``.  ``probe_key`` names
    the probes.
    """
    order = [m.id for m in mutants] if order is None else list(order)
    d = cache_dir() if cache else None
    key = _key(mutants, slam_spec, probe_key, limit)
    path = None if d is None else d / "mutation" / f"source-{key}.json"
    original, covered, found = _read_cache(path, key) if path is not None else (None, None, {})
    if original is None or covered is None:
        original = probe_fingerprints(None, slam_spec, probes, seeds, limit=limit)
        covered, found = probe_coverage(mutants.module.name, slam_spec, probes, seeds, limit=limit), {}
    never = _never_run(mutants, covered)
    found |= {i: original for i in never}
    while True:
        out = classify_probes(order, found, original, budget=budget, never_run=never)
        n_live = sum(s.outcome is None for s in out.values())
        rest = [i for i in order[len(out):] if i not in found]
        if (budget is not None and n_live >= budget) or not rest:
            return out
        need = len(rest) if budget is None else budget - n_live
        share = max(n_live / len(out), 0.25) if out else 0.5
        batch = rest[:max(2 * jobs, min(_BATCH_PER_JOB * jobs, math.ceil(1.1 * need / share)))]
        found |= probe_runs(batch, slam_spec, probes, seeds, jobs=jobs, limit=limit)
        if path is not None:
            write_cache_json(path, {"key": key, "format": _FORMAT, "original": original, "covered": sorted(covered),
                                    "fingerprints": {i: found[i] for i in sorted(found) if i not in never}})


def _never_run(mutants: SourceMutants, covered: frozenset[int]) -> set[str]:
    """The mutants whose change lies in the body of a function no code object of which ran."""
    idle = {f.qualname: f.body_line for f in mutants.functions
            if f.body_line and not any(f.first_line <= line <= f.last_line for line in covered)}
    return {m.id for m in mutants if m.function in idle and m.line >= idle[m.function]}


def select_source_mutants(mutants: SourceMutants, screening: Mapping[str, ProbeScreening], *,
                          sample: int | None = None, reuse: Mapping[str, str] | None = None) -> MutantSelection:
    """The campaign's mutants of a target (see the module docstring): every live mutant of
    ``screening`` runs, in generation order.

    Parameters
    ----------
    sample : int, optional
        The budget ``screening`` was made with (:func:`screen_target`): for the record.
    reuse : mapping, optional
        Mutant id -> directory of an earlier campaign that ran it; a selected live mutant found
        there is reused, not run.
    """
    ids = [m.id for m in mutants]
    seen = [i for i in ids if i in screening]
    live = [i for i in seen if screening[i].outcome is None]
    reuse = dict(reuse or {})
    reused = {i: reuse[i] for i in live if i in reuse}
    run = tuple(i for i in live if i not in reused)
    screened = {i: screening[i].label for i in seen if screening[i].outcome is not None}
    rep = {i: screening[i].duplicate_of for i in screened if screening[i].duplicate_of}
    population = Counter(screening[i].label for i in seen)
    by_id = mutants.by_id
    info = dict(target=str(mutants.target), module=mutants.module.name, path=mutants.module.display_path,
                module_digest=mutants.module.digest, n_mutants=len(ids), n_screened=len(seen),
                classes={label: int(population.get(label, 0)) for label in SCREEN_LABELS},
                n_live=len(live), n_trivial_live=sum(screening[i].trivial for i in live),
                sample=sample, n_sampled=len(live), skipped_functions=dict(mutants.skipped))
    return MutantSelection(run=run, screened=screened, represented_by=rep,
                           unit={i: by_id[i].function for i in seen},
                           operator={i: by_id[i].operator for i in seen},
                           trivial=tuple(i for i in live if screening[i].trivial),
                           reused=reused, info=info)


def mutant_records(mutants: SourceMutants, screening: Mapping[str, ProbeScreening]) -> dict:
    """What a report needs of every mutant, independent of the user's files changing later: the
    module's source and path, and per mutant its place, change, diff and screening."""
    out = {}
    for m in mutants:
        s = screening.get(m.id)
        sl, sc, el, ec = m.span
        out[m.id] = dict(function=m.function, operator=m.operator, line=m.line, span=[sl, sc, el, ec],
                         description=m.description, change=m.change, replacement=m.replacement,
                         diff=m.diff if s is not None else "")
        out[m.id] |= (dict(screening=s.label, reason=s.reason, duplicate_of=s.duplicate_of, trivial=s.trivial)
                      if s is not None else dict(screening=UNSAMPLED, reason="not screened: after the sample "
                                                 "budget in the seeded random order", duplicate_of=None, trivial=False))
    return dict(module=mutants.module.name, path=mutants.module.display_path, source=mutants.module.text,
                mutants=out)
