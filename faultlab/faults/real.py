"""The ``real`` category: faults that reproduce bugs found in public SLAM code, each with its provenance.

Mutants and invented faults stand for real faults only if tests that find the former also find the
latter (Just et al., "Are mutants a valid substitute for real faults in software testing?", FSE 2014).
This module names the faults whose failure mode was *found* in published SLAM code, and says where:
the project, the file, what was wrong, how it was found, and how faultlab knows it (read in a copy of
the code, recorded from an issue thread, or recalled from the public file and not re-read here --
the last kind is a weaker claim and is marked so).

Most entries point at a fault faultlab already has under its own name (:mod:`faultlab.faults.builtin`);
:data:`MEASUREMENT_NOISE_FROM_STATE_COVARIANCE` is defined here.  One entry is not a unit fault: the
paper's field-of-view defect lives in the paper's *simulator*, not in its filter, and faultlab
reproduces it as the scenario option ``fov_bug = True`` (:attr:`RealFault.fault` is None for it).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from faultlab.faults.builtin import BUILTIN_FAULTS
from faultlab.faults.fault import Fault, UnitExample
from faultlab.slam.noise import NoiseConfig

__all__ = ["Provenance", "RealFault", "REAL_FAULTS", "MEASUREMENT_NOISE_FROM_STATE_COVARIANCE", "real_faults"]


@dataclass(frozen=True)
class Provenance:
    """Where a real bug was found.

    Attributes
    ----------
    project : str
        The public project (and version or commit where known).
    file : str
        The file and function.
    what : str
        What was wrong, in one or two sentences.
    found : str
        How the bug was found (by whom, by what).
    known : str
        How faultlab knows it: ``"read"`` (the code was read in a copy of the project),
        ``"reported"`` (a public issue thread), ``"recalled"`` (from the public file, not re-read
        when this entry was written: verify before citing).
    """

    project: str
    file: str
    what: str
    found: str
    known: str

    def __post_init__(self) -> None:
        if self.known not in ("read", "reported", "recalled"):
            raise ValueError(f"provenance.known must be 'read', 'reported' or 'recalled', got {self.known!r}")


@dataclass(frozen=True)
class RealFault:
    """A real bug: the fault (or scenario option) that reproduces it in faultlab, and its provenance."""

    name: str
    fault: Fault | None
    reproduced_by: str
    provenance: Provenance


def _state_block_as_measurement_noise(original):
    """S = H P H^T + Q' with Q' the pose-noise block: the filter's motion noise where the sensor's belongs."""
    M = NoiseConfig().M

    def innovation_covariance(H, P, Q):
        return original(H, P, M)

    return innovation_covariance


def _ex_innovation():
    H = np.tile(np.array([[0.8, 0.6], [-0.12, 0.16]]), (2, 1, 1, 1))
    P = np.tile(np.array([[0.04, 0.01], [0.01, 0.09]]), (2, 1, 1, 1))
    return (H, P, NoiseConfig().Q), {}


MEASUREMENT_NOISE_FROM_STATE_COVARIANCE = Fault(
    name="measurement_noise_from_state_covariance",
    step="innovation_covariance",
    description="The innovation covariance adds the motion-noise matrix instead of the measurement noise Q.",
    rationale=(
        "EKF-based SLAM code keeps several 2x2 and 3x3 noise matrices side by side; PythonRobotics' EKF-SLAM "
        "example forms S = H P H^T + Cx[0:2, 0:2], the top-left block of its state (motion) noise Cx, where "
        "the range-bearing noise belongs. Here the filter's control-noise matrix M = diag(std_v^2, "
        "std_omega^2) stands in for Q: range gets 0.1 m instead of 0.3 m and bearing 20 deg instead of 10 deg "
        "of assumed noise, so the filter trusts ranges too much and bearings too little."),
    origin=("public code: PythonRobotics SLAM/EKFSLAM/ekf_slam.py, calc_innovation() "
            "(S = H @ PEst @ H.T + Cx[0:2, 0:2]); recalled, not re-read"),
    replacement=_state_block_as_measurement_noise,
    examples=(UnitExample(_ex_innovation, "range and bearing noise swapped for the control noise"),),
)

_BUILTIN = {f.name: f for f in BUILTIN_FAULTS}

#: The real faults, the paper's own first.
REAL_FAULTS: tuple[RealFault, ...] = (
    RealFault(
        "fov_right_side_passes", None, "scenario option fov_bug = True (faultlab.scenario.generate_scenario)",
        Provenance(
            project="EmbSys-WWU/SLAMtesting (the paper's replication package), commit 8c0a75d",
            file="simulator.py, the field-of-view test of the observation model",
            what=("min(angle, 2 pi - angle) < sensor_fov with angle in [-pi, pi): every landmark on the right "
                  "(negative bearing) passes whatever the opening, so the simulated field of view is not the "
                  "stated one and bearings near +-pi become common."),
            found="faultlab's replication of the paper: its map errors did not match the published raw data "
                  "until the simulator's field of view was reproduced (reports/profile-paper, notes/reference-sut.md)",
            known="read")),
    RealFault(
        "paper_aliasing", _BUILTIN["paper_aliasing"], "built-in fault paper_aliasing",
        Provenance(
            project="AtsushiSakai/PythonRobotics, as copied into EmbSys-WWU/SLAMtesting slam/slam_correct.py",
            file="SLAM/FastSLAM1/fast_slam1.py, resampling() and update_with_observation()",
            what=("resampling copies the particle list shallowly (tmp = particles[:]) and assigns array views "
                  "(lm[:, :], lmP[:, :]): resampled duplicates share landmark storage and every later update is "
                  "applied once per sharer, one after the other."),
            found="faultlab's replication of the paper (the paper's correct variant carries it)",
            known="read")),
    RealFault(
        "shallow_copy_resampling", _BUILTIN["shallow_copy_resampling"], "built-in fault shallow_copy_resampling",
        Provenance(
            project="AtsushiSakai/PythonRobotics",
            file="SLAM/FastSLAM1/fast_slam1.py, resampling()",
            what="the same shallow copy, reproduced with parallel updates of the sharers (the last write wins)",
            found="faultlab's replication of the paper", known="read")),
    RealFault(
        "new_landmark_near_zero", _BUILTIN["new_landmark_near_zero"], "built-in fault new_landmark_near_zero",
        Provenance(
            project="AtsushiSakai/PythonRobotics, as copied into EmbSys-WWU/SLAMtesting",
            file="SLAM/FastSLAM1/fast_slam1.py, update_with_observation()",
            what=("a landmark counts as new while abs(lm[id, 0]) <= 0.01 (zero-initialised storage), so one "
                  "estimated within 1 cm of x = 0 is re-initialised at every sighting."),
            found="faultlab's replication of the paper (notes/reference-sut.md, 'new landmark')", known="read")),
    RealFault(
        "gain_from_wrong_covariance", _BUILTIN["gain_from_wrong_covariance"],
        "built-in fault gain_from_wrong_covariance",
        Provenance(
            project="AtsushiSakai/PythonRobotics",
            file="SLAM/FastSLAM1/fast_slam1.py, the landmark update (S versus Sf)",
            what="which innovation covariance the landmark update uses, S or Sf, questioned as incorrect",
            found="a user's report: PythonRobotics issue #138 'S here seems incorrect'",
            known="reported")),
    RealFault(
        "measurement_noise_from_state_covariance", MEASUREMENT_NOISE_FROM_STATE_COVARIANCE,
        "fault measurement_noise_from_state_covariance (this module)",
        Provenance(
            project="AtsushiSakai/PythonRobotics",
            file="SLAM/EKFSLAM/ekf_slam.py, calc_innovation()",
            what="S = H @ PEst @ H.T + Cx[0:2, 0:2]: the state noise block Cx where the measurement noise belongs",
            found="reading the example's code", known="recalled")),
)


def real_faults() -> dict[str, RealFault]:
    """The ``real`` category by name."""
    return {r.name: r for r in REAL_FAULTS}
