"""A new SLAM by name from a distribution of your own: the example plugin's odometry-only mapper.

The SLAM (``examples/faultlab-example-plugin/src/faultlab_example_plugin/slam.py``) is a
:class:`~faultlab.slam.registry.SlamKind` that the distribution declares in its ``pyproject.toml``::

    [project.entry-points."faultlab.slams"]
    first_sighting = "faultlab_example_plugin.slam:FIRST_SIGHTING"

Installed (``pip install -e examples/faultlab-example-plugin``), it is a ``[slam] name`` like a built-in
in every process, the worker processes of ``faultlab run --jobs 2`` included.

Run: ``python docs/examples/add_slam.py``; the docs test runs it too.
"""

import numpy as np

from faultlab.metrics import map_errors
from faultlab.scenario import generate_scenario
from faultlab.slam import run_slam
from faultlab.slam.registry import all_slams, build_slam
from faultlab.space import FIXED_VALUES, CaseSpec

assert "first_sighting" in [kind.name for kind in all_slams()]  # found through the entry point

slam = build_slam("first_sighting", {})
scenario = generate_scenario(CaseSpec(FIXED_VALUES), rng=np.random.default_rng(1), n_steps=100)
errors = map_errors(scenario, run_slam(slam, scenario, rng=np.random.default_rng(2)))
print(errors)
assert errors.n_mapped == np.unique(scenario.obs_ids).size  # every landmark it observed, nothing else
