"""The metamorphic-relation contract: a change of the test case and what it must do to the estimate.

A metamorphic relation (Chen et al., *Metamorphic testing: a review of challenges and
opportunities*, ACM CSUR 2018) is a second oracle that needs no ground truth: it transforms a
*source* test case into a *follow-up* case whose correct output is known **relative to the source
run's output**.  Running the SLAM under test on both and comparing the two estimates detects a
fault without knowing what the right map is, e.g. "rotating and shifting the whole world rotates
and shifts the map the same way".

A relation (a subclass of :class:`MetamorphicRelation`) provides:

* :meth:`~MetamorphicRelation.transform` ``(scenario, rng) -> follow-up scenario``: any random
  parameters come from ``rng`` and are recorded in the follow-up's ``meta["metamorphic"]``, so the
  follow-up describes itself;
* :meth:`~MetamorphicRelation.expected` ``(source estimate, follow-up) -> estimate``: what the
  follow-up run should estimate, given the source run's estimate (identity by default);
* :meth:`~MetamorphicRelation.discrepancy` and :meth:`~MetamorphicRelation.spread`: how far a
  follow-up run is from the expectation, and the same measure between two runs of the unmodified
  SLAM with different seeds (see :mod:`faultlab.metamorphic.check` for the decision rule, which
  also depends on :attr:`~MetamorphicRelation.exact`: whether the relation holds exactly or only
  on average);
* :attr:`~MetamorphicRelation.examples`: hand-made source cases with the follow-up values the
  transform must produce, run by one generic test for every relation, built-in or plugin.

Relations are stateless apart from their fixed parameters (constructor keyword arguments; None
means "draw from ``rng``"), so one instance serves any number of checks.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, ClassVar

import numpy as np

from faultlab.metrics.alignment import kabsch_rms
from faultlab.scenario.model import Scenario
from faultlab.slam.protocol import Estimate

__all__ = [
    "META_KEY",
    "RelationExample",
    "MetamorphicRelation",
    "estimate_distance",
    "truth_estimate",
    "map_error",
    "with_record",
]

#: Key of a follow-up scenario's ``meta`` under which a relation records its parameters.
META_KEY = "metamorphic"


@dataclass(frozen=True, eq=False)
class RelationExample:
    """A hand-made source case and what a relation's transform must make of it.

    Attributes
    ----------
    source : callable
        ``source() -> Scenario``, a small source case (called afresh for each use).
    followup : mapping
        Scenario attribute -> its expected value in the follow-up (hand-computed), e.g.
        ``{"landmarks": [[0, 2], [-1, 0]]}``; attributes not named must be unchanged unless
        listed in :attr:`changes`.
    options : mapping
        Keyword arguments of the relation's constructor that fix the transform's parameters
        (e.g. ``{"angle": pi / 2, "translation": (1, 0)}``).
    estimate, expected : Estimate, optional
        An estimate and what :meth:`MetamorphicRelation.expected` must turn it into.
    changes : tuple of str
        Attributes the transform may change beyond those in ``followup`` (checked only for shape).
    note : str
        What the example shows, one line.
    """

    source: Callable[[], Scenario]
    followup: Mapping[str, Any]
    options: Mapping[str, Any] = field(default_factory=dict)
    estimate: Estimate | None = None
    expected: Estimate | None = None
    changes: tuple[str, ...] = ()
    note: str = ""


class MetamorphicRelation(ABC):
    """A metamorphic relation of SLAM: a change of the test case and its effect on the estimate.

    Subclasses set :attr:`name` (lower-case snake_case, unique), :attr:`description` (one line)
    and :attr:`examples`, and implement :meth:`transform`; most also override :meth:`expected`.
    """

    #: Stable name (results tables, the command line).
    name: ClassVar[str]
    #: One line: the transformation and what must happen.
    description: ClassVar[str]
    #: True if the relation holds exactly for a correct algorithm (only rounding may separate the
    #: follow-up estimate from the expected one); False for a statistical relation that holds on average.
    exact: ClassVar[bool] = True
    #: True if :meth:`discrepancy` compares with the scenario's ground truth (not a truth-free oracle).
    uses_truth: ClassVar[bool] = False
    #: Unit of :meth:`discrepancy` and :meth:`spread` (for reports).
    unit: ClassVar[str] = "m"
    #: Examples run by the generic relation test.
    examples: ClassVar[tuple[RelationExample, ...]] = ()

    @abstractmethod
    def transform(self, scenario: Scenario, rng: np.random.Generator) -> Scenario:
        """The follow-up test case of ``scenario`` (not modified); random parameters from ``rng``.

        The follow-up records the relation's name and parameters in ``meta[META_KEY]``
        (see :func:`with_record`).
        """

    def expected(self, estimate: Estimate, followup: Scenario) -> Estimate:
        """What the follow-up run should estimate, given the source run's ``estimate`` (default: the same)."""
        return estimate

    def discrepancy(self, source: Estimate, followup_estimate: Estimate, *, source_scenario: Scenario,
                    followup: Scenario) -> float:
        """How far the follow-up run is from the relation's expectation, in :attr:`unit`.

        Default: :func:`estimate_distance` between :meth:`expected` of the source estimate and the
        follow-up estimate (``inf`` if they map different landmarks).
        """
        return estimate_distance(self.expected(source, followup), followup_estimate)

    def spread(self, a: Estimate, b: Estimate, *, scenario: Scenario) -> float:
        """The same measure between two runs of the source case with different seeds (default:
        :func:`estimate_distance`): the scale of variation that is not a violation."""
        return estimate_distance(a, b)

    def parameters(self, followup: Scenario) -> dict[str, Any]:
        """The parameters the transform recorded in ``followup`` (raises KeyError if it is not this relation's)."""
        record = followup.meta[META_KEY]
        if record.get("relation") != self.name:
            raise KeyError(f"{followup!r} is a follow-up of relation {record.get('relation')!r}, not {self.name!r}")
        return record

    def __repr__(self) -> str:
        return f"<metamorphic relation {self.name}>"


