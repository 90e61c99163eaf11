import numpy as np
import pytest

from faultlab.errors import SlamInputError
from faultlab.slam.streams import unit_streams


def _first(streams, name, n=5):
    return streams[name].random(n)


def test_a_stream_does_not_depend_on_the_other_names_or_their_order():
    a = unit_streams(np.random.default_rng(3), ["resample", "sample_controls"])
    b = unit_streams(np.random.default_rng(3), ["sample_controls"])
    c = unit_streams(np.random.default_rng(3), ["sample_controls", "resample", "extra"])
    ref = _first(a, "sample_controls")
    assert np.array_equal(ref, _first(b, "sample_controls"))
    assert np.array_equal(ref, _first(c, "sample_controls"))


def test_streams_differ_between_names_and_between_seeds():
    s = unit_streams(np.random.default_rng(3), ["a", "b"])
    t = unit_streams(np.random.default_rng(4), ["a"])
    assert not np.array_equal(_first(s, "a"), _first(s, "b"))
    assert not np.array_equal(_first(s, "a"), _first(t, "a"))


def test_the_parent_is_advanced_by_one_draw_only():
    rng = np.random.default_rng(9)
    unit_streams(rng, ["a", "b", "c"])
    ref = np.random.default_rng(9)
    ref.integers(0, 2 ** 63, size=2, dtype=np.int64)
    assert rng.random() == ref.random()


def test_bad_input():
    with pytest.raises(SlamInputError, match="Generator"):
        unit_streams(np.random.RandomState(0), ["a"])
    with pytest.raises(SlamInputError, match="distinct"):
        unit_streams(np.random.default_rng(0), ["a", "a"])
