"""Bootstrap medians against a resample-by-resample transcription of the definition."""

import numpy as np
import pytest

from faultlab.inference.intervals import bootstrap_medians


@pytest.mark.parametrize("n", [1, 2, 7])
def test_bootstrap_medians_are_the_medians_of_the_resamples_drawn(n):
    x = np.random.default_rng(5).lognormal(size=n)
    got = bootstrap_medians(x, replicates=50, rng=np.random.default_rng(11))
    draws = np.random.default_rng(11).integers(0, n, size=(50, n))
    expected = [float(np.median([x[i] for i in row])) for row in draws]
    np.testing.assert_array_equal(got, expected)
    assert got.min() >= x.min() and got.max() <= x.max()
