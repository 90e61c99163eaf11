"""Writing a whole suite of test cases to a directory (used by ``python -m faultlab generate``)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from faultlab.errors import ConfigError
from faultlab.scenario.config import DEFAULT_MIN_DISTANCE, DEFAULT_N_STEPS, DEFAULT_SENSOR_RANGE
from faultlab.scenario.model import Scenario, save_scenario
from faultlab.scenario.suite import draw_suite, generate_case
from faultlab.space.case import PARAMETER_NAMES, VALUE_KEYS, CaseSpec
from faultlab.space.coverage import Coverage, coverage
from faultlab.space.parameters import ParameterSpace, table1_space
from faultlab.space.registry import get_strategy

__all__ = ["SuiteFiles", "write_suite", "cases_frame"]


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


def cases_frame(cases: list[CaseSpec]) -> pd.DataFrame:
    """One row per case (1-based ``case``): the 13 values and ``class_<parameter>``."""
    rows = []
    for i, c in enumerate(cases, start=1):
        row = {"case": i, **{k: c.values[k] for k in VALUE_KEYS}}
        row.update({f"class_{p}": int(c.classes.get(p, -1)) for p in PARAMETER_NAMES})
        rows.append(row)
    return pd.DataFrame(rows)


def write_suite(kind: str, *, seed: int, out: str | Path, run: int = 1, n_cases: int | None = None,
                space: ParameterSpace | None = None, n_steps: int = DEFAULT_N_STEPS,
                sensor_range: float = DEFAULT_SENSOR_RANGE,
                min_distance: float = DEFAULT_MIN_DISTANCE, fov_bug: bool = False) -> SuiteFiles:
    """Draw a suite, generate every case and save it to ``out``.

    The cases are those of suite ``kind`` in evaluation run ``run`` of a campaign with root seed
    ``seed`` (:func:`faultlab.scenario.suite.draw_suite`): byte-identical to the campaign's saved cases.

    Parameters
    ----------
    kind : {"systematic", "random", "fixed"}
    seed : int
        Root seed of the campaign.
    out : path
        Directory (created); receives ``case1.npz``/``case1.json``, ...,
        ``coverage.csv`` and ``cases.csv``.
    run : int
        Evaluation run (1-based).
    n_cases : int, optional
        Default: the builder's choice (5 for the systematic suite of Table I).
    space : ParameterSpace, optional
        Table I when None.
    n_steps, sensor_range, min_distance : int, float, float
        Generation settings (active steps, m, m), as in an experiment file.
    fov_bug : bool
        Reproduce the replication package's field-of-view defect, as an experiment's ``fov_bug``.

    Returns
    -------
    SuiteFiles
    """
    get_strategy(kind)  # ConfigError naming the known kinds
    if n_steps < 1:
        raise ConfigError(f"n_steps must be at least 1, got {n_steps}")
    if run < 1:
        raise ConfigError(f"run must be at least 1, got {run}")
    space = space or table1_space()
    drawn = draw_suite(kind, space, root_seed=seed, run=run, n_cases=n_cases)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    scenarios, paths = [], []
    for case in drawn:
        sc = generate_case(case, n_steps=n_steps, sensor_range=sensor_range, min_distance=min_distance,
                           fov_bug=fov_bug)
        scenarios.append(sc)
        paths.append(save_scenario(sc, out / f"case{case.case}"))
    cases = [c.spec for c in drawn]
    cov = coverage(cases, space)
    cov_csv = out / "coverage.csv"
    cov.table().to_csv(cov_csv, index=False)
    cases_csv = out / "cases.csv"
    cases_frame(cases).to_csv(cases_csv, index=False)
    return SuiteFiles(kind=kind, seed=int(seed), out=out, paths=tuple(paths), scenarios=tuple(scenarios),
                      coverage=cov, coverage_csv=cov_csv, cases_csv=cases_csv)
