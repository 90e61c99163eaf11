"""roboticstoolbox-python's EKF-SLAM behind faultlab (examples/rtb-ekf-slam): its conventions checked against
faultlab's own EKF-SLAM (an independent implementation of the same textbook filter) and the exact truth.

Skipped when the optional dependency is absent: ``pip install -e ".[wild]" -e examples/rtb-ekf-slam``.
"""

import dataclasses
import sys

import numpy as np
import pytest

pytest.importorskip("roboticstoolbox", reason="roboticstoolbox-python is not installed (the [wild] extra)")
rtb_slam = pytest.importorskip("faultlab_rtb_ekf_slam",
                               reason="examples/rtb-ekf-slam is not installed (pip install -e examples/rtb-ekf-slam)")

from faultlab.scenario import generate_scenario  # noqa: E402
from faultlab.slam import EkfSlam, run_slam  # noqa: E402
from faultlab.slam.ekf import EkfSlamConfig  # noqa: E402
from faultlab.slam.process import ProcessSlam, ProcessSlamConfig  # noqa: E402
from faultlab.space import FIXED_VALUES, CaseSpec  # noqa: E402


def _case(seed, n_steps=60):
    values = {**FIXED_VALUES, "map_size": 10.0, "landmark_density": 2.0}  # a few dozen landmarks: the filter is dense
    return generate_scenario(CaseSpec(values), rng=np.random.default_rng(seed), n_steps=n_steps)


def _first_observation_only(case):
    """The case with at most the first observation of every step (the toolbox's one reading per step)."""
    off = case.obs_offsets
    keep = np.zeros(case.obs_range.size, dtype=bool)
    has = off[1:] > off[:-1]
    keep[off[:-1][has]] = True
    counts = np.minimum(np.diff(off), 1)
    return dataclasses.replace(case, obs_offsets=np.r_[0, np.cumsum(counts)].astype(np.int64),
                               obs_range=case.obs_range[keep], obs_bearing=case.obs_bearing[keep],
                               obs_ids=case.obs_ids[keep])


def _by_id(est):
    order = np.argsort(est.landmark_ids)
    return est.landmark_ids[order], est.landmarks[order]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_one_observation_per_step_matches_faultlabs_ekf(seed):
    case = _first_observation_only(_case(seed))
    assert np.all(np.abs(case.controls).sum(axis=1) > 0)  # no empty update, where the conventions differ
    ours = run_slam(EkfSlam(EkfSlamConfig()), case, rng=np.random.default_rng(0))
    theirs = run_slam(rtb_slam.RtbEkfSlam(), case, rng=np.random.default_rng(0))
    ids_o, lm_o = _by_id(ours)
    ids_t, lm_t = _by_id(theirs)
    assert np.array_equal(ids_o, ids_t) and ids_o.size > 3
    np.testing.assert_allclose(lm_t, lm_o, atol=1e-6)
    np.testing.assert_allclose(theirs.pose[:2], ours.pose[:2], atol=1e-6)
    assert abs(np.angle(np.exp(1j * (theirs.pose[2] - ours.pose[2])))) < 1e-6


def test_noise_free_observations_put_every_landmark_at_the_truth():
    case = _case(4, n_steps=40)
    # exact controls and observations from the true poses (drive, then turn)
    poses = case.true_poses
    v = np.hypot(*np.diff(poses[:, :2], axis=0).T)
    w = np.diff(poses[:, 2])
    step = np.repeat(np.arange(case.n_steps), np.diff(case.obs_offsets))
    order = np.argsort(case.landmark_ids)
    where = case.landmarks[order][np.searchsorted(case.landmark_ids[order], case.obs_ids)]
    d = where - poses[step + 1, :2]
    exact = dataclasses.replace(case, controls=np.column_stack([v, w]), obs_range=np.hypot(d[:, 0], d[:, 1]),
                                obs_bearing=np.arctan2(d[:, 1], d[:, 0]) - poses[step + 1, 2] + 4 * np.pi)
    est = run_slam(rtb_slam.RtbEkfSlam(), exact, rng=np.random.default_rng(0))
    ids, lm = _by_id(est)
    truth = case.landmarks[order][np.searchsorted(case.landmark_ids[order], ids)]
    np.testing.assert_allclose(lm, truth, atol=1e-8)
    np.testing.assert_allclose(est.trajectory[:, :2], poses[1:, :2], atol=1e-8)


def test_the_covariance_is_symmetric_positive_semidefinite_and_ordered_like_the_map():
    slam = rtb_slam.RtbEkfSlam()
    est = run_slam(slam, _case(5, n_steps=30), rng=np.random.default_rng(0))
    P = slam.covariance
    assert P.shape == (3 + 2 * est.landmark_ids.size,) * 2
    np.testing.assert_allclose(P, P.T, atol=1e-12)
    assert np.linalg.eigvalsh(P).min() > -1e-9


@pytest.mark.slow
def test_the_process_server_gives_the_in_process_estimate():
    case = _case(6, n_steps=25)
    direct = run_slam(rtb_slam.RtbEkfSlam(), case, rng=np.random.default_rng(0))
    slam = ProcessSlam(ProcessSlamConfig.from_options({"command": [sys.executable, "-m", "faultlab_rtb_ekf_slam"],
                                                       "reply_timeout_s": 120.0}))
    try:
        served = run_slam(slam, case, rng=np.random.default_rng(0))
    finally:
        slam.close()
    assert np.array_equal(_by_id(served)[0], _by_id(direct)[0])
    assert np.array_equal(_by_id(served)[1], _by_id(direct)[1]) and np.array_equal(served.pose, direct.pose)



def test_a_mutant_of_the_toolbox_filter_reaches_the_slam_the_adapter_builds():
    """The adapter imports the toolbox while it is built, so a mutant of ``roboticstoolbox.mobile.EKF``
    served at import (as ``faultlab mutate`` does) is the filter it runs; imported later, in ``reset``,
    it would get the original back and every mutant would look equivalent."""
    from faultlab.mutation.target import generate_source_mutants, mutated_modules, parse_target

    mutants = generate_source_mutants(parse_target("roboticstoolbox.mobile.EKF:EKF.step"), operators=["arithmetic"])
    # the Joseph-form covariance update (I - K H) P (I - K H)^T + K W K^T with the noise term subtracted
    joseph = next(m for m in mutants if m.line == 1006 and "- K @ self._W_est @ K.T" in m.replacement)
    case = _case(3, n_steps=30)
    original = rtb_slam.RtbEkfSlam()
    run_slam(original, case, rng=np.random.default_rng(0))
    with mutated_modules(joseph.id, "faultlab_rtb_ekf_slam"):
        mutated = sys.modules["faultlab_rtb_ekf_slam"].RtbEkfSlam()
    run_slam(mutated, case, rng=np.random.default_rng(0))
    again = rtb_slam.RtbEkfSlam()
    run_slam(again, case, rng=np.random.default_rng(0))
    assert np.array_equal(again.covariance, original.covariance)  # the filter is deterministic
    assert mutated.covariance.shape == original.covariance.shape
    assert not np.array_equal(mutated.covariance, original.covariance)