# --------------------------------------------------------------------------- helpers

def with_record(scenario: Scenario, relation: str, **arrays_and_parameters: Any) -> Scenario:
    """``scenario`` with ``meta[META_KEY] = {"relation": relation, **parameters}`` (JSON-friendly copies).

    Keyword arguments that are scenario attributes (``landmarks``, ``obs_bearing``, ...) replace
    those attributes; the others are recorded as parameters (numpy values converted to lists).
    """
    fields = {k: v for k, v in arrays_and_parameters.items() if hasattr(scenario, k) and k != "meta"}
    params = {k: (v.tolist() if isinstance(v, (np.ndarray, np.generic)) else v)
              for k, v in arrays_and_parameters.items() if k not in fields}
    meta = {**scenario.meta, META_KEY: {"relation": relation, **params}}
    out = replace(scenario, meta=meta, **fields)
    out.validate()
    return out


def estimate_distance(a: Estimate, b: Estimate) -> float:
    """RMS distance between two estimates of the same test case, m (unaligned).

    Over the ``M`` landmarks (matched by id) and the final position, ``M + 1`` points:
    ``sqrt((sum_i |a_i - b_i|^2 + |a_pose_xy - b_pose_xy|^2) / (M + 1))``.  ``inf`` if the two
    map different sets of landmarks (the heading is not compared: its error shows in the map).
    """
    ids_a = np.asarray(a.landmark_ids, dtype=np.int64)
    ids_b = np.asarray(b.landmark_ids, dtype=np.int64)
    if ids_a.size != ids_b.size:
        return math.inf
    oa, ob = np.argsort(ids_a), np.argsort(ids_b)
    if not np.array_equal(ids_a[oa], ids_b[ob]):
        return math.inf
    d = np.asarray(a.landmarks, dtype=float).reshape(-1, 2)[oa] - np.asarray(b.landmarks, dtype=float).reshape(-1, 2)[ob]
    dp = np.asarray(a.pose, dtype=float)[:2] - np.asarray(b.pose, dtype=float)[:2]
    return float(math.sqrt((float(np.sum(d * d)) + float(dp @ dp)) / (ids_a.size + 1)))


def map_error(scenario: Scenario, estimate: Estimate) -> float:
    """Kabsch-aligned RMS map error against the scenario's ground truth, m (NaN if nothing is mapped)."""
    scenario.require_truth("the map error against the ground truth")
    return kabsch_rms(scenario.landmark_ids, scenario.landmarks, estimate.landmark_ids, estimate.landmarks).rms


def truth_estimate(scenario: Scenario) -> Estimate:
    """The ground truth as an estimate: the final true pose and every landmark of the map."""
    scenario.require_truth("the ground truth as an estimate")
    return Estimate(scenario.true_poses[-1].copy(), np.asarray(scenario.landmark_ids, dtype=np.int64).copy(),
                    np.asarray(scenario.landmarks, dtype=float).copy())
