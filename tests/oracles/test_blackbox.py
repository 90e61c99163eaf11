"""faultlab check on black-box SLAMs written like a user's, each with one planted bug and a fixed twin.

Each bug is flagged by the oracle that fits it, the fixed twin passes that oracle, the case shrinks
to a minimal one, and the generated pytest reproducer fails on the buggy SLAM and passes on the twin.
"""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from faultlab.campaigns.checkshrink import reduce_failure
from faultlab.campaigns.checkspec import CheckSpec, judge_scenario
from faultlab.config import read_toml
from faultlab.scenario.suite import draw_suite, generate_case
from faultlab.space.parameters import space_from_mapping

REPO = Path(__file__).resolve().parents[2]
PROGRAM = REPO / "tests" / "oracles" / "blackbox_process.py"
SPACE = Path(__file__).with_name("small_space.toml")

# bug -> (buggy SLAM, fixed twin, the oracle that must flag it, the relation for a metamorphic one)
BUGS = {
    "wrap": ("tests.oracles.blackbox:ekf_wrap", "tests.oracles.blackbox:ekf_fixed", "metamorphic", "bearing_turn"),
    "jacobian": ("tests.oracles.blackbox:ekf_jacobian", "tests.oracles.blackbox:ekf_fixed", "differential", None),
    "symmetry": ("tests.oracles.blackbox:ekf_symmetry", "tests.oracles.blackbox:ekf_fixed", "execution", None),
    "off_by_one": ("tests.oracles.blackbox:mapper_off_by_one", "tests.oracles.blackbox:mapper_fixed", "metamorphic",
                   "id_permutation"),
    "turn_first": (f"{sys.executable} {PROGRAM} --bug turn_first", f"{sys.executable} {PROGRAM}", "differential", None),
}


def _spec(slam: str, oracle: str) -> CheckSpec:
    if slam.startswith(sys.executable):
        return CheckSpec(command=tuple(slam.split()), oracles=(oracle,), paths=(str(REPO),), n_steps=200)
    return CheckSpec(slam=slam, oracles=(oracle,), paths=(str(REPO),), n_steps=200)


@pytest.fixture(scope="module")
def case():
    space = space_from_mapping(read_toml(SPACE, what="space")[0], source="small space")
    first = draw_suite("pairwise", space, root_seed=1)[0]
    return "pairwise-1-001", generate_case(first, n_steps=200)


@pytest.mark.parametrize("bug", list(BUGS))
def test_the_right_oracle_flags_the_bug_and_passes_the_fixed_twin(bug, case):
    buggy, fixed, oracle, relation = BUGS[bug]
    case_id, scenario = case
    (found,) = judge_scenario(_spec(buggy, oracle), case_id, scenario).results
    assert found.failed, found.message
    if relation:
        assert relation in found.details["violated"]
    (twin,) = judge_scenario(_spec(fixed, oracle), case_id, scenario).results
    assert twin.status == "pass", twin.message


@pytest.mark.slow
@pytest.mark.parametrize("bug", list(BUGS))
def test_the_bug_shrinks_and_its_reproducer_fails_on_the_bug_and_passes_on_the_twin(bug, case, tmp_path):
    buggy, fixed, oracle, _ = BUGS[bug]
    case_id, scenario = case
    spec = _spec(buggy, oracle)
    judgement = judge_scenario(spec, case_id, scenario)
    summary = reduce_failure(spec, case_id, scenario, judgement, tmp_path)[oracle]
    assert summary["confirmed"]
    minimal, original = summary["minimal"], summary["original"]
    assert minimal["steps"] < original["steps"] and minimal["landmarks"] < original["landmarks"]
    print(f"{bug}: {original} -> {minimal} in {summary['tests']} tests")
    (test_file,) = Path(summary["directory"]).glob("test_*.py")
    run = lambda env: subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:randomly", "-p", "no:cacheprovider",
                                      str(test_file)], cwd=tmp_path, env={**os.environ, **env}, capture_output=True,
                                     text=True)
    on_bug = run({})
    assert on_bug.returncode == 1, on_bug.stdout
    twin = {"FAULTLAB_COMMAND": fixed} if fixed.startswith(sys.executable) else {"FAULTLAB_SLAM": fixed}
    on_twin = run(twin)
    assert on_twin.returncode == 0, on_twin.stdout
