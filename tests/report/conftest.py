"""Synthetic results that follow the results schema exactly, for the report tests.

The report layer only reads saved results, so its tests need no SLAM: these builders
make a results DataFrame (one row per job) and a metadata dict like the runner writes.
"""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd
import pytest

from faultlab.space.case import FIXED_VALUES, PARAMETER_NAMES, VALUE_KEYS

SUITES = ("systematic", "random", "fixed")
PAPER_FAULTS = ("naive_resampling", "missing_angle_wrap", "motion_sign_error")
VARIANTS = ("baseline",) + PAPER_FAULTS
REPO = Path(__file__).resolve().parents[2]
PAPER_DIR = REPO / "paper_repro"

SCHEMA_COLUMNS = (
    ["run", "suite", "case", "variant", "rep"]
    + list(VALUE_KEYS)
    + [f"class_{p}" for p in PARAMETER_NAMES]
    + ["n_landmarks", "rms_mm", "emd_mm", "n_mapped", "n_unmapped", "runtime_s", "status", "error"]
)


def make_row(run: int, suite: str, case: int, variant: str, rep: int, rms_mm: float,
             status: str = "ok") -> dict:
    """One job row of the results schema; ``rms_mm`` is ignored unless ``status == 'ok'``."""
    row: dict = {"run": run, "suite": suite, "case": case, "variant": variant, "rep": rep}
    row.update(FIXED_VALUES)
    # vary one value per case so rows of different cases differ, as in a real suite
    row["map_size"] = 16.0 * case
    for p in PARAMETER_NAMES:
        row[f"class_{p}"] = 0
    ok = status == "ok"
    row.update(
        n_landmarks=80,
        rms_mm=float(rms_mm) if ok else math.nan,
        emd_mm=float(rms_mm) * 0.9 if ok else math.nan,
        n_mapped=80 if ok else 0,
        n_unmapped=0 if ok else 80,
        runtime_s=1.5,
        status=status,
        error="" if ok else f"{status} in synthetic job",
    )
    return row


def make_results(rms, *, runs: int = 1, suites=SUITES, cases: int = 2, variants=VARIANTS,
                 reps: int = 1, status=None) -> pd.DataFrame:
    """Results frame for every (run, suite, case, variant, rep).

    Parameters
    ----------
    rms : callable or dict
        ``rms(run, suite, case, variant, rep) -> float`` or a dict keyed by that tuple
        (missing keys fall back to 50 mm).
    status : dict, optional
        ``(run, suite, case, variant, rep) -> "crash" | "timeout"`` for failed jobs.
    """
    status = status or {}
    rows = []
    for run in range(1, runs + 1):
        for suite in suites:
            for case in range(1, cases + 1):
                for variant in variants:
                    for rep in range(reps):
                        key = (run, suite, case, variant, rep)
                        value = rms(*key) if callable(rms) else rms.get(key, 50.0)
                        rows.append(make_row(*key, value, status.get(key, "ok")))
    frame = pd.DataFrame(rows, columns=SCHEMA_COLUMNS)
    return frame.astype({"run": "int64", "case": "int64", "rep": "int64", "n_landmarks": "int64",
                         "n_mapped": "int64", "n_unmapped": "int64"})


def paper_results() -> pd.DataFrame:
    """The paper's raw Table II data (paper_repro/) in the results schema (rep 0, all ok)."""
    raw = pd.read_csv(PAPER_DIR / "paper_table2_rms.csv")
    rms = {(int(r.run), r.suite, int(r.case), r.variant, 0): float(r.rms_mm)
           for r in raw.itertuples()}
    return make_results(rms, runs=3, cases=5)


def fake_metadata() -> dict:
    return {
        "package_version": "0.1.0",
        "experiment_hash": "0123456789abcdef" * 4,
        "experiment_name": "synthetic",
        "root_seed": 20240611,
        "runs": 1,
        "wall_time_s": 12.5,
        "started": "2025-01-01T00:00:00",
    }


#: A campaign small enough for tests (a few seconds): two suites, two faults, K = 2 repetitions
#: (so the false-alarm and oracle pages have data), 30 steps, 10 particles.
TINY_EXPERIMENT = """\
description = "tiny campaign for the report tests"
seed = 11
runs = 1
n_steps = 30
variants = ["baseline", "naive_resampling", "missing_angle_wrap"]
repetitions = 2
timeout_s = 120.0

[suites]
fixed = 2
random = 1

[slam]
name = "fastslam"
particles = 10
"""


def write_tiny_experiment(directory: Path) -> Path:
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / "tiny.toml"
    path.write_text(TINY_EXPERIMENT, encoding="utf-8")
    return path


@pytest.fixture(scope="session")
def tiny_store(tmp_path_factory) -> Path:
    """A real results store of :data:`TINY_EXPERIMENT`, run once per test session."""
    from faultlab.runner import run_experiment

    base = tmp_path_factory.mktemp("tiny")
    out = base / "results"
    summary = run_experiment(write_tiny_experiment(base), out, jobs=1, progress=False)
    assert summary.complete and summary.n_jobs == 3 * 3 * 2
    return out


@pytest.fixture
def synthetic_results() -> pd.DataFrame:
    """Hand-made figures: every fault detected in known cells only.

    Baseline 50 mm everywhere.  Detected cells (by the paper's rule, > 250 mm and >= 25 %):
    missing_angle_wrap in every case, motion_sign_error in systematic/random case 1,
    naive_resampling nowhere (its 280 mm in random case 2 is +230 mm only).
    """
    def rms(run, suite, case, variant, rep):
        if variant == "missing_angle_wrap":
            return 1234.4
        if variant == "motion_sign_error":
            return 3000.5 if (case == 1 and suite != "fixed") else 60.0
        if variant == "naive_resampling":
            return 280.0 if (suite == "random" and case == 2) else 55.0
        return 50.0

    return make_results(rms)


@pytest.fixture
def metadata() -> dict:
    return fake_metadata()
