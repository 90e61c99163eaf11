"""The strategies study's analysis: the committed confirmatory study's declared answer is what its store gives."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from faultlab.runner.store import load_metadata, load_results
from faultlab.stats.declaration import declaration_from, declared_table
from faultlab.stats.killmatrix import case_scores, kill_matrix
from faultlab.stats.metadata import judged_metric, read_rule

CONFIRM = Path(__file__).resolve().parents[2] / "reports" / "study-confirm"


@pytest.mark.slow
def test_the_committed_confirmatory_answer_is_the_declaration_stored_before_the_run_applied_to_its_store():
    store = CONFIRM / "store"
    meta = load_metadata(store)
    declaration = declaration_from(meta["declaration"], source=str(store))
    assert declaration.confirmatory  # recorded by `study run` in the checksummed metadata
    with sqlite3.connect(f"file:{store / 'results.sqlite'}?mode=ro", uri=True) as conn:
        first_row = conn.execute("SELECT MIN(written_unix) FROM results").fetchone()[0]
    assert pd.Timestamp(meta["created"]).timestamp() <= first_row  # the store, and so its declaration, came first
    rule, _ = read_rule(meta)
    km = kill_matrix(load_results(store), rule=rule, metric=judged_metric(meta))
    faults = [v for v in km.variants if v != "baseline"]
    table = declared_table(declaration, score=case_scores(km, faults), strategy=km.cases["strategy"].to_numpy(),
                           run=km.cases["run"].to_numpy())
    committed = pd.read_csv(CONFIRM / "declared.csv")
    for column in ("estimate", "estimate_low", "estimate_high", "p", "p_family"):
        np.testing.assert_allclose(table[column].to_numpy(float), committed[column].to_numpy(float), rtol=1e-8)
    assert table["decision"].tolist() == committed["decision"].tolist() == ["no difference shown",
                                                                           "not shown within ±5 pp"]
