"""Writing a whole suite of test cases to a directory (used by ``python -m faultlab generate``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from faultlab.errors import ConfigError
from faultlab.scenario.config import DEFAULT_N_STEPS
from faultlab.scenario.generator import generate_scenario
from faultlab.scenario.model import Scenario, save_scenario
from faultlab.space.case import PARAMETER_NAMES, VALUE_KEYS, CaseSpec
from faultlab.space.coverage import Coverage, coverage
from faultlab.space.parameters import ParameterSpace, table1_space
from faultlab.space.suites import SUITE_KINDS, build_suite

__all__ = ["SuiteFiles", "write_suite", "suite_seeds", "cases_frame"]


@dataclass(frozen=True, eq=False)
class SuiteFiles:
    """What :func:`write_suite` wrote.

    Attributes
    ----------
    kind : str
    seed : int
    out : Path
    paths : tuple of Path
        ``out/case<i>.npz`` (each with a ``.json`` sibling), 1-based.
    scenarios : tuple of Scenario
    coverage : Coverage
    coverage_csv : Path
        ``out/coverage.csv`` (:meth:`Coverage.table`).
    cases_csv : Path
        ``out/cases.csv``: one row per case with the 13 values and ``class_<parameter>``.
    """

    kind: str
    seed: int
    out: Path
    paths: tuple[Path, ...]
    scenarios: tuple[Scenario, ...]
    coverage: Coverage
    coverage_csv: Path
    cases_csv: Path


def suite_seeds(seed: int, n_cases: int) -> tuple[np.random.SeedSequence, list[int]]:
    """The suite's SeedSequence and one integer seed per case, all derived from ``seed``.

    ``SeedSequence(seed).spawn(2)`` gives the suite draw's sequence and the
    parent of the cases; case ``i`` uses ``default_rng(case_seeds[i])`` (a
    63-bit int drawn from the parent's i-th child), so a saved case can be
    regenerated from its recorded :attr:`Scenario.seed`.
    """
    suite_ss, cases_ss = np.random.SeedSequence(int(seed)).spawn(2)
    # 63-bit ints: fit an int64 column as well as JSON
    case_seeds = [int(ss.generate_state(1, dtype=np.uint64)[0] >> np.uint64(1)) for ss in cases_ss.spawn(n_cases)]
    return suite_ss, case_seeds


def cases_frame(cases: list[CaseSpec]) -> pd.DataFrame:
    """One row per case (1-based ``case``): the 13 values and ``class_<parameter>``."""
    rows = []
    for i, c in enumerate(cases, start=1):
        row = {"case": i, **{k: c.values[k] for k in VALUE_KEYS}}
        row.update({f"class_{p}": int(c.classes.get(p, -1)) for p in PARAMETER_NAMES})
        rows.append(row)
    return pd.DataFrame(rows)


def write_suite(kind: str, *, seed: int, out: str | Path, n_cases: int | None = None,
                space: ParameterSpace | None = None, n_steps: int = DEFAULT_N_STEPS) -> SuiteFiles:
    """Draw a suite, generate every case and save it to ``out``.

    Parameters
    ----------
    kind : {"systematic", "random", "fixed"}
    seed : int
        Root seed; the suite and each case use child seeds (:func:`suite_seeds`).
    out : path
        Directory (created); receives ``case1.npz``/``case1.json``, ...,
        ``coverage.csv`` and ``cases.csv``.
    n_cases : int, optional
        Default: the space's minimal systematic suite size (5 with Table I).
    space : ParameterSpace, optional
        Table I when None.
    n_steps : int
        Active steps per case.

    Returns
    -------
    SuiteFiles
    """
    if kind not in SUITE_KINDS:
        raise ConfigError(f"unknown suite kind {kind!r} (expected one of {', '.join(SUITE_KINDS)})")
    if n_steps < 1:
        raise ConfigError(f"n_steps must be at least 1, got {n_steps}")
    space = space or table1_space()
    suite_ss, _ = suite_seeds(seed, 0)
    cases = build_suite(kind, space, rng=np.random.default_rng(suite_ss), n_cases=n_cases)
    _, case_seeds = suite_seeds(seed, len(cases))
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    scenarios, paths = [], []
    for i, (case, cs) in enumerate(zip(cases, case_seeds), start=1):
        sc = generate_scenario(case, rng=np.random.default_rng(cs), n_steps=n_steps, seed=cs)
        scenarios.append(sc)
        paths.append(save_scenario(sc, out / f"case{i}"))
    cov = coverage(cases, space)
    cov_csv = out / "coverage.csv"
    cov.table().to_csv(cov_csv, index=False)
    cases_csv = out / "cases.csv"
    cases_frame(cases).to_csv(cases_csv, index=False)
    return SuiteFiles(kind=kind, seed=int(seed), out=out, paths=tuple(paths), scenarios=tuple(scenarios),
                      coverage=cov, coverage_csv=cov_csv, cases_csv=cases_csv)
