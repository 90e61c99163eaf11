"""The ``real`` category: faults that reproduce bugs found in public SLAM code, each with its provenance.

Mutants and invented faults stand for real faults only if tests that find the former also find the
latter (Just et al., "Are mutants a valid substitute for real faults in software testing?", FSE 2014).
This module names the faults whose failure mode was *found* in published SLAM code, and says where:
the project, the file, what was wrong, how it was found, and how faultlab knows it (read in a copy of
the code, recorded from an issue thread, or recalled from the public file and not re-read -- the last
kind is a weaker claim and is marked so).

Every unit fault of the category is a built-in fault (:mod:`faultlab.faults.builtin`), so an
experiment names it among its ``variants`` like any other and ``faultlab run`` runs it; this module
adds the provenance and the category (:func:`fault_categories`).  One entry is not a unit fault: the
paper's field-of-view defect lives in the paper's *simulator*, not in its filter, and faultlab
reproduces it as the scenario option ``fov_bug = True`` (:attr:`RealFault.fault` is None for it).
"""

from __future__ import annotations

from dataclasses import dataclass

from faultlab.faults.builtin import (
    BUILTIN_FAULTS,
    CONTROL_NOISE_FROM_COVARIANCE,
    MEASUREMENT_NOISE_FROM_STATE_COVARIANCE,
)
from faultlab.faults.fault import Fault

__all__ = ["REAL", "Provenance", "RealFault", "REAL_FAULTS", "real_faults", "fault_categories"]

#: The category name of the faults that reproduce real bugs (``faultlab faults --category real``).
REAL = "real"


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
            project=("AtsushiSakai/PythonRobotics (read at commit 2f8df1ec19a760caa6d255d2fc2a67f534e70ac2), as "
                     "copied into EmbSys-WWU/SLAMtesting slam/slam_correct.py"),
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
            project=("AtsushiSakai/PythonRobotics (read at commit 2f8df1ec19a760caa6d255d2fc2a67f534e70ac2), as "
                     "copied into EmbSys-WWU/SLAMtesting"),
            file="SLAM/FastSLAM1/fast_slam1.py, update_with_observation()",
            what=("a landmark counts as new while abs(lm[id, 0]) <= 0.01 (zero-initialised storage), so one "
                  "estimated within 1 cm of x = 0 is re-initialised at every sighting."),
            found="faultlab's replication of the paper (notes/reference-sut.md, 'new landmark')", known="read")),
    RealFault(
        "gain_from_wrong_covariance", _BUILTIN["gain_from_wrong_covariance"],
        "built-in fault gain_from_wrong_covariance",
        Provenance(
            project="AtsushiSakai/PythonRobotics, commit e0c15292b233f7d142c692c3aba51722d70882a1",
            file="SLAM/FastSLAM1/fast_slam1.py, the landmark update (S versus Sf)",
            what=("the landmark update forms its own innovation covariance S where Table 13.1 of Probabilistic "
                  "Robotics uses Sf, computed a few lines before: which covariance the gain uses is questioned"),
            found="a user's report: PythonRobotics issue #138 'S here seems incorrect' (2018-11-28, still open)",
            known="reported")),
    RealFault(
        "measurement_noise_from_state_covariance", MEASUREMENT_NOISE_FROM_STATE_COVARIANCE,
        "built-in fault measurement_noise_from_state_covariance",
        Provenance(
            project="AtsushiSakai/PythonRobotics, commit 047f89beb47587e9b758565c0d458e279ebb4681",
            file="SLAM/EKFSLAM/ekf_slam.py, calc_innovation()",
            what=("S = H @ PEst @ H.T + Cx[0:2, 0:2]: the (x, y) block of the state noise Cx = diag(0.5 m, "
                  "0.5 m, 30 deg)^2 where the range-bearing noise belongs; the filter assumes 0.5 rad (29 deg) "
                  "of bearing noise whatever the sensor's."),
            found="reading the example's code (the stored public copy, for faultlab's real-fault category)",
            known="read")),
    RealFault(
        "control_noise_from_covariance", CONTROL_NOISE_FROM_COVARIANCE,
        "built-in fault control_noise_from_covariance",
        Provenance(
            project="AtsushiSakai/PythonRobotics, commit 2f8df1ec19a760caa6d255d2fc2a67f534e70ac2",
            file="SLAM/FastSLAM1/fast_slam1.py, predict_particles()",
            what=("ud = u + (np.random.randn(1, 2) @ R).T with R = diag(1.0, 20 deg)^2 a covariance: each "
                  "particle's control noise has deviation sigma^2 instead of sigma (1.0 m/s and 7 deg instead "
                  "of 1.0 m/s and 20 deg; the speed's is right only because its sigma is 1)."),
            found="reading the example's code (the stored public copy, for faultlab's real-fault category)",
            known="read")),
)


def real_faults() -> dict[str, RealFault]:
    """The ``real`` category by name."""
    return {r.name: r for r in REAL_FAULTS}


def fault_categories() -> dict[str, str]:
    """Fault name -> category, for the registered faults that have one (the ``real`` ones)."""
    return {r.name: REAL for r in REAL_FAULTS if r.fault is not None}
