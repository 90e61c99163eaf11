"""Which faults apply to which SLAM: a fault replaces one unit, so it applies to the SLAMs that have it.

A sensor fault (:class:`~faultlab.faults.sensor.SensorFault`) perturbs the input stream and applies
to every SLAM; a hardware limit applies to the SLAMs that have the option it changes.

A fault replaces one unit (:attr:`Fault.step`), so it applies to exactly the SLAMs whose steps table
has a unit of that name (the units shared by FastSLAM 1.0, FastSLAM 2.0 and EKF-SLAM have the same
signatures, see :mod:`faultlab.slam.units`).  :func:`applicable_faults` splits a list of faults
into those that apply to a SLAM and those that do not, with the reason.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

from faultlab.faults.fault import Fault, step_names
from faultlab.faults.registry import all_faults
from faultlab.faults.sensor import SensorFault
from faultlab.slam.registry import SlamKind, build_slam, get_slam_kind

__all__ = ["slam_units", "NotApplicable", "FaultNotApplicableWarning", "Applicability", "not_applicable",
           "fault_applies", "applicable_faults"]


def _slam_label(slam: Any) -> str:
    if isinstance(slam, str):
        return slam
    if isinstance(slam, SlamKind):
        return slam.name
    if isinstance(slam, type):
        return slam.__name__
    return str(getattr(slam, "name", type(slam).__name__))


def slam_units(slam: Any) -> tuple[str, ...]:
    """The replaceable units of a SLAM, in algorithm order; () for a SLAM without units.

    Parameters
    ----------
    slam : str, SlamKind, type or SlamAdapter
        A built-in SLAM's name (``"ekf"``), an import path ``"package.module:factory"`` (the
        factory is called without options to find out), a :class:`~faultlab.slam.registry.SlamKind`,
        a steps dataclass type, or a SLAM instance (its units are the fields of ``slam.steps`` if it
        has ``steps`` and ``with_steps``, the fault contract of :mod:`faultlab.faults.fault`).

    Raises
    ------
    ConfigError
        An unknown SLAM name.
    """
    if isinstance(slam, SlamKind):
        return slam.units
    if isinstance(slam, str):
        kind = get_slam_kind(slam, where="slam")
        if kind is not None:
            return kind.units
        slam = build_slam(slam, {})
    if isinstance(slam, type):
        return step_names(slam)
    steps = getattr(slam, "steps", None)
    if (steps is None or isinstance(steps, type) or not dataclasses.is_dataclass(steps)
            or not callable(getattr(slam, "with_steps", None))):
        return ()
    return step_names(type(steps))


class FaultNotApplicableWarning(UserWarning):
    """Issued when a campaign skips a variant whose fault replaces a unit its SLAM does not have."""


@dataclass(frozen=True)
class NotApplicable:
    """A fault that does not apply to a SLAM, and why: the SLAM has no unit of that name.

    Attributes
    ----------
    fault : str
        The fault's name.
    step : str
        The unit it replaces.
    slam : str
        The SLAM (its name or import path).
    n_units : int
        How many replaceable units the SLAM has (0: none at all, e.g. dead reckoning).
    reason : str
        The reason in words when it is not a missing unit (a hardware limit on a SLAM without its
        option); "" otherwise.
    """

    fault: str
    step: str
    slam: str
    n_units: int
    reason: str = ""

    def __str__(self) -> str:
        if self.reason:
            return f"{self.reason} (SLAM {self.slam!r})"
        if self.n_units == 0:
            return (f"fault {self.fault!r} replaces unit {self.step!r}, but SLAM {self.slam!r} has no "
                    f"replaceable units")
        return (f"fault {self.fault!r} replaces unit {self.step!r}, which SLAM {self.slam!r} does not have "
                f"(it has {self.n_units} other units)")


def _slam_options(slam: Any) -> dict[str, Any]:
    """The default options of a built-in SLAM (name or kind); {} for anything else."""
    kind = slam if isinstance(slam, SlamKind) else (get_slam_kind(slam, where="slam") if isinstance(slam, str)
                                                    else None)
    return {} if kind is None else kind.options({}, where="slam")


def not_applicable(fault: Fault | SensorFault, slam: Any, *, units: tuple[str, ...] | None = None,
                   options: dict[str, Any] | None = None) -> NotApplicable | None:
    """Why ``fault`` does not apply to ``slam`` (see :func:`slam_units`), or None if it applies.

    ``units`` (the SLAM's units, if already known) saves looking them up again.  For a sensor
    fault, ``options`` are the SLAM's options (default: a built-in SLAM's defaults); a stream fault
    applies to every SLAM.
    """
    if isinstance(fault, SensorFault):
        if fault.option is None:
            return None
        reason = fault.not_applicable(_slam_options(slam) if options is None else options)
        if reason is None:
            return None
        return NotApplicable(fault=fault.name, step=fault.step, slam=_slam_label(slam),
                             n_units=len(slam_units(slam) if units is None else units), reason=reason)
    units = slam_units(slam) if units is None else tuple(units)
    if fault.step in units:
        return None
    return NotApplicable(fault=fault.name, step=fault.step, slam=_slam_label(slam), n_units=len(units))


def fault_applies(fault: Fault, slam: Any) -> bool:
    """True if ``slam`` has the unit ``fault`` replaces (see :func:`slam_units` for ``slam``)."""
    return not_applicable(fault, slam) is None


@dataclass(frozen=True)
class Applicability:
    """Result of :func:`applicable_faults`: which faults apply to one SLAM.

    Attributes
    ----------
    slam : str
    units : tuple of str
        The SLAM's replaceable units.
    applicable : tuple of Fault
        In the order given.
    not_applicable : tuple of NotApplicable
        In the order given.
    """

    slam: str
    units: tuple[str, ...]
    applicable: tuple[Fault, ...]
    not_applicable: tuple[NotApplicable, ...]

    def summary(self) -> str:
        """One line: how many faults do not apply and why (empty if all apply)."""
        skipped = self.not_applicable
        if not skipped:
            return ""
        total = len(self.applicable) + len(skipped)
        if not self.units:
            return (f"{len(skipped)} of {total} faults do not apply to {self.slam!r}: it has no replaceable "
                    f"units")
        by_step: dict[str, list[str]] = {}
        for item in skipped:
            by_step.setdefault(item.step, []).append(item.fault)
        parts = "; ".join(f"{step} ({', '.join(names)})" for step, names in by_step.items())
        return (f"{len(skipped)} of {total} faults do not apply to {self.slam!r}: they replace units it does "
                f"not have: {parts}")


def applicable_faults(slam: Any, faults: Iterable[Fault] | None = None) -> Applicability:
    """Split ``faults`` (default: every fault, plugins included) by whether they apply to ``slam``.

    Parameters
    ----------
    slam : str, SlamKind, type or SlamAdapter
        See :func:`slam_units`.
    faults : iterable of Fault, optional
    """
    units = slam_units(slam)
    faults = all_faults(warn=False) if faults is None else list(faults)
    label = _slam_label(slam)
    yes: list[Fault] = []
    no: list[NotApplicable] = []
    for fault in faults:
        reason = not_applicable(fault, label if isinstance(slam, str) else slam, units=units)
        if reason is None:
            yes.append(fault)
        else:
            no.append(reason)
    return Applicability(slam=label, units=units, applicable=tuple(yes), not_applicable=tuple(no))
