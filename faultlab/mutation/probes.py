"""Screening mutants of user source on probe scenarios, before any campaign.

A user's SLAM has no recorded unit examples, so each mutant runs the whole SLAM on a few small
*probe* scenarios, each with its own SLAM seed -- the same seeds for the original and every mutant
(common random numbers) -- and its final estimates (pose, landmark ids and positions) are
fingerprinted bit for bit (:func:`~faultlab.mutation.screening.unit_fingerprint`).  Classes:

* **invalid** -- the mutated module does not compile or cannot be imported, or the SLAM factory
  raises with it: the mutant cannot run, it is neither killed nor survived;
* **equivalent** -- estimates bit-identical to the original's on every probe;
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

import signal
import threading
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from faultlab.mutation.outcome import MutantOutcome
from faultlab.mutation.screening import unit_fingerprint
from faultlab.mutation.target import SourceMutant, mutated_modules, factory_module

__all__ = ["ProbeScreening", "screen_on_probes", "PROBE_TIME_LIMIT_S"]

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


def screen_on_probes(mutants: Sequence[SourceMutant], slam_spec, probes: Sequence, seeds: Sequence[int], *,
                     jobs: int = 1, limit: float | None = PROBE_TIME_LIMIT_S) -> dict[str, ProbeScreening]:
    """Classify ``mutants`` (see the module docstring): mutant id -> :class:`ProbeScreening`, in order.

    ``slam_spec`` builds the SLAM (``.build()``, ``.name``: the runner's SLAM spec); ``probes`` are
    scenarios and ``seeds`` their SLAM seeds.
    """
    ids = [m.id for m in mutants]
    original = probe_fingerprints(None, slam_spec, probes, seeds, limit=limit)
    if jobs > 1 and len(ids) > 1:
        from joblib import Parallel, delayed

        chunks = [ids[i::jobs] for i in range(jobs)]
        parts = Parallel(n_jobs=jobs, backend="loky")(delayed(_chunk)(c, slam_spec, probes, seeds, limit)
                                                      for c in chunks)
        found = {i: f for c, p in zip(chunks, parts) for i, f in zip(c, p)}
    else:
        found = dict(zip(ids, _chunk(ids, slam_spec, probes, seeds, limit)))
    out: dict[str, ProbeScreening] = {}
    first: dict[tuple, str] = {}
    for i in ids:
        fp = found[i]
        if isinstance(fp, str):
            out[i] = ProbeScreening(i, MutantOutcome.INVALID, f"cannot run: {fp}")
        elif fp == original:
            out[i] = ProbeScreening(i, MutantOutcome.EQUIVALENT,
                                    f"estimates bit-identical to the original's on all {len(fp)} probes")
        elif fp in first:
            out[i] = ProbeScreening(i, MutantOutcome.DUPLICATE,
                                    f"estimates bit-identical to {first[fp]}'s on all {len(fp)} probes",
                                    duplicate_of=first[fp])
        else:
            first[fp] = i
            fails = [f for f in fp if f.startswith("fails:")]
            trivial = len(fails) == len(fp)
            differ = sum(a != b for a, b in zip(fp, original))
            reason = (f"fails on every probe ({', '.join(sorted(set(f[6:] for f in fails)))})" if trivial else
                      f"differs from the original on {differ} of {len(fp)} probes")
            out[i] = ProbeScreening(i, None, reason, trivial=trivial)
    return out
