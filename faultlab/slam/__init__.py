"""faultlab.slam: the SLAM adapter protocol, the reference FastSLAM 1.0 and a dead-reckoning baseline."""

from faultlab.slam.deadreckoning import DeadReckoning
from faultlab.slam.fastslam import (
    REFERENCE_STEPS,
    FastSlam,
    FastSlamConfig,
    FastSlamSteps,
    Particles,
    ParticleState,
    landmark_rows,
)
from faultlab.slam.protocol import Estimate, Observations, SlamAdapter, as_control, run_slam

__all__ = [
    "Observations",
    "Estimate",
    "SlamAdapter",
    "run_slam",
    "as_control",
    "FastSlamConfig",
    "FastSlamSteps",
    "REFERENCE_STEPS",
    "FastSlam",
    "Particles",
    "ParticleState",
    "landmark_rows",
    "DeadReckoning",
]
