"""The built-in metamorphic relations of range-bearing SLAM with known correspondences.

============== =============================================================================
relation       follow-up case -> expected follow-up estimate
============== =============================================================================
rigid_motion   world, path and start pose rotated by ``angle`` and shifted by ``translation``
               (the sensor trace is unchanged: it is relative to the vehicle) -> the source
               estimate moved the same way
id_permutation landmark ids relabelled by a permutation, each step's observations listed in the
               order of the new ids -> the source map with its ids relabelled
bearing_turn   ``turns * 2 pi`` added to every bearing -> the same estimate
halved_noise   every observation's deviation from the noise-free measurement (noise, bias and
               outliers alike) halved -> a map error against the ground truth that is not larger
============== =============================================================================

The first three need no ground truth: they compare the follow-up run with the source run.
``halved_noise`` compares the map errors of the two runs against the scenario's own ground truth
(which faultlab has, since it generated the case), so it is a weaker, truth-based oracle; it is
kept because it checks that the SLAM *uses* its measurements (a SLAM whose error does not drop
when its measurements improve ignores or mis-weights them).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from faultlab.errors import ConfigError, ScenarioError
from faultlab.metamorphic.relation import (
    MetamorphicRelation,
    RelationExample,
    map_error,
    with_record,
)
from faultlab.scenario.model import Scenario
from faultlab.scenario.trace import wrap_angle
from faultlab.slam.protocol import Estimate
from faultlab.space.case import FIXED_VALUES, CaseSpec

__all__ = ["RigidMotion", "IdPermutation", "IdRelabel", "BearingTurn", "HalvedNoise", "BUILTIN_RELATIONS", "example_scenario",
           "true_measurements"]

_TWO_PI = 2.0 * math.pi


# --------------------------------------------------------------------------- the examples' source case

def example_scenario() -> Scenario:
    """A hand-made two-step source case (the relations' examples are computed by hand from it).

    Landmarks 10 at (2, 1) and 20 at (0, 2).  Step 0: drive 1 m from (0, 0, 0) to (1, 0, 0) and
    see both: landmark 10 at range sqrt(2) + 0.2 (0.2 m of noise) and bearing pi/4, landmark 20 at
    range sqrt(5) and bearing atan2(2, -1) + 0.1 (0.1 rad of noise).  Step 1: turn by pi/2 on the
    spot and see landmark 10 at range sqrt(2), bearing -pi/4 (exact).
    """
    r2, r5 = math.sqrt(2.0), math.sqrt(5.0)
    return Scenario(
        case=CaseSpec(FIXED_VALUES), seed=None,
        landmarks=np.array([[2.0, 1.0], [0.0, 2.0]]), landmark_ids=np.array([10, 20], dtype=np.int64),
        true_poses=np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 0.0, math.pi / 2]]),
        controls=np.array([[1.0, 0.0], [0.0, math.pi / 2]]),
        obs_offsets=np.array([0, 2, 3], dtype=np.int64),
        obs_range=np.array([r2 + 0.2, r5, r2]),
        obs_bearing=np.array([math.pi / 4, math.atan2(2.0, -1.0) + 0.1, -math.pi / 4]),
        obs_ids=np.array([10, 20, 10], dtype=np.int64))


# --------------------------------------------------------------------------- rigid motion

def _rotation(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s], [s, c]])


class RigidMotion(MetamorphicRelation):
    """Rotate and shift the whole world: the estimate must rotate and shift the same way.

    The landmarks, the true path and the start pose are moved by ``x -> R(angle) x + translation``
    (headings turn by ``angle``, wrapped to [-pi, pi)); the controls and observations are
    relative to the vehicle and stay as they are, so only the start pose the SLAM is given changes.
    A correct SLAM is equivariant: its follow-up estimate is its source estimate moved the same
    way.  The distance is rigid-motion invariant, so comparing in the follow-up's frame is the same
    as comparing after undoing the motion.

    Parameters
    ----------
    angle : float, optional
        rad; default: uniform in [-pi, pi) from ``rng``.
    translation : (2,) array_like, optional
        m; default: uniform in [-max_shift, max_shift]^2 from ``rng``.
    max_shift : float
        m (default 10).
    """

    name = "rigid_motion"
    description = "rotating and shifting the world and start pose moves the estimate the same way"

    def __init__(self, angle: float | None = None, translation=None, *, max_shift: float = 10.0):
        self.angle = None if angle is None else float(angle)
        self.translation = None if translation is None else np.asarray(translation, dtype=float).reshape(2)
        self.max_shift = float(max_shift)

    def transform(self, scenario: Scenario, rng: np.random.Generator) -> Scenario:
        angle = float(rng.uniform(-math.pi, math.pi)) if self.angle is None else self.angle
        shift = rng.uniform(-self.max_shift, self.max_shift, size=2) if self.translation is None else self.translation
        R = _rotation(angle)
        poses = np.array(scenario.true_poses, dtype=float)
        poses[:, :2] = poses[:, :2] @ R.T + shift
        poses[:, 2] = wrap_angle(poses[:, 2] + angle)
        return with_record(scenario, self.name, landmarks=np.asarray(scenario.landmarks, float) @ R.T + shift,
                           true_poses=poses, angle=angle, translation=np.asarray(shift, dtype=float))

    def expected(self, estimate: Estimate, followup: Scenario) -> Estimate:
        p = self.parameters(followup)
        R, shift = _rotation(p["angle"]), np.asarray(p["translation"], dtype=float)
        pose = np.asarray(estimate.pose, dtype=float)
        moved = np.array([*(R @ pose[:2] + shift), float(wrap_angle(pose[2] + p["angle"]))])
        return Estimate(moved, np.asarray(estimate.landmark_ids),
                        np.asarray(estimate.landmarks, dtype=float).reshape(-1, 2) @ R.T + shift)

    examples = (
        RelationExample(
            source=example_scenario, options={"angle": math.pi / 2, "translation": (1.0, 0.0)},
            # (x, y) -> (-y + 1, x); headings + pi/2, and pi wraps to -pi
            followup={"landmarks": [[0.0, 2.0], [-1.0, 0.0]],
                      "true_poses": [[1.0, 0.0, math.pi / 2], [1.0, 1.0, math.pi / 2], [1.0, 1.0, -math.pi]],
                      "start_pose": [1.0, 0.0, math.pi / 2]},
            estimate=Estimate(np.array([1.0, 0.0, 0.0]), np.array([10]), np.array([[2.0, 1.0]])),
            expected=Estimate(np.array([1.0, 1.0, math.pi / 2]), np.array([10]), np.array([[0.0, 2.0]])),
            note="a quarter turn and 1 m along x"),
        RelationExample(
            source=example_scenario, options={"angle": 0.0, "translation": (-3.0, 0.5)},
            followup={"landmarks": [[-1.0, 1.5], [-3.0, 2.5]],
                      "true_poses": [[-3.0, 0.5, 0.0], [-2.0, 0.5, 0.0], [-2.0, 0.5, math.pi / 2]]},
            note="a pure translation"),
    )


# --------------------------------------------------------------------------- id permutation

class IdPermutation(MetamorphicRelation):
    """Relabel the landmarks: the map must be the same with its ids relabelled.

    Every id is replaced by ``mapping[id]``, a permutation of the map's ids, in the map and in
    the observations, and each step's observations are listed in increasing order of the new ids
    (as the generator lists them), so the order in which the SLAM sees a step's observations
    changes too.  With known correspondences, ids are only names: a correct SLAM's follow-up map
    is its source map with the ids relabelled.

    The reordering assumes that a step's result does not depend on the order of its observations,
    true of a filter that processes them jointly or independently (faultlab's SLAMs) but not of the
    textbook's sequential EKF update, which linearises each observation at the state the previous
    one left: reversing a step's observations moves such a filter's map by millimetres.  For such a
    SLAM use ``keep_order=True``: the observations keep their order and only their ids change.

    Parameters
    ----------
    mapping : mapping of int to int, optional
        Old id -> new id, a permutation of the map's ids; default: a uniform random one from ``rng``.
    keep_order : bool
        Keep each step's observations in their order (relabel only); default: list them by new id.
    """

    name = "id_permutation"
    description = "relabelling the landmark ids (and the order of each step's observations) relabels the map"

    def __init__(self, mapping: dict[int, int] | None = None, *, keep_order: bool = False):
        self.mapping = None if mapping is None else {int(k): int(v) for k, v in dict(mapping).items()}
        self.keep_order = bool(keep_order)

    def transform(self, scenario: Scenario, rng: np.random.Generator) -> Scenario:
        old = np.asarray(scenario.landmark_ids, dtype=np.int64)
        if self.mapping is None:
            new = rng.permutation(old)
        else:
            if sorted(self.mapping) != sorted(old.tolist()) or sorted(self.mapping.values()) != sorted(old.tolist()):
                raise ConfigError(f"{self.name}: mapping must be a permutation of the map's ids "
                                  f"{sorted(old.tolist())}, got {self.mapping}")
            new = np.array([self.mapping[int(i)] for i in old], dtype=np.int64)
        relabel = _Relabel(old, new)
        obs_new = relabel(scenario.obs_ids)
        counts = np.diff(scenario.obs_offsets)
        step = np.repeat(np.arange(counts.size), counts)
        order = np.arange(obs_new.size) if self.keep_order else np.lexsort((obs_new, step))  # by step, new id
        return with_record(scenario, self.name, landmark_ids=new, obs_ids=obs_new[order],
                           obs_range=np.asarray(scenario.obs_range)[order],
                           obs_bearing=np.asarray(scenario.obs_bearing)[order], old_ids=old, new_ids=new)

    def expected(self, estimate: Estimate, followup: Scenario) -> Estimate:
        p = self.parameters(followup)
        relabel = _Relabel(np.asarray(p["old_ids"], dtype=np.int64), np.asarray(p["new_ids"], dtype=np.int64))
        return Estimate(np.asarray(estimate.pose), relabel(estimate.landmark_ids), np.asarray(estimate.landmarks))

    examples = (
        RelationExample(
            source=example_scenario, options={"mapping": {10: 20, 20: 10}},
            # step 0 saw (10, 20) -> relabelled (20, 10) -> listed by new id: old 20 first
            followup={"landmark_ids": [20, 10], "obs_ids": [10, 20, 20],
                      "obs_range": [math.sqrt(5.0), math.sqrt(2.0) + 0.2, math.sqrt(2.0)],
                      "obs_bearing": [math.atan2(2.0, -1.0) + 0.1, math.pi / 4, -math.pi / 4]},
            estimate=Estimate(np.array([1.0, 0.0, 0.0]), np.array([10]), np.array([[2.0, 1.0]])),
            expected=Estimate(np.array([1.0, 0.0, 0.0]), np.array([20]), np.array([[2.0, 1.0]])),
            note="swapping the two ids reorders step 0's observations"),
        RelationExample(
            source=example_scenario, options={"mapping": {10: 10, 20: 20}},
            followup={}, note="the identity permutation changes nothing"),
    )


class IdRelabel(IdPermutation):
    """Relabel the landmarks and keep each step's observations in their order.

    :class:`IdPermutation` with ``keep_order=True`` under its own name, so that a check can ask for it:
    the relation that holds for a sequential EKF update (each observation linearised at the state the
    previous one left), whose map legitimately depends on the order of a step's observations.

    Parameters
    ----------
    mapping : mapping of int to int, optional
        Old id -> new id, a permutation of the map's ids; default: a uniform random one from ``rng``.
    """

    name = "id_relabel"
    description = "relabelling the landmark ids, each step's observations kept in their order, relabels the map"

    def __init__(self, mapping: dict[int, int] | None = None):
        super().__init__(mapping, keep_order=True)

    examples = (
        RelationExample(
            source=example_scenario, options={"mapping": {10: 20, 20: 10}},
            # step 0 saw (10, 20) -> relabelled (20, 10), kept in that order
            followup={"landmark_ids": [20, 10], "obs_ids": [20, 10, 20]},
            estimate=Estimate(np.array([1.0, 0.0, 0.0]), np.array([10]), np.array([[2.0, 1.0]])),
            expected=Estimate(np.array([1.0, 0.0, 0.0]), np.array([20]), np.array([[2.0, 1.0]])),
            note="swapping the two ids keeps step 0's order: ranges and bearings stay where they were"),
    )


class _Relabel:
    """Vectorised id relabelling ``old[i] -> new[i]`` (ids not in ``old`` are an error)."""

    def __init__(self, old: np.ndarray, new: np.ndarray):
        order = np.argsort(old)
        self.old, self.new = np.asarray(old, dtype=np.int64)[order], np.asarray(new, dtype=np.int64)[order]

    def __call__(self, ids) -> np.ndarray:
        ids = np.asarray(ids, dtype=np.int64)
        if not ids.size:
            return ids.copy()
        pos = np.minimum(np.searchsorted(self.old, ids), self.old.size - 1)
        if not np.array_equal(self.old[pos], ids):
            raise ScenarioError(f"id_permutation: id {ids[self.old[pos] != ids][0]} is not in the map")
        return self.new[pos]


# --------------------------------------------------------------------------- 2 pi on every bearing

class BearingTurn(MetamorphicRelation):
    """Add whole turns to every bearing: nothing may change.

    A bearing is an angle: ``b`` and ``b + turns * 2 pi`` are the same direction (Table I's
    rotation error is exactly such an offset).  A correct SLAM wraps angles where it compares
    them, so its estimate is the same up to rounding.

    Parameters
    ----------
    turns : int
        Whole turns added (default 1; negative subtracts).
    """

    name = "bearing_turn"
    description = "adding 2 pi to every bearing changes nothing"

    def __init__(self, turns: int = 1):
        if isinstance(turns, bool) or int(turns) != turns or turns == 0:
            raise ConfigError(f"{self.name}: turns must be a non-zero integer, got {turns!r}")
        self.turns = int(turns)

    def transform(self, scenario: Scenario, rng: np.random.Generator) -> Scenario:
        return with_record(scenario, self.name, obs_bearing=np.asarray(scenario.obs_bearing) + self.turns * _TWO_PI,
                           turns=self.turns)

    examples = (
        RelationExample(
            source=example_scenario,
            followup={"obs_bearing": [math.pi / 4 + _TWO_PI, math.atan2(2.0, -1.0) + 0.1 + _TWO_PI,
                                      -math.pi / 4 + _TWO_PI]},
            estimate=Estimate(np.array([1.0, 0.0, 0.0]), np.array([10]), np.array([[2.0, 1.0]])),
            expected=Estimate(np.array([1.0, 0.0, 0.0]), np.array([10]), np.array([[2.0, 1.0]])),
            note="one turn"),
        RelationExample(
            source=example_scenario, options={"turns": -2},
            followup={"obs_bearing": [math.pi / 4 - 2 * _TWO_PI, math.atan2(2.0, -1.0) + 0.1 - 2 * _TWO_PI,
                                      -math.pi / 4 - 2 * _TWO_PI]},
            note="two turns back"),
    )


# --------------------------------------------------------------------------- halved measurement noise

def true_measurements(scenario: Scenario) -> tuple[np.ndarray, np.ndarray]:
    """Noise-free range and bearing (wrapped to [-pi, pi)) of every observation, each shape (M,)."""
    scenario.require_truth("the noise-free measurements")
    ids = np.asarray(scenario.landmark_ids, dtype=np.int64)
    order = np.argsort(ids)
    obs_ids = np.asarray(scenario.obs_ids, dtype=np.int64)
    if not obs_ids.size:
        return np.empty(0), np.empty(0)
    pos = np.minimum(np.searchsorted(ids[order], obs_ids), ids.size - 1)
    if not np.array_equal(ids[order][pos], obs_ids):
        raise ScenarioError(f"observation of landmark {obs_ids[ids[order][pos] != obs_ids][0]}, which is not in the map")
    xy = np.asarray(scenario.landmarks, dtype=float)[order[pos]]
    step = np.repeat(np.arange(scenario.n_steps), np.diff(scenario.obs_offsets))
    pose = np.asarray(scenario.true_poses, dtype=float)[step + 1]  # observed after the step's motion
    d = xy - pose[:, :2]
    return np.hypot(d[:, 0], d[:, 1]), wrap_angle(np.arctan2(d[:, 1], d[:, 0]) - pose[:, 2])


def _offset_example() -> Scenario:
    """:func:`example_scenario` with a whole turn added to every bearing (Table I's rotation error)."""
    s = example_scenario()
    return replace(s, obs_bearing=s.obs_bearing + _TWO_PI)


class HalvedNoise(MetamorphicRelation):
    """Halve the measurement errors: the map error against the ground truth must not grow.

    Every observation moves half-way towards its noise-free value: ``r' = r - (r - r_true) / 2``
    and ``b' = b - wrap(b - b_true) / 2`` (the wrap keeps any whole turns of ``b``, e.g. Table I's
    rotation error).  Noise, bias and outliers are halved alike; the controls are unchanged.
    Measured against the ground truth (:func:`~faultlab.metamorphic.relation.map_error`, Kabsch
    aligned), the discrepancy is the *signed* change of the map error, follow-up minus source, in m:
    negative when the SLAM improves.  The spread between two seeds is the absolute difference of
    their map errors.  This relation needs the ground truth (``uses_truth``).
    """

    name = "halved_noise"
    description = "halving every measurement error does not make the map error against the truth larger"
    exact = False
    uses_truth = True

    def transform(self, scenario: Scenario, rng: np.random.Generator) -> Scenario:
        r_true, b_true = true_measurements(scenario)
        r, b = np.asarray(scenario.obs_range, dtype=float), np.asarray(scenario.obs_bearing, dtype=float)
        return with_record(scenario, self.name, obs_range=r - 0.5 * (r - r_true),
                           obs_bearing=b - 0.5 * wrap_angle(b - b_true), factor=0.5)

    def discrepancy(self, source: Estimate, followup_estimate: Estimate, *, source_scenario: Scenario,
                    followup: Scenario) -> float:
        return map_error(followup, followup_estimate) - map_error(source_scenario, source)

    def spread(self, a: Estimate, b: Estimate, *, scenario: Scenario) -> float:
        return abs(map_error(scenario, a) - map_error(scenario, b))

    examples = (
        RelationExample(
            source=example_scenario,
            followup={"obs_range": [math.sqrt(2.0) + 0.1, math.sqrt(5.0), math.sqrt(2.0)],
                      "obs_bearing": [math.pi / 4, math.atan2(2.0, -1.0) + 0.05, -math.pi / 4]},
            note="the 0.2 m range error and the 0.1 rad bearing error are halved, exact values stay"),
        RelationExample(
            source=_offset_example,
            followup={"obs_range": [math.sqrt(2.0) + 0.1, math.sqrt(5.0), math.sqrt(2.0)],
                      "obs_bearing": [math.pi / 4 + _TWO_PI, math.atan2(2.0, -1.0) + 0.05 + _TWO_PI,
                                      -math.pi / 4 + _TWO_PI]},
            note="a bearing offset by a whole turn keeps its turn"),
    )


#: The built-in relations, one instance each (random parameters drawn per check).
BUILTIN_RELATIONS: tuple[MetamorphicRelation, ...] = (RigidMotion(), IdPermutation(), IdRelabel(), BearingTurn(),
                                                       HalvedNoise())
