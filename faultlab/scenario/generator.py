"""Test-case generation (Sec. VI): a map, a true path and the noisy sensor trace from a :class:`CaseSpec`."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict

import numpy as np

from faultlab.errors import ScenarioError
from faultlab.scenario.config import (
    DEFAULT_MIN_DISTANCE,
    DEFAULT_N_STEPS,
    DEFAULT_SENSOR_RANGE,
    ScenarioConfig,
)
from faultlab.scenario.maps import generate_landmarks, n_symmetric_pairs
from faultlab.scenario.model import Scenario
from faultlab.scenario.trace import DEFAULT_PATH_TURN_STD, drive, measure_controls, measure_observations
from faultlab.space.case import FIXED_VALUES, CaseSpec

__all__ = ["generate_scenario", "fixed_case_scenario", "GENERATOR_VERSION"]

#: Bumped whenever the same seed would produce a different scenario.
GENERATOR_VERSION = 1


def generate_scenario(case: CaseSpec, *, rng: np.random.Generator, n_steps: int = DEFAULT_N_STEPS,
                      sensor_range: float = DEFAULT_SENSOR_RANGE, min_distance: float = DEFAULT_MIN_DISTANCE,
                      seed: int | None = None, path_turn_std: float = DEFAULT_PATH_TURN_STD,
                      fov_bug: bool = False) -> Scenario:
    """Generate the test case of ``case`` (Sec. VI-A..C).

    Draw order from ``rng`` (fixed, so the same seed gives the same case):
    map, path perturbation and targets, control noise, observation noise and
    outliers.

    Parameters
    ----------
    case : CaseSpec
        Parameter values in Table I units.
    rng : numpy.random.Generator
        The only source of randomness.
    n_steps : int
        Active steps (the inactivity steps come on top).
    sensor_range : float
        m.
    min_distance : float
        Minimum landmark distance, m.
    seed : int, optional
        Recorded in :attr:`Scenario.seed` (the entropy ``rng`` was created from).
    path_turn_std : float
        Std of the perturbation of the true turns, rad (see :mod:`faultlab.scenario.trace`).
    fov_bug : bool
        Reproduce the replication package's field-of-view *defect* (every right-side bearing is
        visible whatever the opening; see :mod:`faultlab.scenario.trace`).  False by default;
        recorded in ``meta["config"]["fov_bug"]``.

    Returns
    -------
    Scenario
        ``meta`` holds the SI config, the generator settings and summary counts.

    Raises
    ------
    ScenarioError
        If the map cannot be built (too dense for ``min_distance``) or has no landmarks.
    """
    if not isinstance(rng, np.random.Generator):
        raise TypeError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    if not isinstance(fov_bug, (bool, np.bool_)):
        raise ScenarioError(f"generate_scenario: fov_bug must be True or False, got {fov_bug!r}")
    cfg = ScenarioConfig.from_case(case, n_steps=n_steps, sensor_range=sensor_range, min_distance=min_distance,
                                   fov_bug=bool(fov_bug))
    landmarks, ids = generate_landmarks(side=cfg.map_side, n_landmarks=cfg.n_landmarks, symmetry=cfg.symmetry,
                                        min_distance=cfg.min_distance, rng=rng)
    drv = drive(landmarks, ids, rng=rng, n_steps=cfg.n_steps, step=cfg.step, fov=cfg.fov,
                sensor_range=cfg.sensor_range, loop=cfg.loop, inactivity=cfg.inactivity,
                path_turn_std=path_turn_std, fov_bug=cfg.fov_bug)
    noise = dict(std_distance=cfg.std_distance, std_angle=cfg.std_angle, bias_distance=cfg.bias_distance,
                 bias_angle=cfg.bias_angle, rotation_error=cfg.rotation_error)
    controls = measure_controls(drv.controls, drv.active, rng=rng, **noise)
    obs = measure_observations(landmarks, ids, drv, rng=rng, outlier_probability=cfg.outlier_probability,
                               sensor_range=cfg.sensor_range, **noise)
    meta = {
        "generator_version": GENERATOR_VERSION,
        "config": asdict(cfg),
        "path_turn_std": float(path_turn_std),
        "n_landmarks": int(landmarks.shape[0]),
        "n_symmetric_pairs": n_symmetric_pairs(cfg.n_landmarks, cfg.symmetry),
        "inactivity_start": int(drv.inactivity_start),
        "n_observations": int(obs.range.shape[0]),
        "n_outliers": int(obs.outlier.sum()),
        "n_targets": int(drv.targets.shape[0]),
        "n_rounds": int(drv.target_rounds[-1] + 1) if drv.target_rounds.size else 0,
    }
    sc = Scenario(case=case, seed=None if seed is None else int(seed), landmarks=landmarks, landmark_ids=ids,
                  true_poses=drv.poses, controls=controls, obs_offsets=drv.vis_offsets, obs_range=obs.range,
                  obs_bearing=obs.bearing, obs_ids=obs.ids, meta=meta)
    sc.validate()
    return sc


def fixed_case_scenario(overrides: Mapping[str, float | str], *, seed: int, n_steps: int) -> Scenario:
    """A small scenario for checks: the fixed suite's values with ``overrides``, from one seed.

    The case is :data:`faultlab.space.case.FIXED_VALUES` updated by ``overrides`` (e.g. a small
    map); the generator is ``default_rng(SeedSequence(seed))`` and ``seed`` is recorded.

    Parameters
    ----------
    overrides : mapping
        Parameter values (Table I units) that replace the fixed suite's.
    seed : int
        Entropy of the scenario's SeedSequence.
    n_steps : int
        Active steps (the inactivity steps come on top).

    Returns
    -------
    Scenario
    """
    case = CaseSpec(values={**FIXED_VALUES, **overrides})
    rng = np.random.default_rng(np.random.SeedSequence(seed))
    return generate_scenario(case, rng=rng, n_steps=n_steps, seed=seed)
