"""Every metamorphic relation does what its examples say (one generic test), and the transforms' properties."""

import dataclasses
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.errors import ConfigError, ScenarioError
from faultlab.metamorphic import BUILTIN_RELATIONS, MetamorphicRelation, all_relations, metamorphic_scenario
from faultlab.metamorphic.builtin import (
    BearingTurn,
    HalvedNoise,
    IdPermutation,
    RigidMotion,
    example_scenario,
    true_measurements,
)
from faultlab.metamorphic.relation import META_KEY, estimate_distance, truth_estimate
from faultlab.scenario import generate_scenario
from faultlab.scenario.trace import wrap_angle
from faultlab.slam import Estimate
from faultlab.space import FIXED_VALUES, CaseSpec

RELATIONS = all_relations(plugins=True)
EXAMPLES = [(r.name, i) for r in RELATIONS for i in range(len(r.examples))]
_ARRAYS = ("landmarks", "landmark_ids", "true_poses", "controls", "obs_offsets", "obs_range", "obs_bearing",
           "obs_ids")


def _relation(name):
    return next(r for r in RELATIONS if r.name == name)


def _same_estimate(a: Estimate, b: Estimate):
    order_a, order_b = np.argsort(a.landmark_ids), np.argsort(b.landmark_ids)
    np.testing.assert_array_equal(np.asarray(a.landmark_ids)[order_a], np.asarray(b.landmark_ids)[order_b])
    np.testing.assert_allclose(np.asarray(a.landmarks)[order_a], np.asarray(b.landmarks)[order_b], atol=1e-12)
    np.testing.assert_allclose(a.pose[:2], b.pose[:2], atol=1e-12)
    assert float(wrap_angle(a.pose[2] - b.pose[2])) == pytest.approx(0.0, abs=1e-12)


@pytest.mark.parametrize("name, i", EXAMPLES)
def test_relation_example(name, i):
    """The one generic test of every relation's examples (built-in and plugin)."""
    relation = _relation(name)
    example = relation.examples[i]
    if example.options:
        relation = type(relation)(**example.options)
    source = example.source()
    followup = relation.transform(source, np.random.default_rng(0))
    followup.validate()
    for attr, value in example.followup.items():  # the hand-computed values
        np.testing.assert_allclose(np.asarray(getattr(followup, attr), dtype=float), np.asarray(value, dtype=float),
                                   atol=1e-12, err_msg=attr)
    for attr in _ARRAYS:  # everything else is unchanged
        if attr not in example.followup and attr not in example.changes:
            np.testing.assert_array_equal(getattr(followup, attr), getattr(source, attr), err_msg=attr)
    assert followup.meta[META_KEY]["relation"] == relation.name
    np.testing.assert_array_equal(example.source().obs_bearing, source.obs_bearing)  # the source is not modified
    if example.estimate is not None:
        _same_estimate(relation.expected(example.estimate, followup), example.expected)
    # the ground truth is a perfect estimate: the relation maps the source's truth onto the follow-up's
    _same_estimate(relation.expected(truth_estimate(source), followup), truth_estimate(followup))


def test_every_relation_has_examples_a_name_and_a_one_line_description():
    names = [r.name for r in RELATIONS]
    assert len(set(names)) == len(names)
    assert {"rigid_motion", "id_permutation", "bearing_turn", "halved_noise"} <= set(names)
    for r in RELATIONS:
        assert isinstance(r, MetamorphicRelation) and r.examples, r.name
        assert r.description.strip() and "\n" not in r.description
    assert [r.name for r in BUILTIN_RELATIONS if r.uses_truth] == ["halved_noise"]
    assert [r.name for r in BUILTIN_RELATIONS if not r.exact] == ["halved_noise"]


@pytest.fixture(scope="module")
def case():
    return metamorphic_scenario(seed=3, n_steps=60)


@pytest.mark.parametrize("relation", BUILTIN_RELATIONS, ids=lambda r: r.name)
def test_transforms_are_deterministic_valid_and_truth_consistent_on_a_generated_case(relation, case):
    a = relation.transform(case, np.random.default_rng(5))
    b = relation.transform(case, np.random.default_rng(5))
    for attr in _ARRAYS:
        np.testing.assert_array_equal(getattr(a, attr), getattr(b, attr))
    assert a.meta[META_KEY] == b.meta[META_KEY]
    assert a.n_steps == case.n_steps and a.obs_offsets.tolist() == case.obs_offsets.tolist()
    assert estimate_distance(relation.expected(truth_estimate(case), a), truth_estimate(a)) < 1e-9


@settings(max_examples=40, deadline=None)
@given(angle=st.floats(-10.0, 10.0), tx=st.floats(-50.0, 50.0), ty=st.floats(-50.0, 50.0))
def test_rigid_motion_keeps_the_sensor_trace_and_all_distances(angle, tx, ty):
    sc = example_scenario()
    fu = RigidMotion(angle, (tx, ty)).transform(sc, np.random.default_rng(0))
    # relative geometry: the noise-free measurements of every observation are unchanged
    (r0, b0), (r1, b1) = true_measurements(sc), true_measurements(fu)
    np.testing.assert_allclose(r1, r0, atol=1e-9)
    np.testing.assert_allclose(np.sin(b1 - b0), 0.0, atol=1e-9)
    np.testing.assert_allclose(np.cos(b1 - b0), 1.0, atol=1e-9)
    d0 = np.linalg.norm(sc.landmarks[:, None] - sc.true_poses[None, :, :2], axis=-1)
    d1 = np.linalg.norm(fu.landmarks[:, None] - fu.true_poses[None, :, :2], axis=-1)
    np.testing.assert_allclose(d1, d0, atol=1e-9)
    assert np.all((fu.true_poses[:, 2] >= -math.pi) & (fu.true_poses[:, 2] < math.pi))
    np.testing.assert_array_equal(fu.controls, sc.controls)


