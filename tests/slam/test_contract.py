"""The unit contract against the steps tables it describes (faultlab.slam.contract)."""

import dataclasses
import inspect

import numpy as np

from faultlab.slam import FastSlamSteps
from faultlab.slam.contract import FILTER_UNITS, PARTICLE_UNITS, STREAM_UNITS, filter_wise


def test_every_fastslam_unit_is_called_either_per_particle_or_per_filter():
    units = {f.name for f in dataclasses.fields(FastSlamSteps)}
    assert set(PARTICLE_UNITS) | set(FILTER_UNITS) == units
    assert not set(PARTICLE_UNITS) & set(FILTER_UNITS)


def test_the_stream_units_are_exactly_the_units_taking_an_rng_and_are_filter_units():
    takes_rng = {f.name for f in dataclasses.fields(FastSlamSteps)
                 if "rng" in inspect.signature(f.default).parameters}
    assert set(STREAM_UNITS) == takes_rng
    assert set(STREAM_UNITS) <= set(FILTER_UNITS)


def test_filter_wise_marks_the_function_itself():
    def centred(nu, S):
        return np.zeros(nu.shape[:2])

    assert filter_wise(centred) is centred and centred.filter_wise is True
