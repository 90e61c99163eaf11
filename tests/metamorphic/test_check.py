"""check_relation and the relation x fault matrix: the reference passes, faults violate, the rule by hand."""

import dataclasses
import functools
import math
from collections.abc import Callable

import numpy as np
import pytest

from faultlab.errors import ConfigError, SlamOutputError
from faultlab.faults import Fault, get_fault
from faultlab.metamorphic import (
    BUILTIN_RELATIONS,
    BearingTurn,
    HalvedNoise,
    IdPermutation,
    IdRelabel,
    RigidMotion,
    Verdict,
    check_relation,
    metamorphic_scenario,
    relation_matrix,
)
from faultlab.metamorphic.check import _decide
from faultlab.seeds import sensor_seed_sequence
from faultlab.slam import Estimate, FastSlam, FastSlamConfig, SlamAdapter
from faultlab.slam.protocol import run_slam

RELATION = {r.name: r for r in BUILTIN_RELATIONS}


def _rngs(k=3, seed=0):
    return [np.random.default_rng([seed, i]) for i in range(k)]


def _fastslam():
    return FastSlam(FastSlamConfig(particles=30))


@pytest.fixture(scope="module")
def case():
    return metamorphic_scenario(seed=0, n_steps=80)


# --------------------------------------------------------------------------- the reference FastSLAM and its faults

# Which built-in faults violate which relation on this case (found with `python -m faultlab metamorphic`),
# and faults that keep a relation's symmetry.  halved_noise is a statistical relation: its violations
# depend on the case (turn_before_drive violates it on the 80-step cases of seeds 0, 1, 2 with K = 5,
# not on their 150-step versions), so it is checked with 5 repetitions.
VIOLATIONS = [("rigid_motion", "missing_angle_wrap"), ("rigid_motion", "new_landmark_near_zero"),
              ("rigid_motion", "init_covariance_not_inverted"), ("id_permutation", "weight_overwritten"),
              ("bearing_turn", "missing_angle_wrap"), ("bearing_turn", "bearing_in_degrees"),
              ("halved_noise", "turn_before_drive")]
KEPT = [("rigid_motion", "motion_sign_error"), ("rigid_motion", "naive_resampling"),
        ("id_permutation", "missing_angle_wrap"), ("bearing_turn", "new_landmark_near_zero"),
        ("bearing_turn", "motion_sign_error")]
_EXACT = [RigidMotion(), IdPermutation(), BearingTurn()]


@pytest.fixture(scope="module")
def matrix(case):
    names = sorted({f for r, f in VIOLATIONS + KEPT if r != "halved_noise"})
    return relation_matrix(_fastslam, _EXACT, [get_fault(n) for n in names], case, rngs=_rngs(3),
                           description="the test case")


@pytest.fixture(scope="module")
def noise_matrix(case):
    return relation_matrix(_fastslam, [HalvedNoise()], [get_fault("turn_before_drive")], case, rngs=_rngs(5))


def _result(matrix, noise_matrix, relation, variant):
    return (noise_matrix if relation == "halved_noise" else matrix).results[(variant, relation)]


@pytest.mark.parametrize("relation", [r.name for r in _EXACT] + ["halved_noise"])
def test_reference_fastslam_satisfies_every_relation(relation, matrix, noise_matrix):
    res = _result(matrix, noise_matrix, relation, "baseline")
    assert res.verdict is Verdict.HOLDS, res.summary()
    assert res.basis == "seed spread" and res.discrepancies == res.baseline_discrepancies
    assert len(res.spreads) == len(res.discrepancies) * (len(res.discrepancies) - 1) // 2
    assert res.spread > 0  # the seeds really differ
    if res.exact:  # equivariant up to rounding
        assert max(res.discrepancies) < 1e-9


@pytest.mark.parametrize("relation, fault", VIOLATIONS)
def test_builtin_faults_violate_relations(relation, fault, matrix, noise_matrix):
    res = _result(matrix, noise_matrix, relation, fault)
    assert res.verdict is Verdict.VIOLATED, res.summary()
    assert res.statistic > res.tolerance
    if res.exact:
        assert res.basis == "baseline discrepancy" and res.tolerance == res.atol  # the reference's rounding < 1 µm
        assert res.statistic > 1e-3  # millimetres at least: not a rounding effect


