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


def test_the_committed_check_passes_a_last_bit_change_and_fails_a_change_at_the_written_precision(tmp_path):
    import numpy as np
    import pandas as pd

    from faultlab.precision import FLOAT_FORMAT, write_csv
    from tests.report.committed import REPORTS, stale_tables

    committed = REPORTS / "robustness"
    frame = pd.read_csv(committed / "parameters.csv")
    floats = [c for c in frame.columns if frame[c].dtype == float and frame[c].notna().any()]
    assert floats
    column = floats[0]
    row = int(frame[column].notna().idxmax())
    value = float(frame.at[row, column])
    digit = 10.0 ** (np.floor(np.log10(abs(value))) - 9)  # one unit in the 10th significant digit
    rendered = tmp_path / "rendered"
    rendered.mkdir()

    def render(v: float) -> list[str]:
        changed = frame.copy()
        changed.at[row, column] = v
        write_csv(changed, rendered / "parameters.csv")
        return stale_tables(committed, rendered)

    assert render(value) == []  # the committed table is what write_csv writes of its own values
    # a last-bit change that crosses a rounding boundary: the written last digit flips, the check passes
    boundary = value + digit / 2
    flipped = np.nextafter(boundary, np.inf)
    assert FLOAT_FORMAT % flipped != FLOAT_FORMAT % value
    assert render(flipped) == []
    assert render(np.nextafter(value, np.inf)) == []
    # a change of three units in the last written digit is stale
    assert render(value + 3 * digit) == ["parameters.csv"]
