"""Real data sets in the iSAM text format as scenarios without ground truth (Victoria Park from GTSAM's wheel).

The format (Kaess et al.'s iSAM; GTSAM reads it in ``gtsam/slam/dataset.cpp``) is one record a line:

``ODOMETRY i j dx dy dtheta  sxx sxy sxt syy syt stt``
    the pose ``j`` relative to pose ``i`` (m, rad, in the frame of pose ``i``) and its covariance;
``LANDMARK i l x y  sxx sxy syy``
    landmark ``l`` seen from pose ``i`` at ``(x, y)`` in the robot frame (m) with its covariance.

:func:`read_isam` turns such a file into a :class:`~faultlab.scenario.model.Scenario` whose truth is
absent (``meta["ground_truth"] = False``: NaN landmark positions, NaN poses after the start): the
odometry chain gives the steps, the landmark records seen from the pose after step ``t`` are step
``t``'s observations.  Conventions mapped onto faultlab's:

* motion: faultlab's control ``(v, omega)`` drives ``v`` along the heading, then turns ``omega``; it
  has no sideways motion, so ``v = dx``, ``omega = dtheta`` and ``dy`` is dropped.  How much that
  drops is recorded in ``meta["isam"]["dropped_dy_m"]`` (the sum of ``|dy|``) next to the distance
  driven (``driven_m``).
* observations: range ``hypot(x, y)`` and bearing ``atan2(y, x)`` relative to the heading.
* noise: the odometry's standard deviations (``sqrt(sxx)``, ``sqrt(stt)``; the file's first record)
  and the landmark noise GTSAM's reader assumes for this format (the x-y variance ``sxx`` describes
  the uncertainty at a range of 10 m: ``std_range = sqrt(sxx)``, ``std_bearing = sqrt(sxx / 10)``) are
  recorded in ``meta["noise"]`` under faultlab's names (:class:`~faultlab.slam.noise.NoiseConfig`),
  for configuring the SLAMs run on it.
* the start pose is pose ``i`` of the first record, at (0, 0, 0).
* the scenario's ``case`` is faultlab's fixed parameter values, a placeholder: a real data set was
  not generated from Table I's parameters.

:func:`victoria_park_file` finds Victoria Park in the installed ``gtsam`` wheel (its example data,
``gtsam/Data/victoria_park.txt``) without importing gtsam; nothing is downloaded.
"""

from __future__ import annotations

import importlib.util
import math
from pathlib import Path

import numpy as np

from faultlab.errors import ScenarioError
from faultlab.scenario.model import Scenario
from faultlab.space.case import FIXED_VALUES, CaseSpec

__all__ = ["read_isam", "victoria_park_file", "victoria_park"]


def victoria_park_file() -> Path:
    """Path of ``victoria_park.txt`` in the installed gtsam wheel; ScenarioError if gtsam or the file is absent."""
    spec = importlib.util.find_spec("gtsam")
    if spec is None or not spec.submodule_search_locations:
        raise ScenarioError("Victoria Park is read from the gtsam wheel's example data, and gtsam is not installed "
                            "(pip install \"faultlab[gtsam]\")")
    for root in spec.submodule_search_locations:
        path = Path(root) / "Data" / "victoria_park.txt"
        if path.is_file():
            return path
    raise ScenarioError(f"the installed gtsam ({', '.join(spec.submodule_search_locations)}) ships no "
                        f"Data/victoria_park.txt")


