"""A new fault: the predicted range is scaled by 1 % (a mis-calibrated range sensor model).

Run: ``python docs/examples/add_fault.py``; the docs test runs it too.
"""

import numpy as np

from faultlab.faults import Fault
from faultlab.metrics import map_errors
from faultlab.scenario import generate_scenario
from faultlab.slam import FastSlam, FastSlamConfig, run_slam
from faultlab.space import FIXED_VALUES, CaseSpec

SCALE = 1.01


def _scaled_range(original):
    """Wrap the reference ``predict_measurement``: every predicted range 1 % too long."""

    def predict_measurement(poses, mu):
        zhat, H = original(poses, mu)
        zhat = np.array(zhat, dtype=float)  # never modify the original unit's output in place
        zhat[..., 0] *= SCALE
        return zhat, H

    return predict_measurement


RANGE_SCALE = Fault(
    name="howto/range_scale",  # plugin faults are provider/name
    step="predict_measurement",  # the one unit it replaces
    description="The predicted range is 1 % too long.",
    rationale="A scale factor from the sensor's data sheet applied to the model but not to the data.",
    origin="how-to example",
    replacement=_scaled_range,
)

scenario = generate_scenario(CaseSpec(FIXED_VALUES), rng=np.random.default_rng(1), n_steps=100)
reference = FastSlam(FastSlamConfig(particles=20))
faulty = RANGE_SCALE.apply(reference)  # a new instance; the reference is untouched
errors = {name: map_errors(scenario, run_slam(slam, scenario, rng=np.random.default_rng(2)))
          for name, slam in (("baseline", reference), ("fault", faulty))}
print({name: round(e.rms_mm, 1) for name, e in errors.items()})
assert errors["fault"].rms_mm != errors["baseline"].rms_mm  # not an equivalent mutant on this case
