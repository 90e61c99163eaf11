"""Each built-in sensor fault perturbs only what it says, deterministically, and runs end to end."""

import math
import sqlite3
import tomllib

import numpy as np
import pytest

from faultlab.faults import check_scenario, get_fault, list_faults, not_applicable
from faultlab.faults.registry import builtin_faults
from faultlab.faults.sensorfaults import BUILTIN_SENSOR_FAULTS, episodes
from faultlab.data import resolve_experiment
from faultlab.runner import parse_experiment, run_experiment
from tests.processslam import example_slam  # noqa: F401  (fixture)

STREAM = [f for f in BUILTIN_SENSOR_FAULTS if f.perturbs_stream]
#: fault name -> the scenario fields it may change
CHANGES = {"obs_dropout": "obs", "obs_burst_dropout": "obs", "stuck_range": "range", "obs_delay": "obs",
           "obs_out_of_order": "obs", "range_quantisation": "range", "range_bias_drift": "range",
           "wheel_scale": "v", "wheel_slip": "v", "step_jitter": "controls"}
GROUND_TRUTH = ("landmarks", "landmark_ids", "true_poses")


@pytest.fixture(scope="module")
def scenario():
    return check_scenario(seed=3, n_steps=300)


def test_at_least_eight_faults_with_distinct_names():
    names = [f.name for f in BUILTIN_SENSOR_FAULTS]
    assert len(names) >= 8 and len(set(names)) == len(names)
    assert not set(names) & set(builtin_faults())
    assert set(CHANGES) == {f.name for f in STREAM}
    assert [f.name for f in list_faults(plugins=False).sensor_faults] == names


@pytest.mark.parametrize("fault", STREAM, ids=lambda f: f.name)
def test_perturbs_only_what_it_says(fault, scenario):
    out = fault.perturb(scenario, seed=11)
    for name in GROUND_TRUTH:
        assert getattr(out, name) is getattr(scenario, name)
    assert out.case == scenario.case
    kind = CHANGES[fault.name]
    if kind in ("range", "v", "controls"):
        np.testing.assert_array_equal(out.obs_offsets, scenario.obs_offsets)
        np.testing.assert_array_equal(out.obs_ids, scenario.obs_ids)
        np.testing.assert_array_equal(out.obs_bearing, scenario.obs_bearing)
    if kind in ("range", "obs"):
        np.testing.assert_array_equal(out.controls, scenario.controls)
    if kind == "v":
        np.testing.assert_array_equal(out.controls[:, 1], scenario.controls[:, 1])
    if kind in ("v", "controls"):
        np.testing.assert_array_equal(out.obs_range, scenario.obs_range)
    changed = (not np.array_equal(out.obs_range, scenario.obs_range)
               or not np.array_equal(out.controls, scenario.controls)
               or not np.array_equal(out.obs_offsets, scenario.obs_offsets))
    assert changed, f"{fault.name} changed nothing"
    if kind == "obs":  # observations are delivered whole (range, bearing and id together): a subset or a move
        before = {(r, b, i) for r, b, i in zip(scenario.obs_range, scenario.obs_bearing, scenario.obs_ids)}
        after = set(zip(out.obs_range, out.obs_bearing, out.obs_ids))
        assert after <= before


@pytest.mark.parametrize("fault", STREAM, ids=lambda f: f.name)
def test_deterministic_from_the_seed(fault, scenario):
    a, b = fault.perturb(scenario, seed=5), fault.perturb(scenario, seed=5)
    for name in ("controls", "obs_offsets", "obs_range", "obs_bearing", "obs_ids"):
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
    c = fault.perturb(scenario, seed=6)
    same = all(np.array_equal(getattr(a, n), getattr(c, n)) for n in ("controls", "obs_offsets", "obs_range"))
    assert same != fault.stochastic


def test_dropout_removes_about_p_of_the_observations(scenario):
    out = get_fault("obs_dropout").perturb(scenario, seed=1)
    m = scenario.obs_range.size
    p = 0.2
    kept = out.obs_range.size
    assert abs((m - kept) - p * m) < 5 * math.sqrt(m * p * (1 - p))


def test_quantisation_gives_multiples_of_the_step_within_half_a_step(scenario):
    out = get_fault("range_quantisation").perturb(scenario, seed=0)
    q = out.obs_range / 0.1
    np.testing.assert_allclose(q, np.round(q), atol=1e-9)
    assert np.all(np.abs(out.obs_range - scenario.obs_range) <= 0.05 + 1e-12)


