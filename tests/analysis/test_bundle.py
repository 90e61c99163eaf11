"""faultlab.analysis.bundle: tables as CSV files, metadata as the ``meta`` field or the ``META_FIELDS``."""

from __future__ import annotations

import json
from dataclasses import dataclass

import pandas as pd
import pytest

from faultlab.analysis.bundle import TableBundle
from faultlab.errors import ResultsError


@dataclass(frozen=True)
class _Scalars(TableBundle):
    alpha: float
    seed: int
    campaign: dict
    rows: pd.DataFrame

    TABLES = ("rows",)
    META_FILE = "scalars.json"
    WHAT = "scalars"
    META_FIELDS = {"alpha": float, "seed": int, "campaign": dict}


@dataclass(frozen=True)
class _Whole(TableBundle):
    rows: pd.DataFrame
    meta: dict

    TABLES = ("rows",)


def test_meta_fields_are_the_saved_metadata_and_load_back_with_their_types(tmp_path):
    b = _Scalars(alpha=0.05, seed=3, campaign={"runs": 2}, rows=pd.DataFrame({"x": [1, 2]}))
    b.save(tmp_path)
    assert json.loads((tmp_path / "scalars.json").read_text()) == {"alpha": 0.05, "seed": 3, "campaign": {"runs": 2}}
    (tmp_path / "scalars.json").write_text(json.dumps({"alpha": "0.05", "seed": 3.0, "campaign": {"runs": 2}}))
    back = _Scalars.load(tmp_path)
    assert (back.alpha, back.seed, back.campaign) == (0.05, 3, {"runs": 2}) and isinstance(back.seed, int)
    pd.testing.assert_frame_equal(back.rows, b.rows)
    (tmp_path / "scalars.json").write_text(json.dumps({"alpha": 0.05, "campaign": {}}))
    with pytest.raises(ResultsError, match="scalars.json: not the metadata of a saved scalars .*seed"):
        _Scalars.load(tmp_path)


def test_without_meta_fields_the_metadata_is_the_meta_field(tmp_path):
    b = _Whole(rows=pd.DataFrame({"x": [1.5]}), meta={"k": [1, 2]})
    b.save(tmp_path)
    back = _Whole.load(tmp_path)
    assert back.meta == {"k": [1, 2]}
    pd.testing.assert_frame_equal(back.rows, b.rows)
