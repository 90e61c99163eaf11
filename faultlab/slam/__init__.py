"""faultlab.slam: the SLAM adapter protocol, the reference FastSLAM 1.0, FastSLAM 2.0 (both also with unknown
data association), EKF-SLAM, dead reckoning."""

from faultlab.slam.association import FastSlam2Unknown, FastSlam2UnknownSteps, FastSlamUnknown, FastSlamUnknownSteps

from faultlab.slam.deadreckoning import DeadReckoning
from faultlab.slam.ekf import REFERENCE_STEPS as EKF_REFERENCE_STEPS
from faultlab.slam.ekf import EkfSlam, EkfSlamConfig, EkfSlamSteps
from faultlab.slam.fastslam import (
    REFERENCE_STEPS,
    FastSlam,
    FastSlamConfig,
    FastSlamSteps,
    Particles,
    ParticleState,
    landmark_rows,
)
from faultlab.slam.fastslam2 import REFERENCE_STEPS as FASTSLAM2_REFERENCE_STEPS
from faultlab.slam.fastslam2 import FastSlam2, FastSlam2Steps
from faultlab.slam.protocol import (HIDDEN_ID, Estimate, Observations, SlamAdapter, as_control, association_of,
                                    run_slam, run_slam_batch)

__all__ = [
    "Observations",
    "Estimate",
    "SlamAdapter",
    "run_slam",
    "run_slam_batch",
    "as_control",
    "association_of",
    "HIDDEN_ID",
    "FastSlamConfig",
    "FastSlamSteps",
    "REFERENCE_STEPS",
    "FastSlam",
    "Particles",
    "ParticleState",
    "landmark_rows",
    "DeadReckoning",
    "FastSlam2",
    "FastSlam2Steps",
    "FASTSLAM2_REFERENCE_STEPS",
    "EkfSlam",
    "EkfSlamConfig",
    "EkfSlamSteps",
    "EKF_REFERENCE_STEPS",
    "FastSlamUnknown",
    "FastSlamUnknownSteps",
    "FastSlam2Unknown",
    "FastSlam2UnknownSteps",
]
