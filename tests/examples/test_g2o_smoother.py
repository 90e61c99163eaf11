"""g2o's batch smoother (examples/g2o-smoother): the optimum of the same least-squares problem found by scipy,
the truth on noise-free data, and adapter check through serve().

Skipped when the optional dependency is absent: ``pip install -e ".[wild]" -e examples/g2o-smoother``.
"""

import dataclasses
import sys

import numpy as np
import pytest
from scipy.linalg import cholesky
from scipy.optimize import least_squares

pytest.importorskip("g2opy", reason="g2opy is not installed (the [wild] extra)")
g2o_smoother = pytest.importorskip("faultlab_g2o_smoother",
                                   reason="examples/g2o-smoother is not installed (pip install -e examples/g2o-smoother)")

from faultlab.scenario import generate_scenario  # noqa: E402
from faultlab.slam import run_slam  # noqa: E402
from faultlab.slam.conformance import check_program  # noqa: E402
from faultlab.space import FIXED_VALUES, CaseSpec  # noqa: E402

S = g2o_smoother.G2oSmoother()


def _case(seed, n_steps=12):
    values = {**FIXED_VALUES, "map_size": 6.0, "landmark_density": 1.0}
    return generate_scenario(CaseSpec(values), rng=np.random.default_rng(seed), n_steps=n_steps)


def _wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


def _scipy_optimum(case, est):
    """The same weighted least squares (g2o's edge errors, whitened), minimised by scipy from g2o's answer
    perturbed, with the start pose fixed."""
    T = case.n_steps
    ids = est.landmark_ids
    Lu = cholesky(np.linalg.inv(np.diag([S.std_v ** 2, g2o_smoother.SIDEWAYS_VARIANCE, S.std_omega ** 2])))
    Q = np.diag([S.std_range ** 2, S.std_bearing ** 2])
    step = np.repeat(np.arange(T), np.diff(case.obs_offsets)) + 1
    r, b = case.obs_range, case.obs_bearing
    z = np.column_stack([r * np.cos(b), r * np.sin(b)])
    col = np.searchsorted(ids, case.obs_ids, sorter=np.argsort(ids))
    col = np.argsort(ids)[col]
    Lz = []
    for rk, bk in zip(r, b):
        J = np.array([[np.cos(bk), -rk * np.sin(bk)], [np.sin(bk), rk * np.cos(bk)]])
        Lz.append(cholesky(np.linalg.inv(J @ Q @ J.T + 1e-12 * np.eye(2))))

    def residuals(x):
        poses = np.vstack([case.start_pose, x[:3 * T].reshape(T, 3)])
        lm = x[3 * T:].reshape(-1, 2)
        out = []
        for t in range(T):
            p0, p1 = poses[t], poses[t + 1]
            c, s = np.cos(p0[2]), np.sin(p0[2])
            d = p1[:2] - p0[:2]
            rel = np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1], _wrap(p1[2] - p0[2])])
            v, w = case.controls[t]
            cm, sm = np.cos(w), np.sin(w)
            e = np.array([cm * (rel[0] - v) + sm * rel[1], -sm * (rel[0] - v) + cm * rel[1], _wrap(rel[2] - w)])
            out.append(Lu @ e)
        for k in range(r.size):
            p = poses[step[k]]
            c, s = np.cos(p[2]), np.sin(p[2])
            d = lm[col[k]] - p[:2]
            out.append(Lz[k] @ (np.array([c * d[0] + s * d[1], -s * d[0] + c * d[1]]) - z[k]))
        return np.concatenate(out)

    x0 = np.r_[est.trajectory.ravel(), est.landmarks.ravel()]
    x0 = x0 + np.random.default_rng(0).normal(0, 1e-3, x0.size)
    sol = least_squares(residuals, x0, xtol=1e-14, ftol=1e-14, gtol=1e-14)
    return sol.x[:3 * T].reshape(T, 3), sol.x[3 * T:].reshape(-1, 2)


@pytest.mark.parametrize("seed", [0, 1])
def test_g2o_reaches_the_least_squares_optimum_scipy_finds(seed):
    case = _case(seed)
    est = run_slam(g2o_smoother.G2oSmoother(), case, rng=np.random.default_rng(0))
    assert est.landmark_ids.size >= 2
    poses, lm = _scipy_optimum(case, est)
    np.testing.assert_allclose(est.landmarks, lm, atol=1e-5)
    np.testing.assert_allclose(est.trajectory[:, :2], poses[:, :2], atol=1e-5)


