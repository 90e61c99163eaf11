"""Map error over cases with intervals (faultlab.stats.accuracy)."""

import math

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from faultlab.errors import ConfigError
from faultlab.stats.accuracy import ACCURACY_COLUMNS, case_mean_accuracy


def _frame(per_case_reps):
    return pd.DataFrame([{"run": 1, "suite": "s", "case": c, "rms_mm": x}
                         for c, xs in enumerate(per_case_reps) for x in xs])


def test_intervals_are_t_intervals_over_the_per_case_means():
    df = _frame([[10.0, 30.0], [100.0, 120.0, 110.0], [55.0]])
    out = case_mean_accuracy(df, value="rms_mm", case=["run", "suite", "case"], alpha=0.1)
    means = np.array([20.0, 110.0, 55.0])  # by hand
    lo, hi = stats.t.interval(0.9, 2, loc=means.mean(), scale=stats.sem(means))
    assert set(out) == set(ACCURACY_COLUMNS)
    assert out["n_cases"] == 3 and out["n_jobs"] == 6
    assert out["mean_mm"] == pytest.approx(means.mean())
    assert (out["mean_low"], out["mean_high"]) == pytest.approx((lo, hi))
    glo, ghi = stats.t.interval(0.9, 2, loc=np.log(means).mean(), scale=stats.sem(np.log(means)))
    assert out["gmean_mm"] == pytest.approx(stats.gmean(means))
    assert (out["gmean_low"], out["gmean_high"]) == pytest.approx((math.exp(glo), math.exp(ghi)))
    assert out["median_mm"] == 55.0


def test_one_case_has_no_interval_and_bad_input_is_refused():
    out = case_mean_accuracy(_frame([[4.0, 6.0]]), value="rms_mm", case=["case"])
    assert out["mean_mm"] == 5.0 and math.isnan(out["mean_low"]) and math.isnan(out["gmean_high"])
    assert case_mean_accuracy(_frame([]).reindex(columns=["run", "suite", "case", "rms_mm"]), value="rms_mm",
                              case=["case"])["n_cases"] == 0
    with pytest.raises(ConfigError, match="non-finite"):
        case_mean_accuracy(_frame([[1.0, math.nan]]), value="rms_mm", case=["case"])
    with pytest.raises(ConfigError, match="alpha"):
        case_mean_accuracy(_frame([[1.0]]), value="rms_mm", case=["case"], alpha=1.5)
