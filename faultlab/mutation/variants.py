"""Mutants as campaign variants: ``"mutant:<id>"`` names and the selection of mutants for a campaign.

A variant ``"mutant:<id>"`` (e.g. ``"mutant:motion_model:arithmetic:1"``) is the mutant of the
reference FastSLAM's units with that id, as a :class:`~faultlab.faults.Fault`
(:func:`~faultlab.mutation.mutant.mutant_fault`, picklable: workers rebuild the unit from source).
:func:`faultlab.runner.variants.resolve_variant` hands such names to :func:`resolve_mutant_variant`.

:func:`select_mutants` picks the mutants of a campaign from the screened catalogue by unit,
operator and id; only live mutants run (a duplicate is represented by the mutant it duplicates,
stillborn and equivalent mutants never run), the others are returned with their class so the
campaign can record them.
"""

from __future__ import annotations

import functools
from collections.abc import Iterable
from dataclasses import dataclass, field

import numpy as np

from faultlab.errors import ConfigError, FaultError
from faultlab.faults.fault import Fault
from faultlab.mutation.mutant import _operator_mutants, _parse_id, mutant_fault
from faultlab.mutation.outcome import MutantOutcome
from faultlab.mutation.source import unit_source
from faultlab.mutation.target import is_source_mutant_id, source_mutant_fault
from faultlab.vocabulary import MUTANT_PREFIX

__all__ = ["MUTANT_PREFIX", "MutantSelection", "is_mutant_variant", "mutant_variant", "mutant_id_of",
           "resolve_mutant_variant", "select_mutants"]

#: The SLAM whose units mutant variants belong to.
MUTANT_SLAM = "fastslam"


def is_mutant_variant(name: str) -> bool:
    return isinstance(name, str) and name.startswith(MUTANT_PREFIX)


def mutant_variant(mutant_id: str) -> str:
    """The variant name of a mutant: ``"mutant:<id>"``."""
    return MUTANT_PREFIX + mutant_id


def mutant_id_of(variant: str) -> str:
    """The mutant id of a variant name ``"mutant:<id>"``."""
    if not is_mutant_variant(variant):
        raise FaultError(f"{variant!r} is not a mutant variant ({MUTANT_PREFIX}<id>)")
    return variant[len(MUTANT_PREFIX):]


@functools.lru_cache(maxsize=1)
def _catalogue():
    from faultlab.mutation.catalogue import mutant_catalogue  # screening: seconds, cached on disk

    return mutant_catalogue(MUTANT_SLAM)


@functools.lru_cache(maxsize=1)
def _steps():
    from faultlab.slam.registry import build_slam

    return build_slam(MUTANT_SLAM, {}).steps


@functools.lru_cache(maxsize=4096)
def resolve_mutant_variant(variant: str) -> Fault:
    """The :class:`Fault` of variant ``"mutant:<id>"`` (FaultError naming close ids if unknown).

    A mutant of user source (:mod:`faultlab.mutation.target`) resolves to a
    :class:`~faultlab.mutation.target.SourceMutantFault`, which builds the whole SLAM from the
    mutated module instead of replacing a unit.

    Only the named operator's points in the named function are generated (milliseconds), so a
    worker process resolves a mutant without generating or screening the whole catalogue.
    """
    mutant_id = mutant_id_of(variant)
    if is_source_mutant_id(mutant_id):
        return source_mutant_fault(variant, mutant_id)
    steps = _steps()
    try:
        unit, helper, operator, index = _parse_id(mutant_id)
        original = getattr(steps, unit)
        source = unit_source(unit, original, type(steps))
        function = source.function(helper or source.function_name)
        candidates = _operator_mutants(unit, function, operator, helper is None)
        mutant = candidates[index - 1] if 1 <= index <= len(candidates) else None
    except (FaultError, AttributeError, KeyError, LookupError):
        mutant = None
    if mutant is None or mutant.id != mutant_id:
        _catalogue().mutants.get(mutant_id)  # raises FaultError naming close ids
        raise FaultError(f"unknown mutant {mutant_id!r}")
    return mutant_fault(mutant, type(steps))


