"""Every committed report of a study (mutation, SLAMs, robustness, allocation) is what the code renders
from its committed store (see :mod:`tests.report.committed`; the paper's reports: ``test_committed``)."""

from __future__ import annotations

import pytest

from tests.report.committed import STUDY_REPORTS, check_committed, report_id


@pytest.mark.slow
@pytest.mark.parametrize("report, store, render, per_slam", STUDY_REPORTS, ids=[report_id(c) for c in STUDY_REPORTS])
def test_a_committed_study_report_is_what_its_committed_store_renders(report, store, render, per_slam, tmp_path,
                                                                       monkeypatch):
    check_committed(report, store, render, per_slam, tmp_path, monkeypatch)
