"""The stream a SLAM variant is fed: the case itself, or a sensor fault's perturbation of it.

A sensor fault (:class:`faultlab.faults.sensor.SensorFault`) leaves the SLAM's code alone and
changes its input instead.  :func:`fed_scenario` is the one place that decides which stream a
variant sees; the campaign runner, the equivalent-fault check and the metamorphic check all call
it, so a stream fault is applied the same way everywhere.  It lives with the scenarios, below the
faults and the metamorphic relations, because both of those use it.
"""

from __future__ import annotations

from typing import Any

from faultlab.scenario.model import Scenario

__all__ = ["fed_scenario", "perturbs_stream", "sets_option"]


def perturbs_stream(variant: Any) -> bool:
    """Whether ``variant`` (a fault, a sensor fault or None) perturbs the stream it is fed."""
    return bool(getattr(variant, "perturbs_stream", False))


def sets_option(variant: Any) -> bool:
    """Whether ``variant`` is a hardware limit: a sensor fault that changes a SLAM option, not the stream."""
    return getattr(variant, "option", None) is not None and not perturbs_stream(variant)


def fed_scenario(variant: Any, scenario: Scenario, *, seed: int) -> Scenario:
    """The scenario a SLAM running ``variant`` is fed in the run of SLAM seed ``seed``.

    A stream fault's perturbed stream (``variant.perturb(scenario, seed=seed)``, drawn from the
    fault's own generator keyed by ``seed`` and its name, :func:`faultlab.seeds.sensor_seed_sequence`);
    otherwise -- a code fault, a hardware limit, the unmodified SLAM (None) -- ``scenario`` itself.
    The result keeps ``scenario``'s ground truth arrays, which scoring always uses.
    """
    return variant.perturb(scenario, seed=seed) if perturbs_stream(variant) else scenario
