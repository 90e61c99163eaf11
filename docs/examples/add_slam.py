"""A new SLAM registered by name: an odometry-only mapper as a built-in ``[slam] name``.

Run: ``python docs/examples/add_slam.py``; the docs test runs it too.
"""

import numpy as np

from faultlab.metrics import map_errors
from faultlab.scenario import generate_scenario
from faultlab.slam import Estimate, SlamAdapter, run_slam
from faultlab.slam.registry import BUILTIN_SLAMS, SlamKind, build_slam
from faultlab.space import FIXED_VALUES, CaseSpec


class FirstSighting(SlamAdapter):
    """Integrates the odometry and puts each landmark where it was first seen."""

    name = "first_sighting"

    def reset(self, pose, *, rng):
        self.pose = np.array(pose, dtype=float)
        self.ids = np.empty(0, dtype=np.int64)
        self.xy = np.empty((0, 2))

    def update(self, control, observations):
        v, omega = control
        x, y, th = self.pose
        x, y = x + v * np.cos(th), y + v * np.sin(th)
        th = (th + omega + np.pi) % (2 * np.pi) - np.pi
        self.pose = np.array([x, y, th])
        ids = np.asarray(observations.ids)
        new, first = np.unique(ids[~np.isin(ids, self.ids)], return_index=True)
        r = np.asarray(observations.ranges)[~np.isin(ids, self.ids)][first]
        b = np.asarray(observations.bearings)[~np.isin(ids, self.ids)][first]
        xy = np.column_stack([x + r * np.cos(th + b), y + r * np.sin(th + b)])
        self.ids, self.xy = np.concatenate([self.ids, new]), np.concatenate([self.xy, xy])

    def estimate(self):
        return Estimate(self.pose.copy(), self.ids.copy(), self.xy.copy())


# In faultlab itself this entry goes into BUILTIN_SLAMS in faultlab/slam/registry.py.
BUILTIN_SLAMS["first_sighting"] = SlamKind("first_sighting", "odometry only, landmarks where first seen",
                                           FirstSighting)

slam = build_slam("first_sighting", {})
scenario = generate_scenario(CaseSpec(FIXED_VALUES), rng=np.random.default_rng(1), n_steps=100)
errors = map_errors(scenario, run_slam(slam, scenario, rng=np.random.default_rng(2)))
print(errors)
assert errors.n_mapped == np.unique(scenario.obs_ids).size  # every landmark it observed, nothing else