@dataclass(frozen=True)
class MutantSelection:
    """The mutants a campaign names, split by what becomes of them before it runs.

    Attributes
    ----------
    run : tuple of str
        Ids of the mutants that run (live: neither stillborn, equivalent nor duplicate), in
        catalogue order.
    screened : dict
        Id -> screening class (``stillborn``/``equivalent``/``duplicate``) of the selected
        mutants that do not run.
    represented_by : dict
        Id of a selected duplicate -> id of the live mutant whose outcome it shares.
    unit, operator : dict
        Id -> unit / operator, for every selected mutant (for a mutant of user source, the unit is
        its function).
    trivial : tuple of str
        Ids of running mutants declared trivially killed by screening (they fail on every probe;
        mutants of user source only): the informative score leaves them out.
    reused : dict
        Id -> the earlier campaign's directory whose verdict the mutant reuses (an incremental
        rerun: its function is unchanged); such a mutant does not run.
    info : dict
        What the selection was made from (target, counts before sampling, probes), for the record.
    """

    run: tuple[str, ...]
    screened: dict
    represented_by: dict
    unit: dict
    operator: dict
    trivial: tuple[str, ...] = ()
    reused: dict = field(default_factory=dict)
    info: dict = field(default_factory=dict)


def select_mutants(*, units: Iterable[str] | None = None, operators: Iterable[str] | None = None,
                   ids: Iterable[str] | None = None, sample: int | None = None, seed: int = 0,
                   catalogue=None) -> MutantSelection:
    """Select mutants of the reference FastSLAM from the screened catalogue.

    Parameters
    ----------
    units, operators : iterable of str, optional
        Keep only mutants of these units / operators (default: all).
    ids : iterable of str, optional
        Keep only these mutant ids (default: all).
    sample : int, optional
        Keep a uniform random sample of this many of the *live* selected mutants (all screened-out
        ones stay, with their class), drawn with ``numpy.random.default_rng(seed)``; catalogue order
        is kept.
    seed : int
    catalogue : Catalogue, optional
        Default: the cached catalogue of the reference FastSLAM.

    Returns
    -------
    MutantSelection
    """
    cat = catalogue if catalogue is not None else _catalogue()
    report = cat.report
    units = None if units is None else set(units)
    operators = None if operators is None else set(operators)
    ids = None if ids is None else list(ids)
    if ids is not None:
        for i in ids:
            cat.mutants.get(i)  # unknown id: FaultError naming close ids
    known_units = {m.unit for m in cat.mutants}
    known_ops = {m.operator for m in cat.mutants}
    for what, chosen, known in (("unit", units, known_units), ("operator", operators, known_ops)):
        if chosen is not None and chosen - known:
            raise ConfigError(f"[mutation] unknown {what}(s) {sorted(chosen - known)}; known: {sorted(known)}")
    picked = [m for m in cat.mutants
              if (units is None or m.unit in units) and (operators is None or m.operator in operators)
              and (ids is None or m.id in ids)]
    live = [m.id for m in picked if report[m.id].live]
    if sample is not None:
        if sample < 1:
            raise ConfigError(f"[mutation] sample must be >= 1, got {sample}")
        if sample < len(live):
            keep = set(np.random.default_rng(seed).choice(len(live), size=sample, replace=False).tolist())
            live = [m for j, m in enumerate(live) if j in keep]
    screened, rep = {}, {}
    live_set = set(live)
    for m in picked:
        s = report[m.id]
        if s.live:
            continue
        screened[m.id] = str(s.outcome.value if hasattr(s.outcome, "value") else s.outcome)
        if s.outcome == MutantOutcome.DUPLICATE and getattr(s, "duplicate_of", None):
            rep[m.id] = s.duplicate_of
    run = tuple(m for m in live)
    # the representative of a selected duplicate must run, even if the sample left it out
    for d, r in rep.items():
        if r not in live_set and sample is None:
            run += (r,)
            live_set.add(r)
    return MutantSelection(run=run, screened=screened, represented_by=rep,
                           unit={m.id: m.unit for m in cat.mutants if m.id in live_set or m.id in screened},
                           operator={m.id: m.operator for m in cat.mutants if m.id in live_set or m.id in screened})
