"""Holm's adjustment: statsmodels' values, bit for bit, without the full collection statsmodels forces."""

from __future__ import annotations

import gc

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from statsmodels.stats.multitest import multipletests

from faultlab.inference.multiplicity import holm

p_values = st.lists(st.floats(0.0, 1.0), min_size=0, max_size=40)


def _statsmodels_holm(p, alpha):
    """The reference: statsmodels' Holm, its forced full collection (0.1-0.3 s in a test worker, no effect on
    any value) replaced by a no-op."""
    collect, gc.collect = gc.collect, lambda *args: 0
    try:
        return multipletests(np.asarray(p, dtype=float), alpha=alpha, method="holm")
    finally:
        gc.collect = collect


@settings(max_examples=200, deadline=None)
@given(p_values, st.sampled_from([0.01, 0.05, 0.1]))
def test_holm_is_statsmodels_bit_for_bit(p, alpha):
    reject, adjusted = holm(p, alpha=alpha)
    expected_reject, expected_adjusted, _, _ = _statsmodels_holm(p, alpha)
    np.testing.assert_array_equal(reject, expected_reject)
    np.testing.assert_array_equal(adjusted, expected_adjusted)


def test_a_planted_family_is_adjusted_step_down():
    # sorted 0.001 0.01 0.02 0.5 over n = 4: 4 x 0.001, 3 x 0.01, max(0.03, 2 x 0.02), max(0.04, 0.5)
    reject, adjusted = holm([0.5, 0.01, 0.001, 0.02], alpha=0.05)
    np.testing.assert_allclose(adjusted, [0.5, 0.03, 0.004, 0.04])
    assert reject.tolist() == [False, True, True, True]


def test_no_full_collection_runs(monkeypatch):
    calls = []
    monkeypatch.setattr(gc, "collect", lambda *args: calls.append(args) or 0)
    multipletests(np.array([0.01, 0.2]), method="holm")
    assert len(calls) == 1  # statsmodels' Holm branch collects: what holm() avoids
    holm([0.01, 0.2])
    assert len(calls) == 1


@settings(max_examples=200, deadline=None)
@given(st.lists(st.sampled_from([0.0, 0.001, 0.01, 0.0125, 0.025, 0.05, 0.5, 1.0]), min_size=1, max_size=30),
       st.sampled_from([0.01, 0.05, 0.1]))
def test_ties_and_boundary_values_match_statsmodels(p, alpha):
    reject, adjusted = holm(p, alpha=alpha)
    expected_reject, expected_adjusted, _, _ = _statsmodels_holm(p, alpha)
    np.testing.assert_array_equal(reject, expected_reject)
    np.testing.assert_array_equal(adjusted, expected_adjusted)
