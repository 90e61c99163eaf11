"""Map-error metrics (Sec. VII-B): Kabsch-aligned RMS and earth mover's distance; the absolute trajectory error.

Pure functions over numpy arrays, SI units in; :func:`map_errors` converts to
mm for the results table.
"""

from faultlab.metrics.detection import DetectionRule, detects
from faultlab.metrics.alignment import MapError, kabsch_rms, match_ids
from faultlab.metrics.maperror import MapErrors, map_errors
from faultlab.metrics.trajectory import TrajectoryError, absolute_trajectory_error, trajectory_error_mm
from faultlab.metrics.transport import earth_movers_distance

__all__ = ["DetectionRule", "detects", "MapError", "kabsch_rms", "match_ids", "earth_movers_distance", "MapErrors", "map_errors",
           "TrajectoryError", "absolute_trajectory_error", "trajectory_error_mm"]
