"""FastSLAM profiles as data: the reference and the paper's filter (faultlab.slam.profiles)."""

from __future__ import annotations

import dataclasses
import math
import pickle

import numpy as np
import pytest

from faultlab.errors import ConfigError
from faultlab.faults import get_fault
from faultlab.metrics import map_errors
from faultlab.scenario import generate_scenario
from faultlab.slam import REFERENCE_STEPS, FastSlam, FastSlamConfig, Observations, run_slam
from faultlab.slam import paperunits
from faultlab.slam import particles
from faultlab.slam import units as U
from faultlab.slam.profiles import (
    PAPER_CONFIG,
    PAPER_NO_ALIASING_STEPS,
    PROFILES,
    Difference,
    differences_markdown,
    get_profile,
    profile_names,
)
from faultlab.space import FIXED_VALUES, CaseSpec

PAPER_UNITS = {"classify_new", "predict_measurement", "log_likelihood", "combine_weights", "resample",
               "extract_map"}


def test_registry_and_unknown_names():
    assert profile_names() == ("reference", "paper", "paper_no_aliasing")
    for name in profile_names():
        p = get_profile(name)
        assert p.name == name and p is PROFILES[name] and p.description and "\n" not in p.description
    with pytest.raises(ConfigError, match=r"unknown FastSLAM profile 'papr'.*reference, paper, paper_no_aliasing"):
        get_profile("papr")
    with pytest.raises(ConfigError, match="known profiles"):
        get_profile(None)


def test_which_units_each_profile_replaces():
    assert get_profile("reference").steps is REFERENCE_STEPS
    assert get_profile("reference").config == FastSlamConfig()
    assert set(get_profile("paper_no_aliasing").steps.replaced()) == PAPER_UNITS
    paper = get_profile("paper").steps
    assert set(paper.replaced()) == PAPER_UNITS | {"apply_resample"}
    assert paper.apply_resample is paperunits.apply_resample_aliased
    assert paper.predict_measurement is paperunits.predict_measurement_wrapped
    assert paper.log_likelihood is paperunits.log_likelihood_wrapped


def test_paper_config_is_the_packages_filter_noise_in_si():
    # slam_correct.py: Q = diag(3.0, 10 deg)^2, R = diag(1.0, 20 deg)^2 in units of 0.1 m (maps in mm / 100)
    unit = 0.1
    assert PAPER_CONFIG.particles == 200 and PAPER_CONFIG.resample_ratio == 1.5
    np.testing.assert_allclose(PAPER_CONFIG.Q, np.diag([(3.0 * unit) ** 2, math.radians(10.0) ** 2]), rtol=1e-15)
    assert PAPER_CONFIG.std_v == pytest.approx(1.0 * unit)
    assert PAPER_CONFIG.std_omega == pytest.approx(math.radians(20))


def test_paper_units_use_the_packages_constants_converted_to_metres():
    steps = get_profile("paper").steps
    mu = np.array([[[0.0009, 1.0], [-0.0011, 1.0], [0.005, 1.0]]])
    np.testing.assert_array_equal(steps.classify_new(np.ones(3, bool), mu), [[True, False, False]])  # 0.01 dm
    state = particles.ParticleState.initial(np.zeros(3), 2, capacity=2)
    state.mu[:, 0] = [[1.23456, -0.00049], [1.23456, -0.00049]]
    _, xy = steps.extract_map(state.replace(ids=np.array([3])))
    np.testing.assert_allclose(xy, [[1.235, -0.0]], atol=1e-12)  # whole millimetres
    logw = np.log([0.5, 0.5])
    ll = np.array([[-1.0], [-2.0]])
    out = steps.combine_weights(logw, ll, np.ones((2, 1), bool))
    np.testing.assert_allclose(out, logw + ll[:, 0] + math.log(0.1), rtol=1e-14)  # densities per 0.1 m


def test_profiles_pickle_for_worker_processes():
    for name in profile_names():
        p = pickle.loads(pickle.dumps(get_profile(name)))
        assert p.name == name and p.config == get_profile(name).config
        assert p.steps.replaced() == get_profile(name).steps.replaced()


