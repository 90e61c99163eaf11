"""Unit examples for screening mutants: inputs on which each unit is called, with realistic shapes.

Screening a mutant (:mod:`faultlab.mutation.screening`) compares its unit's outputs with the
original unit's on a few inputs per unit.  The inputs come from two places:

* the hand-written :class:`~faultlab.faults.UnitExample` inputs of the built-in faults
  (:mod:`faultlab.faults.builtin`; small, chosen to expose particular mistakes), and
* **recorded calls**: the SLAM runs a short scenario with every unit wrapped by a recorder that
  keeps a deep copy of the arguments of a few calls (the first, some later ones, and the first
  call whose output has another kind, e.g. the first resampling that returns indices instead of
  None).  These are exactly the inputs the units see in a campaign: N particles, k
  observations per step, weights after real updates, a particle state after resampling.

Recording works for any SLAM whose units live in a steps dataclass and that has
``with_steps(steps)`` (the fault contract), so other SLAMs written as units get examples
without writing any.  A recorded example replays the call with fresh copies of the arguments,
a random generator in the state it had at the call included, so the original and a mutant see
the same random draws.
"""

from __future__ import annotations

import copy
import dataclasses
import functools
import math
from collections.abc import Callable, Mapping

import numpy as np

from faultlab.errors import FaultError
from faultlab.faults.builtin import BUILTIN_FAULTS
from faultlab.faults.check import check_scenario
from faultlab.faults.fault import UnitExample
from faultlab.mutation.source import unit_functions
from faultlab.slam.fastslam import FastSlam, FastSlamConfig, FastSlamSteps
from faultlab.slam.protocol import Observations
from faultlab.slam.particles import ParticleState

__all__ = [
    "EXAMPLE_PARTICLES",
    "EXAMPLE_STEPS",
    "RECORDED_CALLS",
    "EXTRA_EXAMPLES",
    "record_unit_examples",
    "fault_unit_examples",
    "unit_examples",
]

#: Particles of the FastSLAM whose unit calls are recorded.
EXAMPLE_PARTICLES = 50
#: Active steps of the recorded run (on :func:`faultlab.faults.check.check_scenario`, whose
#: inactivity phase comes on top).
EXAMPLE_STEPS = 60
#: Call numbers (0-based, per unit) that are always recorded, if the unit is called that often.
RECORDED_CALLS = (0, 3, 10, 40)


def _kind(value) -> object:
    """The structure of an output, ignoring sizes: None, array rank and dtype kind, tuple of kinds, type."""
    if value is None:
        return None
    if isinstance(value, np.ndarray):
        return ("array", value.ndim, value.dtype.kind)
    if isinstance(value, tuple):
        return tuple(_kind(v) for v in value)
    return type(value).__name__


class _Recorder:
    """Stands in for one unit: calls it and keeps deep copies of the arguments of selected calls."""

    def __init__(self, name: str, unit: Callable, limit: int) -> None:
        self.name = name
        self.unit = unit
        self.limit = limit
        self.calls = 0
        self.kept: list[tuple[int, tuple[tuple, dict]]] = []
        self.kinds: set = set()
        self.memo: dict[int, object] = {}

    def __call__(self, *args, **kwargs):
        n = self.calls
        self.calls += 1
        snapshot = None
        if len(self.kept) < self.limit:
            snapshot = copy.deepcopy((args, kwargs), dict(self.memo))
        out = self.unit(*args, **kwargs)
        kind = _kind(out)
        if snapshot is not None and (n in RECORDED_CALLS or kind not in self.kinds):
            self.kept.append((n, snapshot))
        self.kinds.add(kind)
        return out


def record_unit_examples(slam, scenario, *, rng: np.random.Generator, per_unit: int = 4,
                         estimate_every: int = 20) -> dict[str, tuple[UnitExample, ...]]:
    """Examples for every unit of ``slam``: the arguments of some of its calls in a run on ``scenario``.

    Parameters
    ----------
    slam : SlamAdapter with ``steps`` and ``with_steps``
        The SLAM (not modified; a copy with recording units runs).
    scenario : faultlab.scenario.model.Scenario
    rng : numpy.random.Generator
        The SLAM's randomness for the run.
    per_unit : int
        At most this many examples per unit.
    estimate_every : int
        The estimate is taken every this many steps (and at the end), so units that only the
        estimate calls (``extract_map``) are recorded more than once.

    Returns
    -------
    dict
        Unit name -> recorded :class:`~faultlab.faults.UnitExample` (units never called are absent).
    """
    if not (dataclasses.is_dataclass(getattr(slam, "steps", None)) and callable(getattr(slam, "with_steps", None))):
        raise FaultError(f"{type(slam).__name__} has no replaceable units (steps / with_steps); "
                         f"cannot record unit examples")
    units = unit_functions(slam.steps)
    recorders = {name: _Recorder(name, unit, per_unit) for name, unit in units.items()}
    memo = {id(r): r.unit for r in recorders.values()}  # a recorded argument names the unit, not its recorder
    for r in recorders.values():
        r.memo = memo
    recording = slam.with_steps(dataclasses.replace(slam.steps, **recorders))
    recording.reset(scenario.start_pose, rng=rng)
    offsets, controls = scenario.obs_offsets, scenario.controls
    for t in range(scenario.n_steps):
        a, b = offsets[t], offsets[t + 1]
        recording.step(controls[t], Observations(scenario.obs_range[a:b], scenario.obs_bearing[a:b],
                                                 scenario.obs_ids[a:b]))
        if (t + 1) % estimate_every == 0:
            recording.estimate()
    recording.estimate()
    where = f"{getattr(slam, 'name', type(slam).__name__)} run on a {scenario.n_steps}-step scenario"
    return {name: tuple(UnitExample(functools.partial(copy.deepcopy, snapshot), f"recorded: call {n} in a {where}")
                        for n, snapshot in r.kept)
            for name, r in recorders.items() if r.kept}


