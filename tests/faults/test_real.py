"""The ``real`` fault category: provenance, registration, and each fault's effect where its trigger is and is not.

Every real fault is checked twice at the level of a whole SLAM run: through ``faultlab run`` it changes the
result of the case it is run on, and on a case (or filter setting) without its trigger condition it changes
nothing at all (bit-identical estimates), which is what its provenance says of it.
"""

import dataclasses
import math

import numpy as np
import pytest

from faultlab.cli import main
from faultlab.faults import get_fault, list_faults
from faultlab.faults.builtin import BUILTIN_FAULTS, MEASUREMENT_NOISE_FROM_STATE_COVARIANCE
from faultlab.faults.real import REAL, REAL_FAULTS, Provenance, fault_categories, real_faults
from faultlab.runner import load_results
from faultlab.scenario import generate_scenario
from faultlab.slam import FastSlam, run_slam
from faultlab.slam.fastslam import FastSlamConfig
from faultlab.slam.noise import NoiseConfig
from faultlab.slam.units import innovation_covariance
from faultlab.slam.units import sample_controls as REFERENCE_SAMPLE
from faultlab.space import FIXED_VALUES, CaseSpec

UNIT_FAULTS = [r.name for r in REAL_FAULTS if r.fault is not None]


def test_the_category_holds_at_least_three_faults_each_with_its_provenance():
    assert len(REAL_FAULTS) >= 3 and REAL_FAULTS[0].name == "fov_right_side_passes"
    for r in REAL_FAULTS:
        p = r.provenance
        assert all(getattr(p, a).strip() for a in ("project", "file", "what", "found"))
        if r.fault is not None:
            assert r.fault.name == r.name
    assert len(real_faults()) == len(REAL_FAULTS)
    read = [r for r in REAL_FAULTS if r.provenance.known == "read" and "commit" in r.provenance.project]
    assert len(read) >= 3  # at least three read in a public copy at a named commit


def test_every_real_unit_fault_is_a_registered_built_in_in_the_real_category():
    for name in UNIT_FAULTS:
        assert get_fault(name) is real_faults()[name].fault and get_fault(name) in BUILTIN_FAULTS
    assert fault_categories() == {name: REAL for name in UNIT_FAULTS}
    listing = list_faults(plugins=False)
    assert [f.name for f in listing.in_category(REAL).faults] == [f.name for f in BUILTIN_FAULTS
                                                                  if f.name in UNIT_FAULTS]
    text = listing.format()
    assert text.count("(category: real)") == len(UNIT_FAULTS)


def test_faults_cli_lists_the_real_category(capsys):
    assert main(["faults", "--category", "real", "--no-plugins"]) == 0
    out = capsys.readouterr().out
    assert f"{len(UNIT_FAULTS)} faults ({len(UNIT_FAULTS)} built-in" in out
    assert "naive_resampling" not in out and all(name in out for name in UNIT_FAULTS)


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


def test_the_control_noise_fault_spreads_by_the_variances_by_hand():
    unit = get_fault("control_noise_from_covariance").replacement(REFERENCE_SAMPLE)
    config = FastSlamConfig()
    u = np.array([0.5, 0.1])
    eps = np.random.default_rng(3).standard_normal((4, 2))  # the unit's one draw
    np.testing.assert_allclose(unit(u, 4, np.random.default_rng(3), config),
                               u + eps * np.array([config.std_v ** 2, config.std_omega ** 2]), rtol=0, atol=1e-15)


# --------------------------------------------------------------------------- whole runs

_EXPERIMENT = """
description = "the real faults on the fixed case"
seed = 11
runs = 1
n_steps = 60
variants = {variants}
repetitions = 1
metrics = ["rms"]
fov_bug = {fov_bug}

[suites]
fixed = 1

[slam]
name = "fastslam"
particles = 20
"""


def _run(tmp_path, name, variants, fov_bug=False):
    exp = tmp_path / f"{name}.toml"
    exp.write_text(_EXPERIMENT.format(variants=str(variants).replace("'", '"'), fov_bug=str(fov_bug).lower()))
    assert main(["run", str(exp), "--out", str(tmp_path / name), "--jobs", "1", "--no-progress"]) == 0
    df = load_results(tmp_path / name)
    assert (df["status"] == "ok").all()
    return dict(zip(df["variant"], df["rms_mm"]))


@pytest.mark.slow
def test_every_real_fault_runs_through_faultlab_run_and_changes_the_map(tmp_path):
    rms = _run(tmp_path, "faults", ["baseline", *UNIT_FAULTS])
    assert set(rms) == {"baseline", *UNIT_FAULTS}
    for name in UNIT_FAULTS:
        assert rms[name] != rms["baseline"], name
    # the simulator's field-of-view defect is an experiment setting: the same case seen through it
    fov = _run(tmp_path, "fov", ["baseline"], fov_bug=True)
    assert fov["baseline"] != rms["baseline"]


