"""Toy units with known equivalent, duplicate and stillborn mutants (for the mutation tests).

Kept apart from the test modules so that line numbers and sources are stable: do not reformat.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from faultlab.faults import UnitExample
from faultlab.slam.protocol import Estimate, SlamAdapter

_OFFSET = 1.0


def _double(x):
    return 2.0 * x


def scale(a):
    t = a * 3.0
    t = a + _OFFSET
    return t


def fold(a):
    return a * (2 + 2)


def lin(a):
    return 2.0 * a


def take(a):
    return a[:, 0]


def twice(a):
    return _double(a) + 1.0


def pad(a):
    return a + 0.0 * 5.0


def shift(a):
    out = a + 1.0
    b = -a
    b *= 2.0
    return out


@dataclass(frozen=True)
class ToySteps:
    """A steps table of the toy units."""

    scale: Callable = scale
    fold: Callable = fold
    lin: Callable = lin
    take: Callable = take
    twice: Callable = twice
    shift: Callable = shift
    pad: Callable = pad


def _column():
    return (np.array([[1.5], [-2.0], [0.25]]),), {}


def _column_ints():
    return (np.array([[3], [4], [-7]]),), {}


def _column_wide():
    return (np.array([[1e3], [-1e-3], [0.0], [7.5]]),), {}


#: Two examples per unit: one-column arrays (so that ``a[:, 1]`` raises on every one of them).
EXAMPLES = {name: (UnitExample(_column, "floats"), UnitExample(_column_ints, "integers"))
            for name in ("scale", "fold", "lin", "take", "twice", "pad")}
EXAMPLES["shift"] = (UnitExample(_column, "floats"), UnitExample(_column_wide, "more floats"))


class ToySlam(SlamAdapter):
    """A "SLAM" that feeds each step's ranges, as a (k, 1) column, through every toy unit."""

    name = "toy"

    def __init__(self, steps: ToySteps = ToySteps()) -> None:
        self.steps = steps

    def with_steps(self, steps: ToySteps) -> "ToySlam":
        return ToySlam(steps)

    def reset(self, pose, *, rng) -> None:
        self.pose = np.asarray(pose, dtype=float).copy()
        self.total = 0.0

    def update(self, control, observations) -> None:
        column = np.asarray(observations.ranges, dtype=float)[:, None]
        if column.shape[0]:
            for name in ("scale", "fold", "lin", "take", "twice", "shift", "pad"):
                self.total += float(np.sum(getattr(self.steps, name)(column)))

    def estimate(self) -> Estimate:
        return Estimate(self.pose.copy(), np.empty(0, dtype=np.int64), np.empty((0, 2)))


def make_toy_slam() -> ToySlam:
    """Factory for ``--slam tests.mutation.toy:make_toy_slam``."""
    return ToySlam()
