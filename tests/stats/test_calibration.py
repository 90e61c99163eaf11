"""A/A calibration rates and the check that can fail, against textbook intervals."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from scipy.stats import binomtest

from faultlab.stats.calibration import check_calibration, false_alarm_rates


def _verdicts(p, p_holm=None, suites=None):
    p = np.asarray(p, float)
    return pd.DataFrame({"suite": suites if suites is not None else ["random"] * p.size, "p": p,
                         "p_holm": p if p_holm is None else p_holm})


def test_rates_count_unadjusted_and_holm_flags_per_suite_and_overall():
    v = _verdicts([0.01, 0.2, 0.04, np.nan], p_holm=[0.03, 1.0, 0.12, np.nan],
                  suites=["random", "random", "fixed", "fixed"])
    r = false_alarm_rates(v, alpha=0.05).set_index(["scope", "suite"])
    assert tuple(r.loc[("per_case", "all"), ["k", "n"]]) == (2, 3)      # the untested case is left out
    assert tuple(r.loc[("family_wise", "all"), ["k", "n"]]) == (1, 3)
    assert tuple(r.loc[("per_case", "fixed"), ["k", "n"]]) == (1, 1)


@pytest.mark.parametrize("k,n,status", [(10, 200, "calibrated"), (0, 9, "underpowered"), (30, 200, "miscalibrated"),
                                        (0, 0, "nothing_judged")])
def test_check_statuses_follow_the_interval(k, n, status):
    v = _verdicts(np.r_[np.full(k, 0.001), np.full(n - k, 0.5)])
    check = check_calibration(false_alarm_rates(v, alpha=0.05), alpha=0.05)
    assert check.status == status and check.failed == (status in ("miscalibrated", "nothing_judged"))
    if n:
        ci = binomtest(k, n).proportion_ci(method="exact")  # the reference: scipy's exact interval
        lo, hi = ci.low, ci.high
        assert (check.cp_low, check.cp_high) == pytest.approx((lo, hi), rel=1e-10, abs=1e-15)  # its root-finding's tolerance
        assert (status == "miscalibrated") == (lo > 0.05) and (status == "underpowered") == (lo <= 0.05 <= 0.1 <= hi)
