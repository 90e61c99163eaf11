"""Map errors of one SLAM run against its test case, in mm for result tables."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Collection

import numpy as np

from faultlab.errors import ConfigError
from faultlab.metrics.alignment import kabsch_rms
from faultlab.metrics.transport import earth_movers_distance
from faultlab.vocabulary import ASSOCIATIONS, METRICS, UNKNOWN_ASSOCIATION

__all__ = ["MapErrors", "map_errors"]

_MM_PER_M = 1000.0


@dataclass(frozen=True)
class MapErrors:
    """Map errors of one SLAM execution, as stored in the results table.

    Attributes
    ----------
    rms_mm : float
        Kabsch-aligned RMS landmark error, mm (NaN if nothing was mapped).
    emd_mm : float
        Earth mover's distance between the full ground-truth map and the
        estimated map, mm (see :func:`map_errors` for the alignment used).
    n_mapped, n_unmapped : int
        Ground-truth landmarks the SLAM did / did not map.  For a map without ids (unknown data
        association) ``n_mapped`` is the number of estimated landmarks and ``n_unmapped`` the
        number of ground-truth landmarks beyond it (0 if the SLAM mapped more).
    """

    rms_mm: float
    emd_mm: float
    n_mapped: int
    n_unmapped: int


def map_errors(scenario, estimate, *, emd_alignment: str = "kabsch", metrics: Collection[str] = METRICS,
               association: str = "known") -> MapErrors:
    """RMS (Kabsch) and EMD map errors of ``estimate`` against ``scenario``'s map.

    Parameters
    ----------
    scenario : faultlab.scenario.Scenario
        Provides ``landmark_ids`` (L,) and ``landmarks`` (L, 2), m.
    estimate : faultlab.slam.Estimate
        The SLAM's final estimate (validated here).
    emd_alignment : {"kabsch", "none"}
        ``"kabsch"`` (default): the EMD compares the ground truth with the
        estimate moved by the same rigid alignment the RMS uses, so both
        metrics ignore a global rotation/translation of the SLAM's frame
        (Sec. VII-B, Fig. 4).  ``"none"``: the raw estimate, as an algorithm
        without landmark ids would be scored.  In both cases the EMD uses
        *all* ground-truth landmarks (unmapped ones cost transport) and, when
        nothing was mapped, is NaN.
    metrics : collection of {"rms", "emd", "ate"}
        The map metrics to compute (default both; ``"ate"``, the trajectory error, is accepted and
        ignored here: :func:`faultlab.metrics.trajectory_error_mm`); one left out is NaN and costs nothing.  The EMD is
        exact optimal transport and costs seconds for maps of several thousand landmarks (see
        :func:`earth_movers_distance`).  The landmark counts and the rigid alignment the EMD uses
        are computed whatever this says, so every value computed is the one computed with both.
    association : {"known", "unknown"}
        ``"unknown"``: the estimate comes from a SLAM that saw no landmark ids
        (:mod:`faultlab.slam.protocol`, "Data association"), so its labels correspond to nothing
        in the ground truth: ``rms_mm`` is NaN and the EMD compares the raw estimate (no alignment,
        whatever ``emd_alignment`` says) with the ground truth.

    Returns
    -------
    MapErrors
        In mm.

    Raises
    ------
    SlamOutputError
        Malformed or non-finite estimate, or an estimated id unknown to the map.
    """
    if hasattr(scenario, "require_truth"):
        scenario.require_truth("the map error (RMS, EMD)")
    if emd_alignment not in ("kabsch", "none"):
        raise ConfigError(f"map_errors: emd_alignment must be 'kabsch' or 'none', got {emd_alignment!r}")
    if association not in ASSOCIATIONS:
        raise ConfigError(f"map_errors: association must be one of {', '.join(map(repr, ASSOCIATIONS))}, "
                          f"got {association!r}")
    unknown = sorted(set(metrics) - set(METRICS))
    if unknown or not metrics or isinstance(metrics, str):
        raise ConfigError(f"map_errors: metrics must be a non-empty collection of "
                          f"{', '.join(map(repr, METRICS))}, got {metrics!r}")
    emd = "emd" in metrics
    estimate.validate(where="map_errors: estimate")
    if association == UNKNOWN_ASSOCIATION:
        est_xy = np.asarray(estimate.landmarks, dtype=float).reshape(-1, 2)
        emd_m = earth_movers_distance(scenario.landmarks, est_xy) if emd else float("nan")
        n_truth = int(np.asarray(scenario.landmarks).shape[0])
        return MapErrors(rms_mm=float("nan"), emd_mm=emd_m * _MM_PER_M, n_mapped=int(est_xy.shape[0]),
                         n_unmapped=max(n_truth - int(est_xy.shape[0]), 0))
    err = kabsch_rms(scenario.landmark_ids, scenario.landmarks, estimate.landmark_ids, estimate.landmarks)
    emd_m = float("nan")
    if emd:
        est_xy = np.asarray(estimate.landmarks, dtype=float).reshape(-1, 2)
        if emd_alignment == "kabsch":
            est_xy = err.apply(est_xy)
        emd_m = earth_movers_distance(scenario.landmarks, est_xy)
    return MapErrors(rms_mm=err.rms * _MM_PER_M if "rms" in metrics else float("nan"), emd_mm=emd_m * _MM_PER_M,
                     n_mapped=err.n_mapped, n_unmapped=err.n_unmapped)