@pytest.mark.parametrize("relation, fault", KEPT)
def test_faults_that_keep_a_symmetry_do_not_violate_it(relation, fault, matrix):
    res = matrix.results[(fault, relation)]
    assert res.verdict is Verdict.HOLDS, res.summary()
    assert max(res.discrepancies) < 1e-9


def test_matrix_cells_equal_single_checks_and_the_table_says_so(case, matrix):
    for variant, relation in [("weight_overwritten", IdPermutation()), ("new_landmark_near_zero", RigidMotion())]:
        single = check_relation(_fastslam, relation, case, rngs=_rngs(3), fault=get_fault(variant))
        assert matrix.results[(variant, relation.name)] == single
    assert matrix.variants[0] == "baseline"
    assert matrix.violations() == {
        "rigid_motion": ["init_covariance_not_inverted", "missing_angle_wrap", "new_landmark_near_zero"],
        "id_permutation": ["weight_overwritten"], "bearing_turn": ["bearing_in_degrees", "missing_angle_wrap"]}
    text = matrix.format()
    assert "the test case; 3 repetitions" in text
    assert "id_permutation (exact): violated by weight_overwritten" in text
    row = next(line for line in text.splitlines() if line.startswith("weight_overwritten"))
    assert row.split()[1:] == ["holds", f"{matrix.results[('weight_overwritten', 'rigid_motion')].statistic:.2g}",
                               "VIOLATED", f"{matrix.results[('weight_overwritten', 'id_permutation')].statistic:.2g}",
                               "holds", f"{matrix.results[('weight_overwritten', 'bearing_turn')].statistic:.2g}"]
    assert "WARNING" not in text


def test_same_rngs_same_result_and_one_draw_per_generator(case):
    a = check_relation(ToyMapper, RigidMotion(), case, rngs=_rngs(2, seed=5))
    b = check_relation(ToyMapper, RigidMotion(), case, rngs=_rngs(2, seed=5))
    assert a == b
    rngs = _rngs(2, seed=5)
    check_relation(ToyMapper, BearingTurn(), case, rngs=rngs)
    fresh = _rngs(2, seed=5)
    for used, new in zip(rngs, fresh):
        new.integers(2 ** 63)
        assert used.integers(1 << 30) == new.integers(1 << 30)


# --------------------------------------------------------------------------- the rule, by hand

def test_decision_rule_by_hand():
    exact, statistical = RigidMotion(), HalvedNoise()
    kw = dict(factor=2.0, atol=0.1, errors=[])
    d, base, spreads = [1.0, 3.0, math.nan, 2.0], [0.5, 0.1, 0.2, 0.3], [4.0, 6.0, 10.0]
    fault = _decide(exact, "f", d, base, spreads, **kw)
    assert (fault.statistic, fault.spread, fault.tolerance, fault.basis) == (2.0, 6.0, 1.0, "baseline discrepancy")
    assert fault.verdict is Verdict.VIOLATED  # median 2 > 2 x largest baseline discrepancy 0.5
    assert _decide(exact, "baseline", d, base, spreads, **kw).verdict is Verdict.HOLDS  # 2 <= 2 x 6
    stat = _decide(statistical, "f", d, base, spreads, **kw)
    assert (stat.tolerance, stat.basis, stat.verdict) == (12.0, "seed spread", Verdict.HOLDS)
    assert _decide(statistical, "f", [-5.0, -1.0], base, spreads, **kw).verdict is Verdict.HOLDS  # improvement
    tiny = _decide(exact, "f", [0.05, 0.05], [0.0, 0.0], [0.0], **kw)  # deterministic SLAM: atol decides
    assert (tiny.tolerance, tiny.verdict) == (0.1, Verdict.HOLDS)
    assert _decide(exact, "f", [math.inf, 0.0, math.inf], base, spreads, **kw).verdict is Verdict.VIOLATED
    crash = _decide(exact, "f", [math.nan, math.nan], base, spreads, **kw)
    assert crash.verdict is Verdict.CRASH and math.isnan(crash.statistic)


# --------------------------------------------------------------------------- a toy mapper with one unit

def _place(x, y, th, r, b):
    return np.column_stack([x + r * np.cos(th + b), y + r * np.sin(th + b)])


