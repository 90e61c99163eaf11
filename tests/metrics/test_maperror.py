import numpy as np
import pytest

from faultlab.errors import SlamOutputError
from faultlab.metrics import earth_movers_distance, kabsch_rms, map_errors
from faultlab.scenario.model import Scenario
from faultlab.slam.protocol import Estimate
from faultlab.space.case import FIXED_VALUES, CaseSpec


def make_scenario(landmarks, ids):
    return Scenario(case=CaseSpec(FIXED_VALUES), seed=None, landmarks=np.asarray(landmarks, float),
                    landmark_ids=np.asarray(ids, np.int64), true_poses=np.zeros((1, 3)),
                    controls=np.zeros((0, 2)), obs_offsets=np.zeros(1, np.int64), obs_range=np.empty(0),
                    obs_bearing=np.empty(0), obs_ids=np.empty(0, np.int64))


def test_map_errors_in_mm_with_counts():
    rng = np.random.default_rng(5)
    p = rng.uniform(0, 8, size=(10, 2))
    ids = np.arange(20, 30)
    scen = make_scenario(p, ids)
    c, s = np.cos(0.3), np.sin(0.3)
    mapped = np.array([0, 2, 3, 5, 7, 9])
    q = (p[mapped] + rng.normal(scale=0.05, size=(6, 2))) @ np.array([[c, -s], [s, c]]).T + [1, 1]
    est = Estimate(np.zeros(3), ids[mapped], q)
    out = map_errors(scen, est)
    ref = kabsch_rms(ids, p, ids[mapped], q)
    np.testing.assert_allclose(out.rms_mm, 1000 * ref.rms)
    np.testing.assert_allclose(out.emd_mm, 1000 * earth_movers_distance(p, ref.apply(q)))
    np.testing.assert_allclose(map_errors(scen, est, emd_alignment="none").emd_mm,
                               1000 * earth_movers_distance(p, q))
    assert (out.n_mapped, out.n_unmapped) == (6, 4)


def test_rigidly_moved_full_map_has_zero_aligned_errors():
    p = np.array([[0.0, 0.0], [3.0, 0.0], [0.0, 1.0], [2.0, 2.0]])
    scen = make_scenario(p, [1, 2, 3, 4])
    est = Estimate(np.zeros(3), np.array([4, 3, 2, 1]), p[::-1] + [0.5, -0.2])
    out = map_errors(scen, est)
    np.testing.assert_allclose([out.rms_mm, out.emd_mm], [0.0, 0.0], atol=1e-9)
    np.testing.assert_allclose(map_errors(scen, est, emd_alignment="none").emd_mm, 1000 * np.hypot(0.5, 0.2))


def test_nothing_mapped_gives_nan_and_bad_estimates_raise():
    scen = make_scenario([[0, 0], [1, 1]], [1, 2])
    out = map_errors(scen, Estimate(np.zeros(3), np.empty(0, np.int64), np.empty((0, 2))))
    assert np.isnan(out.rms_mm) and np.isnan(out.emd_mm) and (out.n_mapped, out.n_unmapped) == (0, 2)
    with pytest.raises(SlamOutputError, match="landmark 2"):
        map_errors(scen, Estimate(np.zeros(3), np.array([1, 2]), np.array([[0, 0], [np.nan, 0]])))
    with pytest.raises(SlamOutputError, match="id 5"):
        map_errors(scen, Estimate(np.zeros(3), np.array([5]), np.array([[0.0, 0.0]])))


def test_emd_can_be_skipped():
    scen = make_scenario([[0, 0], [1, 1], [3, 0]], [1, 2, 3])
    est = Estimate(np.zeros(3), np.array([1, 3]), np.array([[0.1, 0.0], [3.0, 0.2]]))
    out = map_errors(scen, est, metrics=("rms",))
    assert np.isnan(out.emd_mm)
    np.testing.assert_allclose(out.rms_mm, map_errors(scen, est).rms_mm)


def test_metrics_option_computes_only_the_listed_errors_bit_for_bit():
    rng = np.random.default_rng(11)
    p = rng.uniform(0, 8, size=(40, 2))
    ids = np.arange(40)
    scen = make_scenario(p, ids)
    mapped = rng.permutation(40)[:30]
    est = Estimate(np.zeros(3), ids[mapped], p[mapped] + rng.normal(scale=0.1, size=(30, 2)))
    both = map_errors(scen, est)
    rms = map_errors(scen, est, metrics=("rms",))
    emd = map_errors(scen, est, metrics=["emd"])
    ref = kabsch_rms(ids, p, ids[mapped], est.landmarks)
    assert rms.rms_mm == both.rms_mm == 1000 * ref.rms and np.isnan(rms.emd_mm)
    assert emd.emd_mm == both.emd_mm == 1000 * earth_movers_distance(p, ref.apply(est.landmarks))
    assert np.isnan(emd.rms_mm)
    assert (rms.n_mapped, rms.n_unmapped) == (emd.n_mapped, emd.n_unmapped) == (30, 10)
    unknown = map_errors(scen, est, association="unknown", metrics=("rms",))
    assert np.isnan(unknown.rms_mm) and np.isnan(unknown.emd_mm)


@pytest.mark.parametrize("metrics", [(), ("rms", "bogus"), "rms"])
def test_metrics_option_rejects_unknown_names(metrics):
    from faultlab.errors import ConfigError

    scen = make_scenario([[0.0, 0.0], [1.0, 0.0]], [1, 2])
    with pytest.raises(ConfigError, match="metrics must be"):
        map_errors(scen, Estimate(np.zeros(3), np.array([1, 2]), np.zeros((2, 2))), metrics=metrics)
