"""Smaller versions of a test case that stay consistent: a prefix of the steps, a subset of the
landmarks, the idle steps cut out.

Each reduction keeps the case self-consistent: the true path, the controls and every remaining
observation are those of the original case (no step in the middle of a motion is removed: that
would leave later observations made from poses the controls no longer reach).
"""

from __future__ import annotations

from collections.abc import Collection
from dataclasses import replace

import numpy as np

from faultlab.errors import ScenarioError
from faultlab.scenario.model import Scenario

__all__ = ["truncate", "keep_landmarks", "drop_idle_steps", "idle_steps", "size"]


def size(scenario: Scenario) -> dict[str, int]:
    """``{"steps": T, "landmarks": L, "observations": M}`` of a case."""
    return {"steps": scenario.n_steps, "landmarks": int(scenario.landmarks.shape[0]),
            "observations": int(scenario.obs_range.shape[0])}


def _with(scenario: Scenario, reduction: dict, **arrays) -> Scenario:
    meta = {**scenario.meta, "reduced": [*scenario.meta.get("reduced", []), reduction]}
    out = replace(scenario, meta=meta, **arrays)
    out.validate()
    return out


def truncate(scenario: Scenario, n_steps: int) -> Scenario:
    """The first ``n_steps`` steps of ``scenario`` (1 <= n_steps <= T); landmarks are all kept."""
    if not 1 <= n_steps <= scenario.n_steps:
        raise ScenarioError(f"truncate: n_steps must lie in [1, {scenario.n_steps}], got {n_steps}")
    m = int(scenario.obs_offsets[n_steps])
    return _with(scenario, {"truncate": int(n_steps)}, controls=scenario.controls[:n_steps].copy(),
                 true_poses=scenario.true_poses[:n_steps + 1].copy(),
                 obs_offsets=scenario.obs_offsets[:n_steps + 1].copy(), obs_range=scenario.obs_range[:m].copy(),
                 obs_bearing=scenario.obs_bearing[:m].copy(), obs_ids=scenario.obs_ids[:m].copy())


def keep_landmarks(scenario: Scenario, ids: Collection[int]) -> Scenario:
    """``scenario`` with only the landmarks ``ids``: the others and every observation of them removed."""
    ids = np.asarray(sorted(int(i) for i in ids), dtype=np.int64)
    keep_lm = np.isin(scenario.landmark_ids, ids)
    keep_obs = np.isin(scenario.obs_ids, ids)
    step = np.repeat(np.arange(scenario.n_steps), np.diff(scenario.obs_offsets))
    counts = np.bincount(step[keep_obs], minlength=scenario.n_steps)
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    return _with(scenario, {"landmarks": int(keep_lm.sum())}, landmarks=scenario.landmarks[keep_lm].copy(),
                 landmark_ids=scenario.landmark_ids[keep_lm].copy(), obs_offsets=offsets,
                 obs_range=scenario.obs_range[keep_obs].copy(), obs_bearing=scenario.obs_bearing[keep_obs].copy(),
                 obs_ids=scenario.obs_ids[keep_obs].copy())


def idle_steps(scenario: Scenario) -> np.ndarray:
    """Indices of the idle steps: control exactly (0, 0), no observation and the true pose unchanged."""
    still = np.all(scenario.controls == 0.0, axis=1)
    quiet = np.diff(scenario.obs_offsets) == 0
    unmoved = np.all(scenario.true_poses[1:] == scenario.true_poses[:-1], axis=1)
    return np.flatnonzero(still & quiet & unmoved)


def drop_idle_steps(scenario: Scenario, steps: Collection[int] | None = None) -> Scenario:
    """``scenario`` without the idle steps ``steps`` (default: all of them; :func:`idle_steps`)."""
    idle = set(map(int, idle_steps(scenario)))
    drop = idle if steps is None else set(map(int, steps))
    if not drop <= idle:
        raise ScenarioError(f"drop_idle_steps: steps {sorted(drop - idle)[:5]} are not idle")
    keep = np.array([t for t in range(scenario.n_steps) if t not in drop], dtype=np.int64)
    if keep.size == 0:
        keep = np.array([0], dtype=np.int64)
    counts = np.diff(scenario.obs_offsets)[keep]
    offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
    obs = np.concatenate([np.arange(scenario.obs_offsets[t], scenario.obs_offsets[t + 1]) for t in keep]
                         ).astype(np.int64) if counts.sum() else np.empty(0, dtype=np.int64)
    return _with(scenario, {"idle_dropped": int(scenario.n_steps - keep.size)},
                 controls=scenario.controls[keep].copy(),
                 true_poses=np.concatenate([scenario.true_poses[:1], scenario.true_poses[keep + 1]]),
                 obs_offsets=offsets, obs_range=scenario.obs_range[obs].copy(),
                 obs_bearing=scenario.obs_bearing[obs].copy(), obs_ids=scenario.obs_ids[obs].copy())
