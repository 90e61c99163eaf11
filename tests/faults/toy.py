"""A toy steps table and SLAM that the fault tests patch."""

import dataclasses


def double_unit(x):
    return 2 * x


def negate_result(original):
    def unit(x):
        return -original(x)

    return unit


@dataclasses.dataclass(frozen=True)
class ToySteps:
    double: object = double_unit
    other: object = abs


class ToySlam:
    def __init__(self, steps=ToySteps()):
        self.steps = steps

    def with_steps(self, steps):
        return ToySlam(steps)
