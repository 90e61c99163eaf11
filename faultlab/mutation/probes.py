"""Screening mutants of user source on probe scenarios, before any campaign.

A user's SLAM has no recorded unit examples, so each mutant runs the whole SLAM on a few small
*probe* scenarios, each with its own SLAM seed -- the same seeds for the original and every mutant
(common random numbers) -- and its final estimates (pose, landmark ids and positions) are
fingerprinted bit for bit (:func:`~faultlab.mutation.screening.unit_fingerprint`).  Classes:

* **invalid** -- the mutated module does not compile or cannot be imported, or the SLAM factory
  raises with it: the mutant cannot run, it is neither killed nor survived;
* **equivalent** -- estimates bit-identical to the original's on every probe; a mutant whose change
  lies in the body of a function the original never calls on the probes (:func:`probe_coverage`)
  is equivalent on them without running (the mutated module differs only in code that does not run);
* **duplicate** -- estimates bit-identical to an earlier (in generation order) live mutant's on
  every probe, including failing the same way: only that one runs;
* **live**, and among the live ones **trivial**: the SLAM fails (raises, returns a non-finite
  map, or exceeds the time limit) on *every* probe.  Every test case kills such a mutant, so it
  says nothing about a suite; the informative score leaves it out (declared here, before the
  campaign runs).

Probes are evidence, not proof: a mutant equivalent on the probes may differ on other inputs.
Each probe run has a wall-clock limit (SIGALRM, in a process's main thread), so a mutant stuck in
a loop counts as failing.  Screening runs mutant by mutant in ``jobs`` processes; the result does
not depend on ``jobs``.
"""

from __future__ import annotations

import importlib.util
import signal
import sys
import threading
from collections.abc import Container, Sequence
from dataclasses import dataclass

import numpy as np

from faultlab.mutation.outcome import MutantOutcome
from faultlab.mutation.screening import unit_fingerprint
from faultlab.mutation.target import SourceMutant, mutated_modules, factory_module

__all__ = ["ProbeScreening", "screen_on_probes", "probe_runs", "probe_coverage", "classify_probes", "PROBE_TIME_LIMIT_S"]

#: Wall-clock limit of one probe run of one mutant.
PROBE_TIME_LIMIT_S = 20.0


@dataclass(frozen=True)
class ProbeScreening:
    """The screening of one mutant on the probes.

    ``outcome`` is INVALID, EQUIVALENT or DUPLICATE, or None (live); ``trivial`` marks a live
    mutant that failed on every probe; ``reason`` says why in one line.
    """

    mutant: str
    outcome: MutantOutcome | None
    reason: str
    duplicate_of: str | None = None
    trivial: bool = False

    @property
    def label(self) -> str:
        return "live" if self.outcome is None else str(self.outcome.value)


class _ProbeTimeout(BaseException):
    pass


def _on_alarm(signum, frame):
    raise _ProbeTimeout()


def _run_probe(build, scenario, seed: int, limit: float | None) -> str:
    """Fingerprint of one probe run: the estimate's, or ``fails:<why>``."""
    from faultlab.slam.protocol import run_slam

    armed = bool(limit) and threading.current_thread() is threading.main_thread() and hasattr(signal, "setitimer")
    previous = signal.signal(signal.SIGALRM, _on_alarm) if armed else None
    try:
        if armed:
            signal.setitimer(signal.ITIMER_REAL, limit)
        try:
            with np.errstate(all="ignore"):
                est = run_slam(build(), scenario, rng=np.random.default_rng(seed))
        finally:
            if armed:
                signal.setitimer(signal.ITIMER_REAL, 0)
    except _ProbeTimeout:
        return "fails:timeout"
    except Exception as exc:  # a mutant may raise anything; a non-finite map is SlamOutputError
        return f"fails:{type(exc).__name__}"
    finally:
        if armed:
            signal.signal(signal.SIGALRM, previous)
    return unit_fingerprint((est.pose, est.landmark_ids, est.landmarks), (), {})


def probe_fingerprints(mutant_id: str | None, slam_spec, probes: Sequence, seeds: Sequence[int], *,
                       limit: float | None = PROBE_TIME_LIMIT_S) -> tuple[str, ...] | str:
    """The probe fingerprints of the original (``mutant_id`` None) or of a mutant; for a mutant that
    cannot be imported or built, the error text (a str, not a tuple)."""
    if mutant_id is None:
        build = slam_spec.build
    else:
        try:
            with mutated_modules(mutant_id, factory_module(slam_spec.name)):
                slam_spec.build()
        except (Exception, SystemExit) as exc:  # a mutated module may raise anything at import
            return f"{type(exc).__name__}: {exc}".splitlines()[0][:300]

        def build():
            with mutated_modules(mutant_id, factory_module(slam_spec.name)):
                return slam_spec.build()
    return tuple(_run_probe(build, s, seed, limit) for s, seed in zip(probes, seeds))


