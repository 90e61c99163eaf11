"""The paper's detection rule on a pair of map errors (Sec. VII-A).

Sec. VII-A: a test case detects a fault when the faulty implementation's map
error exceeds the baseline's "by a value exceeding the expected noise ... 250mm"
and, "since the noise in map error increases with larger map error", by "an
increase of at least 25 %".  Read literally, the absolute condition is strict
(*exceeding*) and the relative one is not (*at least*)::

    increase = faulty - baseline
    detected = (increase > abs_mm) and (increase >= rel * baseline)

The rule is part of a campaign's configuration (stored with its results), so it lives in the
computation layer; pairing jobs and classifying outcomes is :mod:`faultlab.stats.detection`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from faultlab.config import check_number

__all__ = ["DetectionRule", "detects"]


@dataclass(frozen=True)
class DetectionRule:
    """Thresholds of the paper's detection rule (Sec. VII-A).

    Parameters
    ----------
    abs_mm : float
        The RMS increase must *exceed* this, mm (default 250).
    rel : float
        The RMS increase must be *at least* this fraction of the baseline RMS
        (default 0.25, i.e. 25 %).
    """

    abs_mm: float = 250.0
    rel: float = 0.25

    def __post_init__(self) -> None:
        for name in ("abs_mm", "rel"):
            object.__setattr__(self, name, check_number(getattr(self, name), name=f"DetectionRule.{name}",
                                                        minimum=0.0))

    def describe(self) -> str:
        """One line for reports."""
        return (f"detected when faulty RMS - baseline RMS > {self.abs_mm:g} mm "
                f"and >= {100 * self.rel:g} % of the baseline RMS")

    def to_dict(self) -> dict:
        """The rule as the ``[detection]`` table of an experiment file."""
        return {"abs_mm": self.abs_mm, "rel": self.rel}


def detects(faulty_mm, baseline_mm, *, rule: DetectionRule = DetectionRule()):
    """Apply the detection rule elementwise.

    Parameters
    ----------
    faulty_mm, baseline_mm : float or array_like, broadcastable
        RMS errors of the faulty and the baseline variant, mm.
    rule : DetectionRule

    Returns
    -------
    bool or ndarray of bool
        ``faulty - baseline > rule.abs_mm and faulty - baseline >= rule.rel * baseline``.
        NaN inputs give False (use :func:`faultlab.stats.classify` to tell failures apart).
    """
    f = np.asarray(faulty_mm, dtype=float)
    b = np.asarray(baseline_mm, dtype=float)
    increase = f - b
    with np.errstate(invalid="ignore"):
        out = (increase > rule.abs_mm) & (increase >= rule.rel * b)
    return bool(out) if out.ndim == 0 else out
