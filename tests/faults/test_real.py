"""The ``real`` fault category: provenance complete, unit faults change their unit, the new fault by hand."""

import numpy as np
import pytest

from faultlab.faults import get_fault
from faultlab.faults.real import MEASUREMENT_NOISE_FROM_STATE_COVARIANCE, REAL_FAULTS, Provenance, real_faults
from faultlab.scenario import generate_scenario
from faultlab.slam import FastSlam, run_slam
from faultlab.slam.fastslam import FastSlamConfig
from faultlab.slam.noise import NoiseConfig
from faultlab.slam.units import innovation_covariance
from faultlab.space import FIXED_VALUES, CaseSpec


def test_the_category_holds_at_least_three_faults_each_with_its_provenance():
    assert len(REAL_FAULTS) >= 3 and REAL_FAULTS[0].name == "fov_right_side_passes"
    for r in REAL_FAULTS:
        p = r.provenance
        assert all(getattr(p, a).strip() for a in ("project", "file", "what", "found"))
        if r.fault is not None:
            assert r.fault.name == r.name
    assert len(real_faults()) == len(REAL_FAULTS)


def test_built_in_entries_are_the_registered_faults():
    for r in REAL_FAULTS:
        if r.fault is not None and r.name != MEASUREMENT_NOISE_FROM_STATE_COVARIANCE.name:
            assert get_fault(r.name) is r.fault


def test_provenance_says_how_it_is_known():
    with pytest.raises(ValueError, match="known"):
        Provenance("p", "f", "w", "found", known="heard")


def test_the_innovation_covariance_fault_adds_the_control_noise_by_hand():
    H = np.array([[[[1.0, 0.0], [0.0, 0.5]]]])
    P = np.array([[[[0.04, 0.0], [0.0, 0.09]]]])
    unit = MEASUREMENT_NOISE_FROM_STATE_COVARIANCE.replacement(innovation_covariance)
    M = NoiseConfig().M
    expected = np.array([[0.04 + M[0, 0], 0.0], [0.0, 0.25 * 0.09 + M[1, 1]]])
    np.testing.assert_allclose(unit(H, P, NoiseConfig().Q)[0, 0], expected)
    assert not np.allclose(unit(H, P, NoiseConfig().Q), innovation_covariance(H, P, NoiseConfig().Q))


def test_the_new_fault_applies_to_fastslam_and_changes_its_map():
    case = generate_scenario(CaseSpec({**FIXED_VALUES, "map_size": 10.0, "landmark_density": 2.0}),
                             rng=np.random.default_rng(0), n_steps=30)
    slam = FastSlam(FastSlamConfig(particles=20))
    base = run_slam(slam, case, rng=np.random.default_rng(1))
    faulty = run_slam(MEASUREMENT_NOISE_FROM_STATE_COVARIANCE.apply(slam), case, rng=np.random.default_rng(1))
    assert not np.array_equal(base.landmarks, faulty.landmarks)
