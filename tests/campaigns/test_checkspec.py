"""faultlab check's executions run within a wall-clock limit: a user's SLAM stuck in a Python loop
times out (execution oracle), and the check finishes."""

import time
from pathlib import Path

from faultlab.campaigns.check import CheckSpec, run_check
from faultlab.campaigns.checkspec import execute_limited
from faultlab.config import read_toml
from faultlab.scenario.suite import draw_suite, generate_case
from faultlab.space.parameters import space_from_mapping

HERE = Path(__file__).parent
SPACE = read_toml(HERE.parent / "oracles" / "small_space.toml", what="space")[0]

MODULE = '''
from faultlab.slam.deadreckoning import DeadReckoning


class Stuck(DeadReckoning):
    """Waits for a landmark it will never see: loops forever after step 5."""

    def reset(self, pose, *, rng):
        super().reset(pose, rng=rng)
        self.t = 0

    def update(self, control, observations):
        self.t += 1
        while self.t > 5:
            try:
                pass
            except Exception:  # a SLAM swallowing exceptions cannot swallow the limit
                pass
        super().update(control, observations)


def make():
    return Stuck()
'''


def test_a_slam_looping_forever_times_out_and_the_check_finishes(tmp_path):
    (tmp_path / "stuck_slam.py").write_text(MODULE)
    spec = CheckSpec(slam="stuck_slam:make", paths=(str(tmp_path),), suite="random", n_cases=2, n_steps=20,
                     repetitions=2, oracles=("execution", "floor"), reference="", space=SPACE, timeout_s=1.0)
    start = time.monotonic()
    records = run_check(spec, tmp_path / "out", shrink=False)
    elapsed = time.monotonic() - start
    assert len(records) == 2
    for rec in records:
        execution = [r for r in rec.results if r["oracle"] == "execution"][0]
        assert execution["status"] == "fail" and "timeout: wall-clock limit of 1 s" in execution["message"]
    # two runs per case (the same timeout twice: a deterministic failure), each stopped after 1 s
    assert elapsed < 2 * 2 * (1.0 + 5.0) + 30


def test_a_run_within_the_limit_is_untouched():
    from faultlab.slam.deadreckoning import DeadReckoning

    space = space_from_mapping(SPACE, source="small")
    sc = generate_case(draw_suite("random", space, root_seed=1, n_cases=1)[0], n_steps=20)
    out = execute_limited(DeadReckoning, sc, 0, timeout_s=30.0)
    assert out.ok and out.seconds < 30.0