def _chunk(ids: Sequence[str], slam_spec, probes, seeds, limit) -> list:
    return [probe_fingerprints(i, slam_spec, probes, seeds, limit=limit) for i in ids]


def probe_runs(ids: Sequence[str], slam_spec, probes: Sequence, seeds: Sequence[int], *, jobs: int = 1,
               limit: float | None = PROBE_TIME_LIMIT_S) -> dict[str, tuple[str, ...] | str]:
    """Mutant id -> :func:`probe_fingerprints` of each of ``ids``, run in ``jobs`` processes (the
    result does not depend on ``jobs``)."""
    ids = list(ids)
    if jobs > 1 and len(ids) > 1:
        from joblib import Parallel, delayed

        chunks = [c for c in (ids[i::jobs] for i in range(jobs)) if c]
        parts = Parallel(n_jobs=len(chunks), backend="loky")(delayed(_chunk)(c, slam_spec, probes, seeds, limit)
                                                             for c in chunks)
        return {i: f for c, p in zip(chunks, parts) for i, f in zip(c, p)}
    return dict(zip(ids, _chunk(ids, slam_spec, probes, seeds, limit)))


def probe_coverage(module: str, slam_spec, probes: Sequence, seeds: Sequence[int], *,
                   limit: float | None = PROBE_TIME_LIMIT_S) -> frozenset[int]:
    """The first lines (``co_firstlineno``: a decorated function's first decorator) of the code
    objects of module ``module`` that run when it is imported (executed once more, into a module
    object of its own) or when the original SLAM runs the probes (a profile hook, in this
    process's main thread)."""
    ran: set[int] = set()

    def hook(frame, event, arg):
        if event == "call" and frame.f_globals.get("__name__") == module:
            ran.add(frame.f_code.co_firstlineno)

    spec = importlib.util.find_spec(module)
    previous = sys.getprofile()
    sys.setprofile(hook)
    try:
        spec.loader.exec_module(importlib.util.module_from_spec(spec))
        for scenario, seed in zip(probes, seeds):
            _run_probe(slam_spec.build, scenario, seed, limit)
    finally:
        sys.setprofile(previous)
    return frozenset(ran)


def classify_probes(ids: Sequence[str], found: dict, original: tuple[str, ...], *,
                    budget: int | None = None, never_run: Container[str] = ()) -> dict[str, ProbeScreening]:
    """The classes (see the module docstring) of ``ids`` in the order given, from their probe
    fingerprints ``found`` and the original's: a duplicate stands for the earliest in that order.

    Classifies the longest prefix of ``ids`` whose fingerprints are in ``found``, and with a
    ``budget``, stops after its ``budget``-th live mutant.  ``never_run``: mutants whose change
    lies in a function body the original never calls on the probes (their fingerprints are the
    original's without running them; the reason says so).
    """
    out: dict[str, ProbeScreening] = {}
    first: dict[tuple, str] = {}
    n_live = 0
    for i in ids:
        if budget is not None and n_live >= budget or i not in found:
            break
        fp = found[i]
        if isinstance(fp, str):
            out[i] = ProbeScreening(i, MutantOutcome.INVALID, f"cannot run: {fp}")
        elif i in never_run:
            out[i] = ProbeScreening(i, MutantOutcome.EQUIVALENT,
                                    f"its change lies in a function the original never calls on the {len(fp)} probes")
        elif fp == original:
            out[i] = ProbeScreening(i, MutantOutcome.EQUIVALENT,
                                    f"estimates bit-identical to the original's on all {len(fp)} probes")
        elif fp in first:
            out[i] = ProbeScreening(i, MutantOutcome.DUPLICATE,
                                    f"estimates bit-identical to {first[fp]}'s on all {len(fp)} probes",
                                    duplicate_of=first[fp])
        else:
            first[fp] = i
            n_live += 1
            fails = [f for f in fp if f.startswith("fails:")]
            trivial = len(fails) == len(fp)
            differ = sum(a != b for a, b in zip(fp, original))
            reason = (f"fails on every probe ({', '.join(sorted(set(f[6:] for f in fails)))})" if trivial else
                      f"differs from the original on {differ} of {len(fp)} probes")
            out[i] = ProbeScreening(i, None, reason, trivial=trivial)
    return out


def screen_on_probes(mutants: Sequence[SourceMutant], slam_spec, probes: Sequence, seeds: Sequence[int], *,
                     jobs: int = 1, limit: float | None = PROBE_TIME_LIMIT_S) -> dict[str, ProbeScreening]:
    """Classify ``mutants`` (see the module docstring): mutant id -> :class:`ProbeScreening`, in order.

    ``slam_spec`` builds the SLAM (``.build()``, ``.name``: the runner's SLAM spec); ``probes`` are
    scenarios and ``seeds`` their SLAM seeds.
    """
    ids = [m.id for m in mutants]
    original = probe_fingerprints(None, slam_spec, probes, seeds, limit=limit)
    return classify_probes(ids, probe_runs(ids, slam_spec, probes, seeds, jobs=jobs, limit=limit), original)
