"""The stream a variant is fed (faultlab.scenario.feed)."""

import numpy as np

from faultlab.faults import get_fault
from faultlab.scenario import fixed_case_scenario
from faultlab.scenario.feed import fed_scenario, perturbs_stream, sets_option
from faultlab.seeds import sensor_seed_sequence


def test_only_stream_faults_change_the_stream_and_they_draw_from_their_own_seed_stream():
    case = fixed_case_scenario({"map_size": 16.0}, seed=0, n_steps=30)
    dropout, budget, code = get_fault("obs_dropout"), get_fault("particle_budget"), get_fault("missing_angle_wrap")
    for variant in (None, budget, code):
        assert fed_scenario(variant, case, seed=7) is case
    assert (perturbs_stream(dropout), perturbs_stream(budget), perturbs_stream(code), perturbs_stream(None)) == (
        True, False, False, False)
    assert (sets_option(dropout), sets_option(budget), sets_option(code), sets_option(None)) == (
        False, True, False, False)
    fed = fed_scenario(dropout, case, seed=7)
    # independent reference: the fault's perturbation called with the generator the seed scheme defines
    ref = dropout.perturbation(case, np.random.default_rng(sensor_seed_sequence(7, "obs_dropout")))
    np.testing.assert_array_equal(fed.obs_ids, ref.obs_ids)
    np.testing.assert_array_equal(fed.obs_offsets, ref.obs_offsets)
    assert fed.obs_ids.size < case.obs_ids.size and fed.landmarks is case.landmarks
    assert not np.array_equal(fed_scenario(dropout, case, seed=8).obs_ids, fed.obs_ids)
