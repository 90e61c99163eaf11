"""One case pipeline: how the test cases of a suite are drawn and generated, wherever that happens.

A campaign (``faultlab run``) and ``faultlab generate`` both go through :func:`draw_suite` and
:func:`generate_case` with the seed scheme of :mod:`faultlab.seeds`, so ``generate --seed S
--suite K --run R`` writes exactly the cases that run ``R`` of a campaign with ``seed = S`` tests
for suite ``K`` (same parameter values, same seeds, byte-identical files).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from faultlab.scenario.config import DEFAULT_MIN_DISTANCE, DEFAULT_N_STEPS, DEFAULT_SENSOR_RANGE
from faultlab.scenario.generator import generate_scenario
from faultlab.scenario.model import Scenario
from faultlab.seeds import case_seed, suite_seed_sequence
from faultlab.space.case import CaseSpec
from faultlab.space.parameters import ParameterSpace
from faultlab.space.registry import build_suite

__all__ = ["SuiteCase", "draw_suite", "generate_case"]


@dataclass(frozen=True)
class SuiteCase:
    """One drawn test case: its identity, parameter values and generation seed.

    Attributes
    ----------
    run : int
        Evaluation run (1-based).
    suite : str
        Suite kind.
    case : int
        Case number within the suite (1-based).
    spec : CaseSpec
    seed : int
        The seed the scenario is generated from (:func:`faultlab.seeds.case_seed`).
    """

    run: int
    suite: str
    case: int
    spec: CaseSpec
    seed: int


def draw_suite(kind: str, space: ParameterSpace, *, root_seed: int, run: int = 1,
               n_cases: int | None = None) -> tuple[SuiteCase, ...]:
    """The cases of suite ``kind`` in evaluation run ``run`` of a campaign with ``root_seed``.

    Parameters
    ----------
    kind : str
        A suite kind (:func:`faultlab.space.registry.suite_kinds`).
    space : ParameterSpace
    root_seed : int
        The campaign's root seed.
    run : int
        Evaluation run (1-based); each run draws a new suite.
    n_cases : int, optional
        Suite size (default: the builder's choice).
    """
    rng = np.random.default_rng(suite_seed_sequence(root_seed, run, kind))
    specs = build_suite(kind, space, rng=rng, n_cases=n_cases)
    return tuple(SuiteCase(run=int(run), suite=kind, case=c, spec=spec,
                           seed=case_seed(root_seed, run, kind, c)) for c, spec in enumerate(specs, start=1))


def generate_case(case: SuiteCase, *, n_steps: int = DEFAULT_N_STEPS, sensor_range: float = DEFAULT_SENSOR_RANGE,
                  min_distance: float = DEFAULT_MIN_DISTANCE, fov_bug: bool = False) -> Scenario:
    """Generate the scenario of a drawn case from its own seed (Sec. VI).

    ``fov_bug`` reproduces the replication package's field-of-view defect (see
    :func:`faultlab.scenario.generator.generate_scenario`); it is recorded in the scenario's
    ``meta["config"]["fov_bug"]``.
    """
    return generate_scenario(case.spec, rng=np.random.default_rng(case.seed), n_steps=n_steps,
                             sensor_range=sensor_range, min_distance=min_distance, seed=case.seed,
                             fov_bug=fov_bug)