def test_rigid_motion_draws_its_parameters_from_the_rng():
    sc = example_scenario()
    p1 = RigidMotion().transform(sc, np.random.default_rng(1)).meta[META_KEY]
    p2 = RigidMotion().transform(sc, np.random.default_rng(2)).meta[META_KEY]
    assert p1 != p2 and -math.pi <= p1["angle"] < math.pi and max(map(abs, p1["translation"])) <= 10.0


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2 ** 32 - 1))
def test_id_permutation_relabels_consistently_and_sorts_each_step(seed):
    sc = metamorphic_scenario(seed=1, n_steps=20)
    fu = IdPermutation().transform(sc, np.random.default_rng(seed))
    p = fu.meta[META_KEY]
    new_of = dict(zip(p["old_ids"], p["new_ids"]))
    assert sorted(new_of.values()) == sorted(sc.landmark_ids.tolist())  # a permutation of the same ids
    # every observation keeps its measurement and now carries the new id, listed by new id per step
    for t in range(sc.n_steps):
        a, b = sc.obs_offsets[t], sc.obs_offsets[t + 1]
        old = {new_of[int(i)]: (r, br) for i, r, br in zip(sc.obs_ids[a:b], sc.obs_range[a:b], sc.obs_bearing[a:b])}
        ids = fu.obs_ids[a:b].tolist()
        assert ids == sorted(ids) and set(ids) == set(old)
        for i, r, br in zip(ids, fu.obs_range[a:b], fu.obs_bearing[a:b]):
            assert (r, br) == old[i]
    new_xy = dict(zip(fu.landmark_ids.tolist(), map(tuple, fu.landmarks)))
    for old_id, xy in zip(sc.landmark_ids.tolist(), map(tuple, sc.landmarks)):
        assert new_xy[new_of[old_id]] == xy


def test_bad_parameters_are_refused():
    with pytest.raises(ConfigError, match="permutation of the map's ids"):
        IdPermutation({10: 20, 20: 30}).transform(example_scenario(), np.random.default_rng(0))
    with pytest.raises(ConfigError, match="non-zero integer"):
        BearingTurn(0)
    with pytest.raises(ConfigError, match="non-zero integer"):
        BearingTurn(1.5)
    sc = example_scenario()
    with pytest.raises(ScenarioError, match="landmark 99, which is not in the map"):
        true_measurements(dataclasses.replace(sc, obs_ids=np.array([10, 99, 10])))


def test_true_measurements_recover_a_noise_free_trace():
    values = {**FIXED_VALUES, "variance_distance": 0.0, "variance_angle": 0.0, "outlier_probability": 0.0,
              "rotation_error": 2 * math.pi}
    sc = generate_scenario(CaseSpec(values), rng=np.random.default_rng(4), n_steps=50)
    r, b = true_measurements(sc)
    np.testing.assert_allclose(r, sc.obs_range, atol=1e-12)
    np.testing.assert_allclose(b + 2 * math.pi, sc.obs_bearing, atol=1e-12)  # the generator's +2 pi rotation error
    # so halving the (zero) noise changes nothing, and the whole turn survives
    fu = HalvedNoise().transform(sc, np.random.default_rng(0))
    np.testing.assert_allclose(fu.obs_range, sc.obs_range, atol=1e-12)
    np.testing.assert_allclose(fu.obs_bearing, sc.obs_bearing, atol=1e-12)


@settings(max_examples=20, deadline=None)
@given(st.integers(0, 1000))
def test_halved_noise_halves_every_residual_and_twice_quarters_it(seed):
    sc = metamorphic_scenario(seed=seed, n_steps=15)
    r, b = true_measurements(sc)
    once = HalvedNoise().transform(sc, np.random.default_rng(0))
    twice = HalvedNoise().transform(once, np.random.default_rng(0))
    np.testing.assert_allclose(once.obs_range - r, 0.5 * (sc.obs_range - r), atol=1e-12)
    np.testing.assert_allclose(twice.obs_range - r, 0.25 * (sc.obs_range - r), atol=1e-12)
    np.testing.assert_allclose(wrap_angle(twice.obs_bearing - b), 0.25 * wrap_angle(sc.obs_bearing - b), atol=1e-12)
    assert np.all(once.obs_range >= 0)


def test_id_permutation_can_keep_each_steps_order():
    from faultlab.metamorphic import IdPermutation
    from faultlab.metamorphic.builtin import example_scenario

    src = example_scenario()
    kept = IdPermutation({10: 20, 20: 10}, keep_order=True).transform(src, np.random.default_rng(0))
    moved = IdPermutation({10: 20, 20: 10}).transform(src, np.random.default_rng(0))
    np.testing.assert_array_equal(kept.obs_range, src.obs_range)  # same order, ids relabelled
    np.testing.assert_array_equal(kept.obs_ids, np.where(src.obs_ids == 10, 20, 10))
    assert not np.array_equal(moved.obs_range, src.obs_range)
