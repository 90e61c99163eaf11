"""Small synthetic results frames in the runner's schema, for the stats tests."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from faultlab.space.case import FIXED_VALUES, PARAMETER_NAMES, VALUE_KEYS

SCHEMA_COLUMNS = (["run", "suite", "case", "variant", "rep"] + list(VALUE_KEYS)
                  + [f"class_{p}" for p in PARAMETER_NAMES]
                  + ["n_landmarks", "rms_mm", "emd_mm", "n_mapped", "n_unmapped", "runtime_s", "status", "error"])


def job(run, suite, case, variant, rep, rms_mm, status="ok", **values) -> dict:
    """One results row; scenario values default to the fixed suite's, overridable by keyword."""
    row = {"run": run, "suite": suite, "case": case, "variant": variant, "rep": rep}
    row.update(FIXED_VALUES)
    row.update(values)
    row.update({f"class_{p}": 0 for p in PARAMETER_NAMES})
    ok = status == "ok"
    row.update(n_landmarks=320, rms_mm=float(rms_mm) if ok else math.nan,
               emd_mm=float(rms_mm) / 2 if ok else math.nan, n_mapped=320 if ok else 0, n_unmapped=0,
               runtime_s=1.0, status=status, error="" if ok else f"synthetic {status}")
    return row


def frame(rows) -> pd.DataFrame:
    """DataFrame with exactly the schema's columns from :func:`job` dicts."""
    return pd.DataFrame(list(rows), columns=SCHEMA_COLUMNS)


def paired(cells, *, suite="systematic", run=1, fault="naive_resampling", **values) -> pd.DataFrame:
    """One (baseline, faulty) pair per ``(faulty_mm, baseline_mm)`` in ``cells``; case i + 1, rep 0."""
    rows = []
    for i, (f, b) in enumerate(cells):
        rows.append(job(run, suite, i + 1, "baseline", 0, b, **values))
        rows.append(job(run, suite, i + 1, fault, 0, f, **values))
    return frame(rows)


def paired_frame(diffs: dict, k: int, *, status: dict | None = None, case: int = 1) -> pd.DataFrame:
    """One case, K repetitions: a baseline and each variant ``v`` at the baseline plus ``diffs[v]`` (mm),
    paired by repetition; ``status[v]`` other than "ok" makes every repetition of ``v`` fail."""
    rng = np.random.default_rng(0)
    base = 100 + rng.random(k) * 10
    rows = [dict(run=1, suite="fixed", case=case, variant="baseline", rep=r, status="ok", rms_mm=base[r],
                 emd_mm=base[r]) for r in range(k)]
    for v, d in diffs.items():
        for r in range(k):
            st = (status or {}).get(v, "ok")
            rows.append(dict(run=1, suite="fixed", case=case, variant=v, rep=r, status=st,
                             rms_mm=base[r] + d[r] if st == "ok" else math.nan, emd_mm=math.nan))
    return pd.DataFrame(rows)