def test_delay_shifts_every_batch_by_one_step(scenario):
    out = get_fault("obs_delay").perturb(scenario, seed=0)
    assert len(out.observations(0)[0]) == 0
    for t in range(1, scenario.n_steps):
        for a, b in zip(out.observations(t), scenario.observations(t - 1)):
            np.testing.assert_array_equal(a, b)


def test_wheel_scale_multiplies_v_only(scenario):
    out = get_fault("wheel_scale").perturb(scenario, seed=0)
    np.testing.assert_allclose(out.controls[:, 0], 1.05 * scenario.controls[:, 0])


def test_stuck_range_repeats_an_earlier_reading(scenario):
    out = get_fault("stuck_range").perturb(scenario, seed=2)
    changed = np.flatnonzero(out.obs_range != scenario.obs_range)
    assert changed.size
    for i in changed:  # the frozen value is a range read before, at an unchanged position
        earlier = scenario.obs_range[:i][out.obs_range[:i] == scenario.obs_range[:i]]
        assert out.obs_range[i] == earlier[-1]


def test_episodes_against_a_loop():
    rng = np.random.default_rng(4)
    got = episodes(200, np.random.default_rng(4), rate=0.05, mean_length=6)
    starts = np.flatnonzero(rng.random(200) < 0.05)
    lengths = rng.geometric(1 / 6, size=starts.size)
    want = np.zeros(200, bool)
    for s, n in zip(starts, lengths):
        want[s:s + n] = True
    np.testing.assert_array_equal(got, want)


def test_particle_budget_applies_only_to_slams_with_particles():
    fault = get_fault("particle_budget")
    assert not_applicable(fault, "fastslam") is None
    assert fault.configure_options({"particles": 30})["particles"] == 8
    for slam in ("ekf", "gtsam", "dead_reckoning"):
        reason = not_applicable(fault, slam)
        assert reason is not None and "particles" in str(reason)
    assert not_applicable(fault, "process", options={"command": ["x"]}) is not None
    assert all(not_applicable(f, "ekf") is None for f in STREAM)


def _tiny(slam: dict, variants: list[str]):
    data = tomllib.loads(resolve_experiment("smoke").read_text())
    data.update(slam=slam, variants=["baseline", *variants], n_steps=25, repetitions=2,
                suites={"random": 2}, metrics=["rms"])  # the checks read the RMS; the EMD would cost 90 %
    return parse_experiment(data)


def _rows(summary):
    with sqlite3.connect(summary.results) as con:
        return {(v, c, r): (s, rms) for v, c, r, s, rms in
                con.execute("select variant, \"case\", rep, status, rms_mm from results")}


@pytest.mark.slow
def test_fastslam_campaign_with_sensor_faults(tmp_path):
    names = ["obs_dropout", "wheel_scale", "particle_budget"]
    summary = run_experiment(_tiny({"name": "fastslam", "particles": 8}, names), tmp_path, jobs=1,
                             progress=False)
    rows = _rows(summary)
    assert summary.counts["ok"] == len(rows) == 2 * 2 * 4
    # the faults change the map error of at least one job each, the baseline is reproduced
    for name in names:
        assert any(rows[(name, c, r)][1] != rows[("baseline", c, r)][1] for c in (1, 2) for r in (0, 1))
    again = run_experiment(_tiny({"name": "fastslam", "particles": 8}, names), tmp_path / "again", jobs=1,
                           progress=False)
    assert _rows(again) == rows


@pytest.mark.slow
def test_process_adapter_campaign_with_sensor_faults(example_slam, tmp_path):  # noqa: F811
    exp = _tiny({"name": "process", "command": [str(example_slam)]},
                ["obs_burst_dropout", "step_jitter", "particle_budget"])
    with pytest.warns(UserWarning, match="particle_budget"):
        summary = run_experiment(exp, tmp_path, jobs=1, progress=False)
    rows = _rows(summary)
    assert {v for v, _, _ in rows} == {"baseline", "obs_burst_dropout", "step_jitter"}
    assert all(s == "ok" for s, _ in rows.values())
    assert any(rows[("step_jitter", c, r)][1] != rows[("baseline", c, r)][1] for c in (1, 2) for r in (0, 1))