@dataclasses.dataclass(frozen=True)
class MapperSteps:
    place: Callable = _place


class ToyMapper(SlamAdapter):
    """Odometry, and each landmark where it was first seen (deterministic; one replaceable unit)."""

    name = "toy_mapper"

    def __init__(self, steps: MapperSteps = MapperSteps()):
        self.steps = steps

    def with_steps(self, steps):
        return ToyMapper(steps)

    def reset(self, pose, *, rng):
        self.pose, self.map = np.array(pose, dtype=float), {}

    def update(self, control, observations):
        x, y, th = self.pose
        x, y = x + control[0] * np.cos(th), y + control[0] * np.sin(th)
        th = (th + control[1] + np.pi) % (2 * np.pi) - np.pi
        self.pose = np.array([x, y, th])
        xy = self.steps.place(x, y, th, observations.ranges, observations.bearings)
        for i, p in zip(observations.ids.tolist(), xy):
            self.map.setdefault(i, p)

    def estimate(self):
        ids = np.array(sorted(self.map), dtype=np.int64)
        return Estimate(self.pose.copy(), ids, np.array([self.map[i] for i in ids]).reshape(-1, 2))


def _bearing_scaled(original):
    def place(x, y, th, r, b):
        return original(x, y, th, r, b * 1.001)
    return place


def _refuse_big_bearings(original):
    def place(x, y, th, r, b):
        if np.any(np.abs(b) > 4.0):
            raise ValueError("bearing out of range")
        return original(x, y, th, r, b)
    return place


def _always_crash(original):
    def place(x, y, th, r, b):
        raise RuntimeError("broken")
    return place


def _toy_fault(name, replacement):
    return Fault(name=f"toy/{name}", step="place", description="d", rationale="r", origin="test",
                 replacement=replacement)


def test_toy_mapper_faults_hold_violate_and_crash(case):
    ok = check_relation(ToyMapper, BearingTurn(), case, rngs=_rngs(2))
    assert ok.verdict is Verdict.HOLDS and ok.spread == 0.0 and ok.tolerance == ok.atol  # deterministic
    scaled = check_relation(ToyMapper, BearingTurn(), case, rngs=_rngs(2), fault=_toy_fault("scaled", _bearing_scaled))
    assert scaled.verdict is Verdict.VIOLATED and scaled.statistic > 1e-3
    # rotation-equivariant: scaling a bearing relative to the heading keeps the rigid-motion relation
    assert check_relation(ToyMapper, RigidMotion(), case, rngs=_rngs(2),
                          fault=_toy_fault("scaled", _bearing_scaled)).verdict is Verdict.HOLDS
    refuse = check_relation(ToyMapper, BearingTurn(), case, rngs=_rngs(2),
                            fault=_toy_fault("refuse", _refuse_big_bearings))
    assert refuse.verdict is Verdict.VIOLATED and refuse.discrepancies == (math.inf, math.inf)
    assert refuse.errors[0] == "rep 0 follow-up: ValueError: bearing out of range"
    crash = check_relation(ToyMapper, IdPermutation(), case, rngs=_rngs(2), fault=_toy_fault("crash", _always_crash))
    assert crash.verdict is Verdict.CRASH and len(crash.errors) == 4
    assert "crash" in crash.summary()


def test_bad_arguments_and_a_crashing_baseline_are_errors(case):
    with pytest.raises(ConfigError, match="at least 2 repetitions"):
        check_relation(ToyMapper, BearingTurn(), case, rngs=_rngs(1))
    with pytest.raises(ConfigError, match="numpy.random.Generator"):
        check_relation(ToyMapper, BearingTurn(), case, rngs=[1, 2])
    with pytest.raises(ConfigError, match="factor must be a finite number >= 0"):
        check_relation(ToyMapper, BearingTurn(), case, rngs=_rngs(2), factor=-1.0)
    with pytest.raises(SlamOutputError, match="the unmodified SLAM failed on the source case in repetition 0"):
        check_relation(lambda: ToyMapper(MapperSteps(_always_crash(_place))), BearingTurn(), case, rngs=_rngs(2))


# --------------------------------------------------------------------------- sensor faults

def _dropout(p):
    from faultlab.faults.sensorfaults import drop_observations

    return dataclasses.replace(get_fault("obs_dropout"), perturbation=functools.partial(drop_observations, p=p))


