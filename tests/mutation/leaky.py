"""A unit written like a user's, with an ``np.empty`` scratch matrix (for the nondeterminism tests).

Kept apart from the test modules so that line numbers and sources are stable: do not reformat.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from faultlab.faults import UnitExample


def rotation(theta):
    """Rotation matrices (n, 2, 2) of the angles ``theta`` (n,); every entry is written."""
    out = np.empty(theta.shape + (2, 2))
    c = np.cos(theta)
    s = np.sin(theta)
    out[:, 0, 0] = c
    out[:, 0, 1] = -s
    out[:, 1, 0] = s
    out[:, 1, 1] = c
    return out


@dataclass(frozen=True)
class LeakySteps:
    rotation: Callable = rotation


def _angles():
    return (np.array([0.0, 0.5, -2.0]),), {}


EXAMPLES = {"rotation": (UnitExample(_angles, "three angles"),)}