def test_paper_measurement_model_wraps_the_predicted_bearing():
    steps = get_profile("paper").steps
    poses = np.array([[0.0, 0.0, -3.0], [0.0, 0.0, 3.0]])
    mu = np.array([[[-1.0, 1.0]], [[0.5, -1.0]]])
    zhat, _ = steps.predict_measurement(poses, mu)
    for i in range(2):
        raw = math.atan2(mu[i, 0, 1] - poses[i, 1], mu[i, 0, 0] - poses[i, 0]) - poses[i, 2]
        assert abs(raw) > math.pi
        assert zhat[i, 0, 1] == pytest.approx((raw + math.pi) % (2 * math.pi) - math.pi, abs=1e-12)
    ref, _ = get_profile("reference").steps.predict_measurement(poses, mu)
    assert np.all(np.abs(ref[..., 1]) > math.pi)


def test_missing_angle_wrap_under_the_paper_profile_keeps_the_weights_wrap():
    fault = get_fault("missing_angle_wrap")
    steps = fault.patch(get_profile("paper").steps)
    assert steps.replaced() == tuple(sorted(PAPER_UNITS | {"apply_resample", "wrap_bearing"},
                                            key=REFERENCE_STEPS.unit_names().index))
    poses = np.array([[0.0, 0.0, math.pi - 0.02]])
    mu = np.array([[[1.0, -0.05]]])  # just behind on the right: predicted bearing near pi
    zhat, H = steps.predict_measurement(poses, mu)
    assert -math.pi <= zhat[0, 0, 1] < math.pi  # the prediction's own wrap survives the fault
    z = np.array([[1.0, -math.pi + 0.02]])  # the same direction, reported across the cut
    nu = steps.innovation(z, zhat, wrap=steps.wrap_bearing)
    assert abs(nu[0, 0, 1]) > 6.0  # the EKF's innovation is no longer wrapped ...
    S = steps.innovation_covariance(H, np.tile(np.eye(2) * 0.01, (1, 1, 1, 1)), PAPER_CONFIG.Q)
    wrapped = nu.copy()
    wrapped[..., 1] = (wrapped[..., 1] + math.pi) % (2 * math.pi) - math.pi
    # ... but the weight's is: the likelihood is the one of the wrapped innovation (compute_weight)
    assert steps.log_likelihood(nu, S)[0, 0] == pytest.approx(U.log_likelihood(wrapped, S)[0, 0], rel=1e-12)
    # under the reference profile the same fault also corrupts the weight
    ref = fault.patch(REFERENCE_STEPS)
    assert ref.log_likelihood(nu, S)[0, 0] < U.log_likelihood(wrapped, S)[0, 0] - 100


def _two_steps(config, steps):
    slam = FastSlam(config, steps=steps)
    slam.reset(np.zeros(3), rng=np.random.default_rng(4))
    slam.update(np.array([0.5, math.pi - 0.02]), Observations([1.0], [math.pi - 0.05], [0]))
    slam.update(np.array([0.0, 0.04]), Observations([1.0], [-math.pi + 0.05], [0]))  # seen across the cut
    return slam.particles()


def test_missing_angle_wrap_under_the_paper_profile_changes_the_ekf_update_only():
    cfg = dataclasses.replace(PAPER_CONFIG, particles=4, std_v=0.01, std_omega=0.01)
    fault = get_fault("missing_angle_wrap")
    base = _two_steps(cfg, PAPER_NO_ALIASING_STEPS)
    faulty = _two_steps(cfg, fault.patch(PAPER_NO_ALIASING_STEPS))
    # the weights are the baseline's, as in the paper's faulty rotation (up to the last bits: the fault also
    # drops the wrap of yaw + bearing before sin/cos at initialisation, as the paper's does)
    np.testing.assert_allclose(faulty.weights, base.weights, rtol=1e-12)
    assert np.ptp(base.weights) > 0  # the weights do depend on the particles
    assert np.max(np.abs(faulty.means - base.means)) > 0.1  # the EKF update drags the landmark
    ref_cfg = dataclasses.replace(cfg, std_range=FastSlamConfig().std_range)
    ref_base = _two_steps(ref_cfg, REFERENCE_STEPS)
    ref_faulty = _two_steps(ref_cfg, fault.patch(REFERENCE_STEPS))
    assert not np.allclose(ref_faulty.weights, ref_base.weights, rtol=1e-6)  # the reference's weights change


