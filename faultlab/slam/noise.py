"""The noise a filter assumes: one settings class shared by every SLAM under test."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from faultlab.config import Option, Settings

__all__ = ["NoiseConfig"]


@dataclass(frozen=True)
class NoiseConfig(Settings):
    """Control and measurement noise a filter assumes (defaults: the paper's setup, Sec. VII-A).

    Attributes
    ----------
    std_v : float
        Control noise std on the forward motion v per step, m (>= 0).
    std_omega : float
        Control noise std on the turn omega per step, rad (>= 0).
    std_range : float
        Measurement noise std on range, m (> 0).
    std_bearing : float
        Measurement noise std on bearing, rad (> 0).
    """

    std_v: float = 0.1
    std_omega: float = math.radians(20.0)
    std_range: float = 0.3
    std_bearing: float = math.radians(10.0)

    #: field -> its setting in an experiment's ``[slam]`` table (angles in degrees there).
    OPTIONS: ClassVar[dict[str, Option]] = {
        "std_v": Option("std_v", bounds={"minimum": 0.0}),
        "std_omega": Option("std_omega_deg", degrees=True, bounds={"minimum": 0.0}),
        "std_range": Option("std_range", bounds={"positive": True}),
        "std_bearing": Option("std_bearing_deg", degrees=True, bounds={"positive": True}),
    }

    @property
    def Q(self) -> np.ndarray:
        """Measurement noise covariance diag(std_range^2, std_bearing^2), shape (2, 2)."""
        return np.diag([self.std_range ** 2, self.std_bearing ** 2])

    @property
    def M(self) -> np.ndarray:
        """Control noise covariance diag(std_v^2, std_omega^2), shape (2, 2)."""
        return np.diag([self.std_v ** 2, self.std_omega ** 2])