def test_total_dropout_feeds_the_slam_no_observation_and_changes_the_result(case):
    from faultlab.metamorphic.check import _Checker

    fault = _dropout(1.0)
    res = check_relation(ToyMapper, RigidMotion(), case, rngs=_rngs(2), fault=fault)
    base = check_relation(ToyMapper, RigidMotion(), case, rngs=_rngs(2))
    # planted reference: the same case with every observation removed by hand, run without any fault
    blind = dataclasses.replace(case, obs_offsets=np.zeros_like(case.obs_offsets), obs_range=case.obs_range[:0],
                                obs_bearing=case.obs_bearing[:0], obs_ids=case.obs_ids[:0])
    expected = run_slam(ToyMapper(), blind, rng=np.random.default_rng(0))
    checker = _Checker(ToyMapper, case, _rngs(2))
    for k in range(2):
        faulty, unmodified = checker.run(fault, None, k), checker.run(None, None, k)
        assert faulty.landmark_ids.size == 0 and unmodified.landmark_ids.size > 0
        np.testing.assert_array_equal(faulty.pose, expected.pose)
    assert res.variant == "obs_dropout" and res.discrepancies != base.discrepancies


def test_stream_fault_is_fed_as_the_runner_feeds_it_and_a_correct_slam_keeps_a_commuting_relation(case):
    from faultlab.metamorphic.check import _Checker

    fault = _dropout(0.3)
    checker = _Checker(ToyMapper, case, _rngs(2))
    for k in range(2):
        fed = checker.fed(fault, None, k)
        ref = fault.perturbation(case, np.random.default_rng(sensor_seed_sequence(checker.seeds[k], fault.name)))
        np.testing.assert_array_equal(fed.obs_ids, ref.obs_ids)
        assert 0 < fed.obs_ids.size < case.obs_ids.size
    res = check_relation(ToyMapper, BearingTurn(), case, rngs=_rngs(2), fault=fault)
    assert res.verdict is Verdict.HOLDS  # dropping the same observations commutes with adding 2 pi


def test_unjudgeable_sensor_faults_are_refused_with_one_clear_error(case):
    # id_permutation re-sorts each step's observations: dropping by position then drops others
    with pytest.raises(ConfigError, match="'id_permutation' cannot be judged under sensor fault 'obs_dropout'"):
        relation_matrix(ToyMapper, [BearingTurn(), IdPermutation()], [_dropout(0.5)], case, rngs=_rngs(2))
    with pytest.raises(ConfigError, match="'particle_budget' is a hardware limit"):
        check_relation(ToyMapper, BearingTurn(), case, rngs=_rngs(2), fault=get_fault("particle_budget"))


class SequentialMapper(ToyMapper):
    """A user's sequential filter: every observation it processes moves its pose 1 mm forward first.

    Like a sequential EKF update (each observation linearised at the state the previous one left),
    its map depends on the order of a step's observations, not on the landmarks' names.
    """

    name = "sequential_mapper"

    def update(self, control, observations):
        x, y, th = self.pose
        x, y = x + control[0] * np.cos(th), y + control[0] * np.sin(th)
        th = (th + control[1] + np.pi) % (2 * np.pi) - np.pi
        for i, r, b in zip(observations.ids.tolist(), observations.ranges, observations.bearings):
            x, y = x + 0.001 * np.cos(th), y + 0.001 * np.sin(th)
            self.map.setdefault(i, np.array([x + r * np.cos(th + b), y + r * np.sin(th + b)]))
        self.pose = np.array([x, y, th])


def test_id_relabel_holds_for_an_order_dependent_slam_that_id_permutation_flags(case):
    assert np.diff(case.obs_offsets).max() > 1  # some step sees several landmarks, so reordering matters
    reordered = check_relation(SequentialMapper, IdPermutation(), case, rngs=_rngs(2))
    assert reordered.verdict is Verdict.VIOLATED and reordered.statistic > 1e-4
    relabelled = check_relation(SequentialMapper, IdRelabel(), case, rngs=_rngs(2))
    assert relabelled.verdict is Verdict.HOLDS and max(relabelled.discrepancies) < 1e-12
    assert RELATION["id_relabel"].keep_order and not RELATION["id_permutation"].keep_order
