"""The false-alarm rate of faultlab check on correct SLAMs, measured on 100 cases: at most alpha."""

import functools

import pytest

from faultlab.config import read_toml
from faultlab.campaigns.checkspec import DEFAULT_ORACLES
from faultlab.oracles import get_oracle, judge_case, repetition_seeds
from faultlab.scenario.suite import draw_suite, generate_case
from faultlab.slam.registry import build_slam
from faultlab.space.parameters import space_from_mapping

from pathlib import Path

ALPHA = 0.05
SPACE = Path(__file__).with_name("small_space.toml")


@pytest.mark.slow
def test_correct_slams_fail_at_most_alpha_of_100_cases():
    space = space_from_mapping(read_toml(SPACE, what="space")[0], source="small space")
    cases = draw_suite("random", space, root_seed=11, n_cases=100)
    slams = {"ekf": functools.partial(build_slam, "ekf", {}),
             "fastslam": functools.partial(build_slam, "fastslam", {"particles": 20})}
    reference = functools.partial(build_slam, "ekf", {})
    flagged, judged = [], 0
    for k, case in enumerate(cases):
        name = "ekf" if k % 2 == 0 else "fastslam"  # 50 cases each: deterministic and stochastic
        case_id = f"random-{case.case:03d}"
        j = judge_case(case_id, generate_case(case, n_steps=60), slams[name], oracles=[get_oracle(o) for o in DEFAULT_ORACLES],
                       seeds=repetition_seeds(11, case_id, 8), alpha=ALPHA, reference=reference)
        judged += 1
        if j.failed:
            flagged.append((name, case_id, [r.message for r in j.results if r.failed]))
    print(f"false alarms: {len(flagged)} of {judged} cases", flagged)
    assert judged == 100
    assert len(flagged) / judged <= ALPHA, flagged
