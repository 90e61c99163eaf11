"""Holm's adjustment: statsmodels' values, bit for bit, without the full collection statsmodels forces."""

from __future__ import annotations

import gc
import threading

import numpy as np
import pytest
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


def test_no_full_collection_runs_and_gc_collect_is_restored(monkeypatch):
    calls = []
    monkeypatch.setattr(gc, "collect", lambda *args: calls.append(args) or 0)
    counting = gc.collect
    multipletests(np.array([0.01, 0.2]), method="holm")
    assert len(calls) == 1  # statsmodels' Holm branch collects: what holm() avoids
    holm([0.01, 0.2])
    assert len(calls) == 1 and gc.collect is counting


def test_gc_collect_is_restored_after_an_error_and_after_concurrent_calls(monkeypatch):
    import faultlab.inference.multiplicity as multiplicity

    original = gc.collect

    def failing(*args, **kwargs):
        assert gc.collect is not original  # raised while the collection is swapped out
        raise RuntimeError("statsmodels failed")

    with monkeypatch.context() as m:
        m.setattr(multiplicity, "multipletests", failing)
        with pytest.raises(RuntimeError, match="statsmodels failed"):
            holm([0.1, 0.2])
    assert gc.collect is original
    threads = [threading.Thread(target=lambda: [holm(np.random.default_rng(i).random(30)) for _ in range(50)])
               for i in range(4)]
    for t in threads:
        t.start()
    for t in threads:
        t.join()
    assert gc.collect is original
