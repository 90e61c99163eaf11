"""faultlab compare on a stochastic SLAM: against itself (independent seeds) no regression and equivalence
within the default delta; against a planted degradation a regression.  The full measurement (100 runs) is
``benchmarks/compare_calibration.py``; this is its seeded small version, which can fail."""

from pathlib import Path

import pytest

from faultlab.analysis.compare import DEFAULT_DELTA, compare_records
from faultlab.campaigns.compare import RecordSpec, candidate_spec, record
from faultlab.config import read_toml

HERE = Path(__file__).parent
SPACE = read_toml(HERE.parent / "oracles" / "small_space.toml", what="space")[0]
RUNS = 6  # seeds 1-6 of the benchmark's runs, at compare's default K = 8


@pytest.mark.slow
def test_self_compare_is_equivalent_and_a_planted_degradation_is_a_regression(tmp_path):
    self_ok, self_regressions, found = 0, 0, 0
    for seed in range(1, RUNS + 1):
        base = RecordSpec(slam="compare_slams:fastslam20", suite="pairwise", n_steps=60, seed=seed, repetitions=8,
                          paths=(str(HERE),), space=SPACE)
        b = record(base, tmp_path / f"b{seed}")
        same = candidate_spec(base, slam="compare_slams:fastslam20", rep_seed=seed + 100_000)
        r = compare_records(base.to_dict(), b, same.to_dict(), record(same, tmp_path / f"s{seed}"),
                            delta=DEFAULT_DELTA)
        self_ok += (not r.regression) and r.equivalent
        self_regressions += r.regression
        worse = candidate_spec(base, slam="compare_slams:miscalibrated", rep_seed=seed + 200_000)
        found += compare_records(base.to_dict(), b, worse.to_dict(), record(worse, tmp_path / f"d{seed}"),
                                 delta=DEFAULT_DELTA).regression
    assert self_regressions == 0
    assert self_ok >= RUNS - 1
    assert found >= RUNS - 2
