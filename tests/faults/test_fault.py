"""The fault contract (faultlab.faults.fault): what a replacement receives as its original unit."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from faultlab.faults.fault import Fault
from faultlab.slam import REFERENCE_STEPS
from faultlab.slam import twins
from faultlab.slam import units as U

SEEN: list = []


def _record(original):
    SEEN.append(original)
    return original


def _fault(step: str) -> Fault:
    return Fault(name="test/record", step=step, description="records its original", rationale="test",
                 origin="test", replacement=_record)


def _numpy_resample(w, n_eff, empty, rng, config):
    return U.resample(w, n_eff, empty, rng, config)


@pytest.mark.skipif(not twins.JIT_ENABLED, reason="compiled twins turned off (FAULTLAB_JIT=0)")
def test_a_replacement_wraps_the_twin_of_a_reference_unit_on_the_compiled_path(monkeypatch):
    SEEN.clear()
    _fault("ekf_update").patch(REFERENCE_STEPS)
    _fault("combine_weights").patch(REFERENCE_STEPS)  # no twin: the unit itself
    custom = dataclasses.replace(REFERENCE_STEPS, resample=_numpy_resample)
    _fault("resample").patch(custom)  # not the reference: as it is
    monkeypatch.setattr(twins, "JIT_ENABLED", False)
    _fault("ekf_update").patch(REFERENCE_STEPS)  # twins off: the numpy unit
    assert SEEN == [twins.ekf_update, U.combine_weights, _numpy_resample, U.ekf_update]


@pytest.mark.skipif(not twins.JIT_ENABLED, reason="compiled twins turned off (FAULTLAB_JIT=0)")
def test_the_twin_a_replacement_wraps_returns_the_units_values():
    rng = np.random.default_rng(4)
    n, k = 5, 3
    mu, nu = rng.normal(size=(n, k, 2)), rng.normal(size=(n, k, 2))
    P = np.broadcast_to(np.eye(2) * 0.3, (n, k, 2, 2)).copy()
    H, S = rng.normal(size=(n, k, 2, 2)), np.broadcast_to(np.eye(2) * 2.0, (n, k, 2, 2)).copy()
    SEEN.clear()
    unit = _fault("ekf_update").patch(REFERENCE_STEPS).ekf_update
    for got, want in zip(unit(mu, P, H, S, nu), U.ekf_update(mu, P, H, S, nu)):
        assert np.array_equal(got.view(np.int64), np.asarray(want).view(np.int64))