def test_differences_are_rows_of_four_texts_and_render_as_markdown():
    required = {"filter noise", "predicted bearing", "innovation wraps", "new landmark", "weights",
                "resampling draws", "resampling copies", "map output", "unobserved landmarks", "length unit",
                "field of view (scenario)"}
    for name in profile_names():
        rows = get_profile(name).differences
        assert required <= {r.point for r in rows}, name
        assert len({r.point for r in rows}) == len(rows)
        for r in rows:
            assert isinstance(r, Difference) and len(r) == 4 and all(isinstance(x, str) and x.strip() for x in r)
        table = differences_markdown(name).splitlines()
        assert table[0].startswith("| point | the paper's filter | faultlab `" + name + "`")
        assert len(table) == 2 + len(rows) and all(line.count(" | ") == 3 for line in table[2:])
    copies = {p: next(r for r in get_profile(p).differences if r.point == "resampling copies").faultlab
              for p in ("paper", "paper_no_aliasing")}
    assert "apply_resample_aliased" in copies["paper"] and "deep copies" in copies["paper_no_aliasing"]


def test_paper_profile_runs_a_fixed_suite_case_end_to_end():
    scenario = generate_scenario(CaseSpec(dict(FIXED_VALUES)), rng=np.random.default_rng(3), n_steps=20)
    results = {}
    for name in ("paper", "paper_no_aliasing"):
        slam = get_profile(name).slam()
        est = run_slam(slam, scenario, rng=np.random.default_rng(9))
        err = map_errors(scenario, est)
        results[name] = (est, slam)
        assert err.n_mapped == np.unique(scenario.obs_ids).size  # every observed landmark is mapped
        assert err.n_mapped + err.n_unmapped == scenario.landmarks.shape[0]
        assert err.rms_mm < 300.0  # the paper's fixed suite: 38-101 mm after 1000 steps
        np.testing.assert_allclose(est.landmarks * 1000, np.round(est.landmarks * 1000), atol=1e-6)  # whole mm
    assert np.unique(results["paper"][1].state.owner).size < 200  # resampled particles share maps
    np.testing.assert_array_equal(results["paper_no_aliasing"][1].state.owner, np.arange(200))
    assert not np.array_equal(results["paper"][0].landmarks, results["paper_no_aliasing"][0].landmarks)


def test_each_ablation_changes_one_point_of_the_paper_profile():
    from faultlab.slam.profiles import ABLATION_PROFILES, ABLATIONS, Arm, ablation_arms

    base = get_profile("paper_no_aliasing")
    points = {d.point for d in get_profile("paper").differences}
    for ab in ABLATIONS:
        assert ab.point in points and ab.change
        paper, alt = get_profile(ab.paper.profile), get_profile(ab.alternative.profile)
        assert paper.config == alt.config == PAPER_CONFIG
        changed = {n for n in type(base.steps).unit_names()
                   if getattr(paper.steps, n) is not getattr(alt.steps, n)}
        # exactly one unit differs between the arms, or none and the scenarios' field of view does
        assert len(changed) + (ab.paper.fov_bug != ab.alternative.fov_bug) == 1, ab.point
        if changed:
            (unit,) = changed
            assert getattr(alt.steps, unit) is getattr(REFERENCE_STEPS, unit)  # the alternative is faultlab's
    assert {a.point for a in ABLATIONS if a.paper.profile == "paper"} == {"resampling copies"}
    arms = ablation_arms()
    assert len(arms) == len(set(arms)) and Arm("paper") in arms and Arm("paper_no_aliasing", False) in arms
    assert Arm("paper_no_aliasing", False).name == "paper_no_aliasing-fov-off"
    for name, p in ABLATION_PROFILES.items():
        assert get_profile(name) is p and name not in profile_names()