def _records(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """(odometry rows (n, 11), landmark rows (m, 7)) of an iSAM file, in file order."""
    odo, lms = [], []
    try:
        lines = path.read_text().splitlines()
    except OSError as exc:
        raise ScenarioError(f"{path}: cannot be read ({exc.strerror or exc})") from exc
    for n, line in enumerate(lines, 1):
        parts = line.split()
        if not parts:
            continue
        try:
            if parts[0] == "ODOMETRY" and len(parts) == 12:
                odo.append([float(x) for x in parts[1:]])
            elif parts[0] == "LANDMARK" and len(parts) == 8:
                lms.append([float(x) for x in parts[1:]])
            else:
                raise ValueError(f"expected ODOMETRY with 11 numbers or LANDMARK with 7, got {parts[0]!r} "
                                 f"with {len(parts) - 1}")
        except ValueError as exc:
            raise ScenarioError(f"{path}, line {n}: {exc}") from None
    if not odo:
        raise ScenarioError(f"{path}: no ODOMETRY record")
    return np.array(odo), np.array(lms).reshape(-1, 7)


def read_isam(path, *, name: str | None = None) -> Scenario:
    """The scenario (without ground truth) of an iSAM 2-D file of odometry and landmark sightings.

    Raises
    ------
    ScenarioError
        The file cannot be read, a line is not a record, the odometry is not one chain (record ``k``
        starts at the pose where record ``k - 1`` ended), or a landmark is seen from a pose off the
        chain or twice from one pose.
    """
    path = Path(path)
    name = name or path.stem
    odo, lms = _records(path)
    chain = np.r_[odo[0, 0], odo[:, 1]].astype(np.int64)
    if np.any(odo[1:, 0] != odo[:-1, 1]):
        k = int(np.flatnonzero(odo[1:, 0] != odo[:-1, 1])[0]) + 1
        raise ScenarioError(f"{path}: ODOMETRY record {k + 1} starts at pose {int(odo[k, 0])}, not where the "
                            f"previous one ended ({int(odo[k - 1, 1])}): the odometry is not one chain")
    if np.unique(chain).size != chain.size:
        raise ScenarioError(f"{path}: the odometry chain visits a pose twice")
    order = np.argsort(chain)
    pose_ids = lms[:, 0].astype(np.int64)
    at = np.minimum(np.searchsorted(chain[order], pose_ids), chain.size - 1)
    step_of = order[at] - 1  # observed after the step that ends at that pose
    off_chain = chain[order][at] != pose_ids
    if off_chain.any() or np.any(step_of < 0):
        bad = int(pose_ids[off_chain | (step_of < 0)][0])
        raise ScenarioError(f"{path}: a landmark is seen from pose {bad}, which is not reached by a step of the "
                            f"odometry chain")
    ids = lms[:, 1].astype(np.int64)
    by = np.lexsort((ids, step_of))
    step_of, ids, xy = step_of[by], ids[by], lms[by, 2:4]
    if np.any((step_of[1:] == step_of[:-1]) & (ids[1:] == ids[:-1])):
        raise ScenarioError(f"{path}: a landmark is seen twice from one pose")
    T = odo.shape[0]
    offsets = np.r_[0, np.cumsum(np.bincount(step_of, minlength=T))].astype(np.int64)
    landmark_ids = np.unique(ids)
    true_poses = np.full((T + 1, 3), np.nan)
    true_poses[0] = 0.0
    sxx = float(lms[0, 4]) if lms.shape[0] else float("nan")
    meta = {
        "ground_truth": False, "dataset": name, "source": str(path),
        "isam": {"dropped_dy_m": float(np.abs(odo[:, 3]).sum()), "driven_m": float(np.abs(odo[:, 2]).sum()),
                 "max_abs_dy_m": float(np.abs(odo[:, 3]).max()), "first_pose_id": int(chain[0])},
        "noise": {"std_v": math.sqrt(odo[0, 5]), "std_omega_deg": math.degrees(math.sqrt(odo[0, 10])),
                  "std_range": math.sqrt(sxx), "std_bearing_deg": math.degrees(math.sqrt(sxx / 10.0))},
    }
    scenario = Scenario(case=CaseSpec(dict(FIXED_VALUES)), seed=None,
                        landmarks=np.full((landmark_ids.size, 2), np.nan), landmark_ids=landmark_ids,
                        true_poses=true_poses, controls=np.ascontiguousarray(odo[:, [2, 4]]), obs_offsets=offsets,
                        obs_range=np.hypot(xy[:, 0], xy[:, 1]), obs_bearing=np.arctan2(xy[:, 1], xy[:, 0]),
                        obs_ids=ids, meta=meta)
    scenario.validate()
    return scenario


def victoria_park() -> Scenario:
    """Victoria Park (Sydney; Guivant and Nebot's laser-detected trees and odometry) from the gtsam wheel."""
    return read_isam(victoria_park_file(), name="victoria_park")
