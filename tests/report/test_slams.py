"""The cross-SLAM report (faultlab.report.slams)."""

import numpy as np

from faultlab.analysis.slams import compare_slams
from tests.analysis.test_slams import stores  # noqa: F401  (the fixture: one tiny store per SLAM)


def test_the_report_renders_every_number_of_the_comparison(stores, tmp_path):  # noqa: F811
    from faultlab.report.slams import write_slam_report

    c = compare_slams(stores)
    page = write_slam_report(c, tmp_path).read_text()
    for name in ("accuracy.csv", "sensitivity.csv", "not_judged.csv", "protocol.json", "slams.png"):
        assert (tmp_path / name).stat().st_size > 0
    for r in c.accuracy.itertuples():
        assert f"| {r.slam} | {r.association} | {r.metric.upper()} | {r.n_cases} | {r.n_jobs} | " in page
    for r in c.sensitivity.itertuples():
        assert f"| {r.slam} | {r.fault} | {r.metric.upper()} | paper's thresholds | {r.k}/{r.n} |" in page
        # two cases: no outcome of the two-sided campaign-level test reaches alpha (2^-1), and the page says so
        assert r.effect_verdict == "cannot_judge" and "| cannot judge (smallest attainable p = 0.5) |" in page
    assert np.isfinite(c.accuracy.mean_mm).all()
