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

Beyond the paper, ``[detection]`` also chooses how a *case* is judged:

``rule = "paper"`` (default)
    the thresholds above on each (faulty, baseline) pair of one SLAM repetition; with K > 1
    repetitions a case detects a fault when a strict majority of its judged repetitions do
    (the per-case share of detecting repetitions is reported beside it).
``rule = "statistical"``
    the exact paired sign-flip test over the case's K repetitions
    (:func:`faultlab.stats.case_verdicts`) at level ``alpha``, Holm-adjusted within the
    multiplicity ``family``; two-sided by default (``direction = "either"``: a fault is
    detected when it changes the map error, worse or better, and the verdict says which), or
    the paper's one-sided notion (``direction = "worse"``).  A verdict is possible only from
    ``K >= min_pairs(alpha)`` usable pairs (the smallest attainable p value is ``2^-K``
    one-sided, ``2^-(K-1)`` two-sided): two-sided K >= 6 at alpha = 0.05, K >= 8 at 0.01; and
    Holm within a family of m cases needs that floor to be at most ``alpha / m`` for the
    smallest p value to survive (e.g. 45 cases at alpha = 0.05: K >= 11 two-sided, 10 one-sided).

``family`` (the multiplicity family of the Holm correction of the statistical rule):

``"fault"`` (default)
    all cases of one fault, across suites and runs: adding another fault or variant to a
    campaign changes no verdict of this one;
``"suite_fault"``
    the cases of one (suite, fault);
``"case"``
    none: each (case, fault) is its own family (per-comparison level ``alpha``).

``direction`` (the statistical rule's alternative): ``"either"`` (default, two-sided) or
``"worse"`` (one-sided, the paper's notion).

``metric`` (``"rms"`` or ``"emd"``, the experiment's top-level ``metric``) is the map error both
rules compare.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from faultlab.config import check_number
from faultlab.errors import ConfigError
from faultlab.vocabulary import DEFAULT_ALPHA, DEFAULT_DIRECTION, DIRECTIONS

__all__ = ["DetectionRule", "detects", "RULES", "FAMILIES"]

#: How a case is judged: the paper's thresholds, or the exact paired test over K repetitions.
RULES: tuple[str, ...] = ("paper", "statistical")
#: Multiplicity families of the statistical rule's Holm correction (see the module docstring).
FAMILIES: tuple[str, ...] = ("fault", "suite_fault", "case")


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
    rule : {"paper", "statistical"}
        How a case is judged (module docstring); default the paper's.
    alpha : float
        Level of the statistical rule's tests, in (0, 1) (default
        :data:`~faultlab.vocabulary.DEFAULT_ALPHA`).
    family : {"fault", "suite_fault", "case"}
        Multiplicity family of the statistical rule's Holm correction (default ``"fault"``).
    direction : {"either", "worse"}
        Alternative of the statistical rule's tests: two-sided (default) or the paper's one-sided.
    """

    abs_mm: float = 250.0
    rel: float = 0.25
    rule: str = "paper"
    alpha: float = DEFAULT_ALPHA
    family: str = "fault"
    direction: str = DEFAULT_DIRECTION

    def __post_init__(self) -> None:
        for name in ("abs_mm", "rel"):
            object.__setattr__(self, name, check_number(getattr(self, name), name=f"DetectionRule.{name}",
                                                        minimum=0.0))
        alpha = check_number(self.alpha, name="DetectionRule.alpha", positive=True)
        if not alpha < 1:
            raise ConfigError(f"DetectionRule.alpha: must lie in (0, 1), got {self.alpha!r}")
        object.__setattr__(self, "alpha", alpha)
        for name, allowed in (("rule", RULES), ("family", FAMILIES), ("direction", DIRECTIONS)):
            value = getattr(self, name)
            if value not in allowed:
                raise ConfigError(f"DetectionRule.{name}: must be one of {', '.join(map(repr, allowed))}, "
                                  f"got {value!r}")

    @property
    def statistical(self) -> bool:
        """Whether cases are judged by the exact paired test."""
        return self.rule == "statistical"

    @property
    def test_name(self) -> str:
        """The statistical rule's test, with its sidedness, for reports."""
        return ("exact two-sided paired sign-flip test" if self.direction == "either"
                else "exact one-sided paired sign-flip test (the paper's notion: the error grows)")

    def describe(self) -> str:
        """One line for reports."""
        paper = (f"detected when faulty RMS - baseline RMS > {self.abs_mm:g} mm "
                 f"and >= {100 * self.rel:g} % of the baseline RMS")
        if not self.statistical:
            return paper
        sided = ("two-sided (a change of the error, worse or better)" if self.direction == "either"
                 else "one-sided (the error grows: the paper's notion)")
        return (f"detected when the exact {sided} paired sign-flip test over the K repetitions rejects at "
                f"alpha = {self.alpha:g} after Holm within the family '{self.family}' (a crash of the faulty "
                f"variant alone counts as detected); per repetition: {paper}")

    def to_dict(self) -> dict:
        """The rule as the ``[detection]`` table of an experiment file.

        The keys beyond the paper's thresholds appear only where they differ from their defaults,
        so an experiment of the paper's rule keeps the hash (and resumable store) it always had;
        the statistical rule always records its ``direction`` (a stored rule without one was run
        one-sided, before the two-sided default, and is read back so:
        :func:`faultlab.stats.metadata.read_rule`).
        """
        out = {"abs_mm": self.abs_mm, "rel": self.rel}
        for name in ("rule", "alpha", "family", "direction"):
            if getattr(self, name) != DetectionRule.__dataclass_fields__[name].default:
                out[name] = getattr(self, name)
        if self.statistical:  # always recorded: a stored rule without it predates the two-sided default
            out["direction"] = self.direction
        return out


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
