"""A new metamorphic relation: shifting the whole world shifts the estimate by the same vector.

Run: ``python docs/examples/add_metamorphic_relation.py``; the docs test runs it too.
"""

import numpy as np

from faultlab.metamorphic.check import Verdict, check_relation, metamorphic_scenario
from faultlab.metamorphic.relation import MetamorphicRelation, with_record
from faultlab.slam import Estimate, FastSlam, FastSlamConfig


class Shift(MetamorphicRelation):
    """Add a vector to every landmark and true position: the map moves by that vector."""

    name = "shift"
    description = "shifting the world and the start pose shifts the estimate the same way"

    def __init__(self, offset=(3.0, -2.0)):
        self.offset = np.asarray(offset, dtype=float).reshape(2)

    def transform(self, scenario, rng):
        poses = np.array(scenario.true_poses, dtype=float)
        poses[:, :2] += self.offset
        return with_record(scenario, self.name, landmarks=np.asarray(scenario.landmarks, float) + self.offset,
                           true_poses=poses, offset=self.offset)

    def expected(self, estimate, followup):
        offset = np.asarray(self.parameters(followup)["offset"])
        pose = np.asarray(estimate.pose, dtype=float) + [*offset, 0.0]
        return Estimate(pose, np.asarray(estimate.landmark_ids), np.asarray(estimate.landmarks) + offset)


scenario = metamorphic_scenario(seed=0, n_steps=60)
rngs = [np.random.default_rng(seed) for seed in (1, 2)]
slam = lambda: FastSlam(FastSlamConfig(particles=20))  # noqa: E731
result = check_relation(slam, Shift(), scenario, rngs=rngs)
print(result.verdict, result.statistic, result.tolerance)
assert result.verdict == Verdict.HOLDS  # the unmodified FastSLAM is translation-equivariant