def fault_unit_examples(faults=BUILTIN_FAULTS) -> dict[str, tuple[UnitExample, ...]]:
    """The hand-written examples of ``faults``, by the unit they call (each example once)."""
    out: dict[str, list[UnitExample]] = {}
    seen: set = set()
    for fault in faults:
        for ex in fault.examples:
            key = (fault.step, ex.make_args)
            if key not in seen:
                seen.add(key)
                out.setdefault(fault.step, []).append(ex)
    return {k: tuple(v) for k, v in out.items()}


# --------------------------------------------------------------------------- hand-written examples

def _ex_wrap_boundaries():
    """Angles on and beyond the wrap's boundaries: -pi stays, pi and 3 pi become -pi."""
    a = np.array([-math.pi, math.pi, 3.0 * math.pi, -2.5 * math.pi, 0.3, 7.0, -7.0, 1e-17])
    return (a,), {}


def _ex_extract_map():
    """Four particles with distinct maps, resampled lineage and unequal weights (best: particle 2)."""
    n, cap = 4, 4
    st = ParticleState.initial(np.zeros(3), n, capacity=cap)
    mu = np.arange(n * cap * 2, dtype=float).reshape(n, cap, 2) * 0.25 - 3.0
    P = np.tile(np.eye(2), (n, cap, 1, 1)) * np.arange(1.0, 1.0 + n)[:, None, None, None]
    anc = np.array([[0, 1, 2, 0], [1, 1, 3, 1], [2, 0, 2, 2], [3, 3, 1, 3]], dtype=np.int32)
    return (st.replace(ids=np.array([7, 3, 12], dtype=np.int64), mu=mu, P=P, anc=anc,
                       lineage=np.array([1, 0, 3, 2], dtype=np.intp),
                       logw=np.log(np.array([0.1, 0.2, 0.4, 0.3])),
                       poses=np.arange(12.0).reshape(n, 3)),), {}


def _ex_effective_sample_size():
    return (np.array([0.5, 0.25, 0.125, 0.0625, 0.0625]),), {}


#: Hand-written examples for units whose built-in-fault examples do not cover them well.
EXTRA_EXAMPLES: dict[str, tuple[UnitExample, ...]] = {
    "wrap_heading": (UnitExample(_ex_wrap_boundaries, "angles on and beyond -pi and pi"),),
    "wrap_bearing": (UnitExample(_ex_wrap_boundaries, "angles on and beyond -pi and pi"),),
    "extract_map": (UnitExample(_ex_extract_map, "unequal weights, resampled lineage, distinct maps"),),
    "effective_sample_size": (UnitExample(_ex_effective_sample_size, "unequal weights"),),
}


@functools.lru_cache(maxsize=8)
def _reference_examples(particles: int, n_steps: int, seed: int) -> dict[str, tuple[UnitExample, ...]]:
    slam = FastSlam(FastSlamConfig(particles=particles))
    recorded = record_unit_examples(slam, check_scenario(seed=seed, n_steps=n_steps),
                                    rng=np.random.default_rng(np.random.SeedSequence([seed, 2])))
    return _merge(fault_unit_examples(), EXTRA_EXAMPLES, recorded)


def _merge(*parts: Mapping[str, tuple[UnitExample, ...]]) -> dict[str, tuple[UnitExample, ...]]:
    out: dict[str, tuple[UnitExample, ...]] = {}
    for part in parts:
        for unit, exs in part.items():
            out[unit] = out.get(unit, ()) + tuple(exs)
    return out


def unit_examples(slam=None, *, n_steps: int = EXAMPLE_STEPS, seed: int = 0) -> dict[str, tuple[UnitExample, ...]]:
    """Unit examples for screening the mutants of ``slam`` (default: the reference FastSLAM 1.0).

    For the reference FastSLAM (reference units, default settings; the number of particles does
    not matter): the built-in faults' examples, :data:`EXTRA_EXAMPLES` and calls recorded in a
    run of FastSLAM with :data:`EXAMPLE_PARTICLES` particles on the check scenario
    (:func:`faultlab.faults.check.check_scenario`, ``n_steps`` active steps, seed ``seed``),
    cached.  For any other SLAM with units: the calls recorded in its own run on the same
    scenario, plus the hand-written examples if its units are :class:`FastSlamSteps`.

    Returns
    -------
    dict
        Unit name -> tuple of :class:`~faultlab.faults.UnitExample`.
    """
    if slam is None or (isinstance(slam, FastSlam) and type(slam.steps) is FastSlamSteps
                        and slam.steps.replaced() == ()
                        and dataclasses.replace(slam.config, particles=EXAMPLE_PARTICLES)
                        == FastSlamConfig(particles=EXAMPLE_PARTICLES)):
        return _reference_examples(EXAMPLE_PARTICLES, n_steps, seed)
    recorded = record_unit_examples(slam, check_scenario(seed=seed, n_steps=n_steps),
                                    rng=np.random.default_rng(np.random.SeedSequence([seed, 2])))
    if type(getattr(slam, "steps", None)) is FastSlamSteps:
        return _merge(fault_unit_examples(), EXTRA_EXAMPLES, recorded)
    return recorded