def test_noise_free_data_gives_the_truth():
    case = _case(2, n_steps=30)
    poses = case.true_poses
    step = np.repeat(np.arange(case.n_steps), np.diff(case.obs_offsets))
    order = np.argsort(case.landmark_ids)
    d = case.landmarks[order][np.searchsorted(case.landmark_ids[order], case.obs_ids)] - poses[step + 1, :2]
    exact = dataclasses.replace(case, controls=np.column_stack([np.hypot(*np.diff(poses[:, :2], axis=0).T),
                                                                np.diff(poses[:, 2])]),
                                obs_range=np.hypot(d[:, 0], d[:, 1]),
                                obs_bearing=np.arctan2(d[:, 1], d[:, 0]) - poses[step + 1, 2])
    est = run_slam(g2o_smoother.G2oSmoother(), exact, rng=np.random.default_rng(0))
    truth = case.landmarks[order][np.searchsorted(case.landmark_ids[order], est.landmark_ids)]
    np.testing.assert_allclose(est.landmarks, truth, atol=1e-8)
    np.testing.assert_allclose(est.trajectory[:, :2], poses[1:, :2], atol=1e-8)


@pytest.mark.slow
def test_the_served_smoother_passes_every_check():
    report = check_program([sys.executable, "-m", "faultlab_g2o_smoother"], reply_timeout_s=60.0,
                           execution_timeout_s=120.0)
    assert report.passed, report.format()


def test_a_start_from_another_estimate_reaches_the_same_optimum_and_reports_its_chi2():
    case = _case(3, n_steps=20)
    cold = g2o_smoother.G2oSmoother()
    a = run_slam(cold, case, rng=np.random.default_rng(0))
    warm = g2o_smoother.G2oSmoother(initial=a)
    b = run_slam(warm, case, rng=np.random.default_rng(0))
    np.testing.assert_allclose(b.landmarks, a.landmarks, atol=1e-5)  # both stop within RTOL of the optimum
    assert np.isfinite(cold.chi2) and warm.chi2 == pytest.approx(cold.chi2, rel=1e-6)
    # a start far from the optimum costs iterations, not the answer
    far = dataclasses.replace(a, trajectory=a.trajectory + np.array([0.5, -0.5, 0.1]))
    c = run_slam(g2o_smoother.G2oSmoother(initial=far), case, rng=np.random.default_rng(0))
    np.testing.assert_allclose(c.landmarks, a.landmarks, atol=1e-5)


def test_the_optimum_does_not_depend_on_the_frame():
    # fifty iterations stopped short on a pairwise case (reports/wild): iterate to convergence
    from faultlab.metamorphic import RigidMotion

    case = _case(4, n_steps=60)
    rel = RigidMotion(angle=1.0, translation=(3.0, -2.0))
    follow = rel.transform(case, np.random.default_rng(0))
    src = run_slam(g2o_smoother.G2oSmoother(), case, rng=np.random.default_rng(0))
    got = run_slam(g2o_smoother.G2oSmoother(), follow, rng=np.random.default_rng(0))
    exp = rel.expected(src, follow)
    o, p = np.argsort(exp.landmark_ids), np.argsort(got.landmark_ids)
    np.testing.assert_allclose(got.landmarks[p], exp.landmarks[o], atol=1e-6)


def test_an_idle_phase_with_one_landmark_still_reaches_the_frame_free_optimum():
    # the minimal case faultlab check reduced a rigid_motion failure to (reports/wild/check): 24 steps
    # with 4 sightings of one landmark, turns of a whole turn plus a little; Levenberg-Marquardt alone
    # left the map 2.5 um (the full 2100-step case: 23 mm) off in the rotated frame after 1000 iterations
    from faultlab.metamorphic import RigidMotion
    from faultlab.metamorphic.relation import estimate_distance

    values = {**FIXED_VALUES, "map_size": 4.0, "landmark_density": 1.0, "inactivity": 20,
              "rotation_error": -2 * np.pi}
    case = generate_scenario(CaseSpec(values), rng=np.random.default_rng(2), n_steps=8)
    rel = RigidMotion()
    follow = rel.transform(case, np.random.default_rng(0))
    src = g2o_smoother.G2oSmoother()
    a = run_slam(src, case, rng=np.random.default_rng(0))
    b = run_slam(g2o_smoother.G2oSmoother(), follow, rng=np.random.default_rng(0))
    assert estimate_distance(rel.expected(a, follow), b) < 1e-9
    lm_only = g2o_smoother.G2oSmoother(iterations=30)  # a capped run is where Gauss-Newton must finish
    c = run_slam(lm_only, case, rng=np.random.default_rng(0))
    np.testing.assert_allclose(c.landmarks, a.landmarks, atol=1e-9)
