"""A tiny third-party fault plugin for faultlab (the README's "Writing a fault plugin" example).

faultlab finds this module through the entry point declared in ``pyproject.toml``::

    [project.entry-points."faultlab.faults"]
    example = "faultlab_example_plugin:FAULTS"

The entry-point name (``example``) is the provider: fault names are ``example/<name>``.
"""

from __future__ import annotations

import numpy as np

from faultlab.faults import Fault

__all__ = ["FAULTS", "DOUBLE_RANGE_OFFSET"]

#: The sensor mounting offset, m.
OFFSET = 0.05


def _double_range_offset(original):
    """Wrap the reference ``predict_measurement``: add the offset to every predicted range."""

    def predict_measurement(poses, mu):
        zhat, H = original(poses, mu)
        zhat = np.array(zhat, dtype=float)  # never modify the original unit's output in place
        zhat[..., 0] += OFFSET
        return zhat, H

    return predict_measurement


DOUBLE_RANGE_OFFSET = Fault(
    name="example/double_range_offset",
    step="predict_measurement",
    description="The predicted range adds a 5 cm sensor mounting offset that the driver already removed.",
    rationale=(
        "Calibration offsets are easy to apply twice: once in the sensor driver and once in the "
        "measurement model. Every innovation is then biased by -5 cm, so each EKF update pulls the "
        "landmarks 5 cm towards the robot and the weights prefer particles that sit too far away."),
    origin="example plugin: a calibration applied twice (common integration error)",
    replacement=_double_range_offset,
)

#: What the entry point loads: a Fault or an iterable of Faults.
FAULTS = [DOUBLE_RANGE_OFFSET]
