"""The budget oracle: accuracy bounds per Table I class (the most lenient applies) and time per step,
on a planted slow user SLAM and its fast twin."""

import functools
import sys
from pathlib import Path

import pytest

from faultlab.campaigns.check import CheckSpec, run_check
from faultlab.config import read_toml
from faultlab.errors import ConfigError
from faultlab.oracles import BudgetOracle, judge_case, repetition_seeds
from faultlab.oracles.budget import case_budget_mm
from faultlab.oracles.oracle import execute, map_error_mm
from faultlab.scenario.suite import draw_suite, generate_case
from faultlab.slam.deadreckoning import DeadReckoning
from faultlab.slam.registry import build_slam
from faultlab.space.parameters import space_from_mapping

HERE = Path(__file__).parent
sys.path.insert(0, str(HERE))
import slow_slams  # noqa: E402

SPACE = read_toml(HERE / "small_space.toml", what="space")[0]


def _case(seed=3, steps=40):
    space = space_from_mapping(SPACE, source="small")
    return generate_case(draw_suite("random", space, root_seed=seed, n_cases=1)[0], n_steps=steps)


def _budget(factory, scenario, k=4, **options):
    return judge_case("c", scenario, factory, oracles=[BudgetOracle()], seeds=repetition_seeds(0, "c", k),
                      alpha=0.05, options=options).results[0]


def test_the_most_lenient_declared_class_applies_else_the_overall_budget():
    classes = {"map_size": "large", "outlier_probability": "high", "bias": "none"}
    opts = {"budget_mm": 100.0, "budget_classes": {"map_size.large": 500, "outlier_probability.high": 300,
                                                    "map_size.small": 50}}
    assert case_budget_mm(opts, classes) == 500
    assert case_budget_mm(opts, {"map_size": "medium"}) == 100
    assert case_budget_mm({"budget_classes": {"map_size.small": 50}}, {"map_size": "medium"}) is None


def test_accuracy_of_a_deterministic_slam_is_judged_exactly_on_its_one_run():
    sc = _case()
    err = map_error_mm(sc, execute(DeadReckoning, sc, 0))
    over = _budget(DeadReckoning, sc, budget_mm=err * 0.99)
    within = _budget(DeadReckoning, sc, budget_mm=err * 1.01)
    assert over.failed and "exactly" in over.message
    assert within.status == "pass"
    assert _budget(DeadReckoning, sc).status == "skip"


def test_accuracy_of_a_stochastic_slam_by_the_sign_test():
    sc = _case()
    fast = functools.partial(build_slam, "fastslam", {"particles": 10})
    errors = sorted(map_error_mm(sc, execute(fast, sc, s)) for s in repetition_seeds(0, "c", 8))
    above_all = _budget(fast, sc, k=8, budget_mm=errors[0] * 0.9)  # 8 of 8 above: p = 1/256
    assert above_all.failed and above_all.p_value == pytest.approx(0.5 ** 8)
    assert _budget(fast, sc, k=8, budget_mm=errors[4] * 1.001).status == "pass"  # 3 of 8 above
    assert _budget(fast, sc, k=4, budget_mm=errors[0] * 0.9).status == "pass"  # 4 of 4: p = 1/16, too few runs


def test_a_planted_quadratic_slam_exceeds_the_time_budget_and_its_twin_does_not():
    sc = _case(steps=60)
    assert sc.landmarks.shape[0] >= 20
    slow = _budget(slow_slams.make_slow, sc, budget_step_ms=1.0)
    fast = _budget(slow_slams.make_fast, sc, budget_step_ms=1.0)
    assert slow.failed and "ms per step" in slow.message
    assert fast.status == "pass", fast.message


def test_per_class_budgets_reach_each_case_through_check(tmp_path):
    spec = CheckSpec(slam="dead_reckoning", suite="random", n_cases=6, n_steps=30, repetitions=2, reference="",
                     oracles=("budget",), space=SPACE, options={"budget_classes": {"map_size.small": 0.001}})
    records = run_check(spec, tmp_path / "out", shrink=False)
    space = space_from_mapping(SPACE, source="small")
    expected = ["fail" if space["map_size"].class_names[c.spec.classes["map_size"]] == "small" else "skip"
                for c in draw_suite("random", space, root_seed=1, n_cases=6)]
    assert [r.results[0]["status"] for r in records] == expected
    assert "fail" in expected and "skip" in expected
    with pytest.raises(ConfigError, match="map_size's classes"):
        CheckSpec(slam="dead_reckoning", oracles=("budget",), space=SPACE,
                  options={"budget_classes": {"map_size.huge": 5}}).validate()