def _case(n_steps=60, **over):
    spec = CaseSpec({**FIXED_VALUES, "map_size": 16.0, "landmark_density": 1.5, **over})
    return generate_scenario(spec, rng=np.random.default_rng(5), n_steps=n_steps)


def _maps(scenario, fault, config=FastSlamConfig(particles=20)):
    slam = FastSlam(config)
    base = run_slam(slam, scenario, rng=np.random.default_rng(1))
    faulty = run_slam(get_fault(fault).apply(slam), scenario, rng=np.random.default_rng(1))
    return base, faulty


def _same(a, b):
    return np.array_equal(a.landmarks, b.landmarks) and np.array_equal(a.pose, b.pose)


def test_measurement_noise_fault_changes_nothing_when_the_sensor_noise_equals_the_control_noise():
    noise = NoiseConfig()
    equal = FastSlamConfig(particles=20, std_range=noise.std_v, std_bearing=noise.std_omega)  # Q == M
    assert _same(*_maps(_case(), "measurement_noise_from_state_covariance", equal))
    assert not _same(*_maps(_case(), "measurement_noise_from_state_covariance"))


def test_control_noise_fault_changes_nothing_when_every_deviation_is_one():
    ones = FastSlamConfig(particles=20, std_v=1.0, std_omega=1.0)  # sigma^2 == sigma
    assert _same(*_maps(_case(), "control_noise_from_covariance", ones))
    assert not _same(*_maps(_case(), "control_noise_from_covariance"))


@pytest.mark.parametrize("fault", ["paper_aliasing", "shallow_copy_resampling"])
def test_resampling_faults_change_nothing_when_the_filter_never_resamples(fault):
    never = FastSlamConfig(particles=20, resample_ratio=1e12)  # N_eff >= 1 > N / ratio
    assert _same(*_maps(_case(), fault, never))
    assert not _same(*_maps(_case(), fault))


def _shifted(scenario, dx):
    """The world moved by dx along x (start pose, path and map): every range and bearing unchanged."""
    shift = np.array([dx, 0.0])
    return dataclasses.replace(scenario, landmarks=scenario.landmarks + shift,
                               true_poses=scenario.true_poses + np.array([dx, 0.0, 0.0]))


def test_new_landmark_near_zero_changes_nothing_far_from_the_y_axis_and_bites_on_it():
    case = _case()
    far = _shifted(case, 100.0)  # every estimate tens of metres from x = 0
    assert _same(*_maps(far, "new_landmark_near_zero"))
    first = case.obs_ids[0]  # put the first landmark seen on the y axis
    on_axis = _shifted(case, -float(case.landmarks[list(case.landmark_ids).index(first), 0]))
    assert not _same(*_maps(on_axis, "new_landmark_near_zero"))


def _first_sightings_only(scenario):
    """The scenario with every landmark observed once (its first sighting): no landmark update ever."""
    keep = np.zeros(scenario.obs_ids.size, dtype=bool)
    keep[np.unique(scenario.obs_ids, return_index=True)[1]] = True
    n = scenario.obs_offsets.size - 1
    step = np.repeat(np.arange(n), np.diff(scenario.obs_offsets))
    counts = np.bincount(step[keep], minlength=n)
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    once = dataclasses.replace(scenario, obs_offsets=offsets, obs_ids=scenario.obs_ids[keep],
                               obs_range=scenario.obs_range[keep], obs_bearing=scenario.obs_bearing[keep])
    once.validate()
    return once


def test_gain_fault_changes_nothing_when_no_landmark_is_seen_twice():
    case = _case()
    once = _first_sightings_only(case)
    assert once.obs_ids.size == np.unique(case.obs_ids).size and once.obs_ids.size > 3
    assert _same(*_maps(once, "gain_from_wrong_covariance"))
    assert not _same(*_maps(case, "gain_from_wrong_covariance"))


def test_fov_bug_changes_nothing_with_a_full_circle_field_of_view():
    spec = CaseSpec({**FIXED_VALUES, "field_of_view": 2 * math.pi})
    full = generate_scenario(spec, rng=np.random.default_rng(2), n_steps=60)
    bug = generate_scenario(spec, rng=np.random.default_rng(2), n_steps=60, fov_bug=True)
    for name in ("obs_offsets", "obs_ids", "obs_range", "obs_bearing"):
        np.testing.assert_array_equal(getattr(full, name), getattr(bug, name))
