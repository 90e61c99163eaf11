"""One test case's parameter values (paper units) and their equivalence classes."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Mapping

from faultlab.errors import ScenarioError

__all__ = ["CaseSpec", "VALUE_KEYS", "PARAMETER_NAMES", "FIXED_VALUES"]

#: The 11 parameters of Table I, in the paper's row order.
PARAMETER_NAMES: tuple[str, ...] = (
    "directionality",
    "rotation_error",
    "inactivity",
    "map_size",
    "landmark_density",
    "step_size",
    "symmetry",
    "outlier_probability",
    "field_of_view",
    "variance",
    "bias",
)

#: Keys of :attr:`CaseSpec.values` with their units (Table I units).
#: ``variance`` and ``bias`` have a distance and an angle component.
VALUE_KEYS: dict[str, str] = {
    "directionality": "-",  # "random" or "loop"
    "rotation_error": "rad",
    "inactivity": "steps",
    "map_size": "m^2",
    "landmark_density": "lm/m^2",
    "step_size": "cm",
    "symmetry": "%",
    "outlier_probability": "%",
    "field_of_view": "rad",
    "variance_distance": "mm",  # a standard deviation
    "variance_angle": "rad",  # a standard deviation
    "bias_distance": "mm",
    "bias_angle": "rad",
}

#: The *fixed* suite's values (the replication package's defaults).
FIXED_VALUES: dict[str, float | str] = {
    "directionality": "random",
    "rotation_error": 0.0,
    "inactivity": 0,
    "map_size": 64.0,  # 8 m side
    "landmark_density": 5.0,
    "step_size": 80.0,
    "symmetry": 0.0,
    "outlier_probability": 2.0,
    "field_of_view": math.pi,
    "variance_distance": 10.0,
    "variance_angle": 0.02,
    "bias_distance": 0.0,
    "bias_angle": 0.0,
}


@dataclass(frozen=True)
class CaseSpec:
    """Parameter values of one test case and the class index of each parameter.

    Parameters
    ----------
    values : mapping
        One entry per key of :data:`VALUE_KEYS`, in Table I units.
    classes : mapping
        Parameter name (:data:`PARAMETER_NAMES`) -> index of the equivalence
        class the value was drawn from (or falls in), 0-based in Table I order.
        ``-1`` where the value lies in no class of the space.
    """

    values: Mapping[str, float | str]
    classes: Mapping[str, int] = field(default_factory=dict)

    def __post_init__(self) -> None:
        missing = [k for k in VALUE_KEYS if k not in self.values]
        if missing:
            raise ScenarioError(f"case values lack {', '.join(missing)}")
        object.__setattr__(self, "values", dict(self.values))
        object.__setattr__(self, "classes", {k: int(v) for k, v in self.classes.items()})

    def to_dict(self) -> dict:
        """JSON-serialisable form (see :meth:`from_dict`)."""
        return {"values": dict(self.values), "classes": dict(self.classes)}

    @classmethod
    def from_dict(cls, data: Mapping) -> "CaseSpec":
        return cls(values=dict(data["values"]), classes=dict(data.get("classes", {})))
