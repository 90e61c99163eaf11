"""The repetitions-against-cases report rendered from a planted pool."""

import re
import subprocess
import sys

import numpy as np
import pandas as pd

from faultlab.analysis.allocation import allocation_study, allocation_summary
from faultlab.report.allocation import allocation_markdown


def _planted() -> pd.DataFrame:
    rng = np.random.default_rng(1)
    rows = []
    for case in range(10):
        base = 1000.0 + 100.0 * rng.random(12)
        for variant, errors in (("baseline", base), ("always", base * 1.5), ("some", base * (1.5 if case < 2 else 1))):
            rows += [dict(run=1, suite="random", case=case, rep=r, variant=variant, status="ok", rms_mm=errors[r],
                          emd_mm=1.0, runtime_s=0.1) for r in range(12)]
    return pd.DataFrame(rows)


def test_markdown_lists_every_allocation_and_no_zero_width_interval():
    table = allocation_study(_planted(), budget=36, ks=[6, 9, 12], draws=100, seed=0)
    meta = {"budget": 36, "pool": 10, "stored_k": 12, "n_steps": 60, "slam": "fastslam", "ks": [6, 9, 12],
            "draws": 100, "seed": 0, "alternative": "two-sided", "alpha": 0.05}
    text = allocation_markdown(table, allocation_summary(table), meta)
    for k, n in ((6, 6), (9, 4), (12, 3)):
        assert f"| always | {k} x {n} |" in text
    intervals = re.findall(r"\(([<>]?[\d.]+)-([<>]?[\d.]+)\)", text)
    assert intervals and all(lo != hi for lo, hi in intervals)   # 'always' is certain: 100 % (>99.99-100.00)


def test_k_report_refuses_a_budget_k_does_not_divide_and_writes_nothing(tmp_path):
    reports = tmp_path / "reports"
    proc = subprocess.run([sys.executable, "-m", "faultlab", "study", "k-report", str(tmp_path / "missing"),
                           "--budget", "70", "--k", "6", "--reports", str(reports)], capture_output=True, text=True)
    assert proc.returncode != 0 and "Traceback" not in proc.stderr and proc.stderr.strip()
    assert not reports.exists()
