"""The mutants of a user's target that a campaign runs: screened on probes (cached), sampled, reused.

:func:`screen_target` screens every mutant of a target on probe scenarios
(:mod:`faultlab.mutation.probes`) and caches the result on disk like the unit catalogue
(:func:`faultlab.mutation.catalogue.cache_dir`), keyed by everything it depends on: the faultlab,
Python and numpy versions, the target module's and the SLAM factory module's source, the SLAM
and its options, the probes and every mutant id.  :func:`select_source_mutants` turns the
screening into a :class:`~faultlab.mutation.variants.MutantSelection`: live mutants run (a
``sample`` budget draws that many of them uniformly, seeded), the others are recorded with their
class, and mutants whose verdict an earlier campaign already holds (same id: same function
source, operator and position) are *reused* instead of run.
"""

from __future__ import annotations

import hashlib
import json
import sys
from collections import Counter
from collections.abc import Mapping, Sequence

import numpy as np

import faultlab
from faultlab.cache import write_cache_json
from faultlab.errors import ConfigError
from faultlab.mutation.catalogue import cache_dir
from faultlab.mutation.outcome import MutantOutcome
from faultlab.mutation.probes import ProbeScreening, screen_on_probes
from faultlab.mutation.target import SourceMutants, factory_module, module_source
from faultlab.mutation.variants import MutantSelection

__all__ = ["screen_target", "select_source_mutants", "mutant_records", "SCREEN_LABELS"]

_FORMAT = "faultlab-source-screening-1"
#: Screening classes of mutants of user source, in report order.
SCREEN_LABELS = ("live", "invalid", "equivalent", "duplicate")


def _key(mutants: SourceMutants, slam_spec, probe_key: str) -> str:
    h = hashlib.sha256()
    factory = factory_module(slam_spec.name)
    parts = [_FORMAT, faultlab.__version__, sys.version, np.__version__, mutants.module.text,
             module_source(factory).text if factory else "", repr(slam_spec.to_dict()), probe_key]
    for part in parts:
        h.update(f"{part}\0".encode())
    for m in mutants:
        h.update(f"{m.id}\0".encode())
    return h.hexdigest()[:32]


def screen_target(mutants: SourceMutants, slam_spec, probes: Sequence, seeds: Sequence[int], *, probe_key: str,
                  jobs: int = 1, cache: bool = True) -> dict[str, ProbeScreening]:
    """Mutant id -> :class:`ProbeScreening` of every mutant of ``mutants`` (cached on disk).

    ``probe_key`` names the probes (how they were drawn) for the cache key.
    """
    d = cache_dir() if cache else None
    key = _key(mutants, slam_spec, probe_key)
    path = None if d is None else d / "mutation" / f"source-{key}.json"
    if path is not None and path.is_file():
        try:
            data = json.loads(path.read_text())
            if data.get("key") == key:
                return {i: ProbeScreening(i, MutantOutcome(o) if o else None, r, dup, bool(t))
                        for i, (o, r, dup, t) in data["results"].items()}
        except (OSError, ValueError, KeyError, TypeError):
            pass  # a damaged cache file is ignored and rewritten
    found = screen_on_probes(list(mutants), slam_spec, probes, seeds, jobs=jobs)
    if path is not None:
        data = {"key": key, "format": _FORMAT,
                "results": {i: [s.outcome.value if s.outcome else None, s.reason, s.duplicate_of, s.trivial]
                            for i, s in found.items()}}
        write_cache_json(path, data)
    return found


def select_source_mutants(mutants: SourceMutants, screening: Mapping[str, ProbeScreening], *,
                          sample: int | None = None, seed: int = 0,
                          reuse: Mapping[str, str] | None = None) -> MutantSelection:
    """The campaign's mutants of a target (see the module docstring).

    Parameters
    ----------
    sample : int, optional
        Budget: run a uniform random sample of this many live mutants (``numpy.random.default_rng(seed)``
        without replacement, generation order kept); default all.
    reuse : mapping, optional
        Mutant id -> directory of an earlier campaign that ran it; a selected live mutant found
        there is reused, not run.
    """
    ids = [m.id for m in mutants]
    live = [i for i in ids if screening[i].outcome is None]
    if sample is not None:
        if isinstance(sample, bool) or not isinstance(sample, int) or sample < 1:
            raise ConfigError(f"[mutation] sample must be an integer >= 1, got {sample!r}")
        if sample < len(live):
            keep = set(np.random.default_rng(seed).choice(len(live), size=sample, replace=False).tolist())
            live = [m for j, m in enumerate(live) if j in keep]
    reuse = dict(reuse or {})
    reused = {i: reuse[i] for i in live if i in reuse}
    run = tuple(i for i in live if i not in reused)
    screened = {i: screening[i].label for i in ids if screening[i].outcome is not None}
    rep = {i: screening[i].duplicate_of for i in screened if screening[i].duplicate_of}
    population = Counter(screening[i].label for i in ids)
    by_id = mutants.by_id
    chosen = set(live) | set(screened)
    info = dict(target=str(mutants.target), module=mutants.module.name, path=mutants.module.display_path,
                module_digest=mutants.module.digest, n_mutants=len(ids),
                classes={label: int(population.get(label, 0)) for label in SCREEN_LABELS},
                n_live=sum(screening[i].outcome is None for i in ids),
                n_trivial_live=sum(screening[i].outcome is None and screening[i].trivial for i in ids),
                sample=sample, n_sampled=len(live), skipped_functions=dict(mutants.skipped))
    return MutantSelection(run=run, screened=screened, represented_by=rep,
                           unit={i: by_id[i].function for i in ids if i in chosen},
                           operator={i: by_id[i].operator for i in ids if i in chosen},
                           trivial=tuple(i for i in live if screening[i].trivial),
                           reused=reused, info=info)


def mutant_records(mutants: SourceMutants, screening: Mapping[str, ProbeScreening]) -> dict:
    """What a report needs of every mutant, independent of the user's files changing later: the
    module's source and path, and per mutant its place, change, diff and screening."""
    out = {}
    for m in mutants:
        s = screening[m.id]
        sl, sc, el, ec = m.span
        out[m.id] = dict(function=m.function, operator=m.operator, line=m.line, span=[sl, sc, el, ec],
                         description=m.description, change=m.change, replacement=m.replacement, diff=m.diff,
                         screening=s.label, reason=s.reason, duplicate_of=s.duplicate_of, trivial=s.trivial)
    return dict(module=mutants.module.name, path=mutants.module.display_path, source=mutants.module.text,
                mutants=out)
