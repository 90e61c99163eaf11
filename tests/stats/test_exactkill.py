"""Exact kills of a deterministic SLAM: any change of the map error, or the mutant alone failing."""

import math

import pandas as pd
from hypothesis import given, settings
from hypothesis import strategies as st

from faultlab.stats.exactkill import exact_kills


def _row(case, variant, rms, status="ok", suite="random"):
    return dict(run=1, suite=suite, case=case, variant=variant, rep=0, status=status, rms_mm=rms,
                error="" if status == "ok" else "Boom: x")


def test_each_rule_on_one_case():
    df = pd.DataFrame([_row(1, "baseline", 100.0), _row(1, "mutant:a", 100.0), _row(1, "mutant:b", 100.0 + 1e-9),
                       _row(1, "mutant:c", math.nan, "crash"), _row(1, "mutant:d", math.nan, "timeout"),
                       _row(2, "baseline", math.nan, "crash"), _row(2, "mutant:a", 5.0)])
    k = exact_kills(df).set_index(["case", "fault"])
    assert k.loc[(1, "mutant:a"), "kill"] == "" and k.loc[(1, "mutant:a"), "verdict"] == "not_detected"
    assert k.loc[(1, "mutant:b"), "kill"] == "killed" and k.loc[(1, "mutant:b"), "direction"] == "worse"
    assert k.loc[(1, "mutant:c"), "kill"] == "crash" and k.loc[(1, "mutant:d"), "kill"] == "timeout"
    assert k.loc[(2, "mutant:a"), "verdict"] == "cannot_judge" and k.loc[(2, "mutant:a"), "kill"] == ""


values = st.sampled_from([100.0, 100.5, 99.0, math.nan])


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(values, values), min_size=2, max_size=6), st.integers(1, 5))
def test_adding_cases_never_unkills(cases, cut):
    """A suite kills when some case kills; the kill on a case reads that case alone: monotone in the cases."""
    rows = []
    for c, (b, m) in enumerate(cases, 1):
        rows += [_row(c, "baseline", b, "ok" if b == b else "crash"), _row(c, "mutant:x", m, "ok" if m == m else "crash")]
    df = pd.DataFrame(rows)
    cut = min(cut, len(cases))
    small = exact_kills(df[df["case"] <= cut])
    large = exact_kills(df)
    killed_small = (small["kill"] != "").any()
    killed_large = (large["kill"] != "").any()
    assert killed_large or not killed_small
    # and the per-case decisions are those of the larger suite on the shared cases
    pd.testing.assert_series_equal(small["kill"].reset_index(drop=True),
                                   large[large["case"] <= cut]["kill"].reset_index(drop=True))
