"""Fault registry: mutation-style faults that patch one unit of the reference FastSLAM.

Built-in faults (the paper's three, Sec. VII-A, plus realistic particle-filter
SLAM mistakes) live in :mod:`faultlab.faults.builtin`; third-party faults are
discovered through the entry-point group ``faultlab.faults``
(:mod:`faultlab.faults.discovery`).  Sensor and hardware faults
(:mod:`faultlab.faults.sensor`, built-ins in :mod:`faultlab.faults.sensorfaults`) perturb the
input stream every SLAM sees instead of a unit.  A fault is applied per SLAM instance
(:meth:`Fault.apply` returns a new instance) and never leaks into the
reference.  :func:`check_faults` flags equivalent mutants.

>>> from faultlab.faults import get_fault                   # doctest: +SKIP
>>> from faultlab.slam import FastSlam                      # doctest: +SKIP
>>> faulty = get_fault("naive_resampling").apply(FastSlam())  # doctest: +SKIP
"""

from faultlab.faults.check import (
    CheckStatus,
    FaultCheck,
    FaultCheckReport,
    check_faults,
    check_scenario,
    unit_outputs,
)
from faultlab.faults.applicability import (
    Applicability,
    FaultNotApplicableWarning,
    NotApplicable,
    applicable_faults,
    fault_applies,
    not_applicable,
    slam_units,
)
from faultlab.faults.discovery import ENTRY_POINT_GROUP, PluginFailure, PluginWarning, load_plugins
from faultlab.faults.fault import Fault, UnitExample, apply_faults, known_steps, step_names
from faultlab.faults.registry import (
    FaultListing,
    all_faults,
    all_sensor_faults,
    builtin_faults,
    builtin_sensor_faults,
    get_fault,
    list_faults,
    resolve_fault,
)
from faultlab.faults.sensor import SENSOR_ENTRY_POINT_GROUP, SensorFault, load_sensor_plugins
from faultlab.faults.slamlisting import list_slams

__all__ = [
    "ENTRY_POINT_GROUP",
    "SENSOR_ENTRY_POINT_GROUP",
    "SensorFault",
    "all_sensor_faults",
    "builtin_sensor_faults",
    "load_sensor_plugins",
    "Fault",
    "UnitExample",
    "FaultListing",
    "PluginFailure",
    "PluginWarning",
    "all_faults",
    "apply_faults",
    "builtin_faults",
    "get_fault",
    "list_faults",
    "load_plugins",
    "resolve_fault",
    "step_names",
    "CheckStatus",
    "FaultCheck",
    "FaultCheckReport",
    "check_faults",
    "check_scenario",
    "unit_outputs",
    "Applicability",
    "FaultNotApplicableWarning",
    "NotApplicable",
    "applicable_faults",
    "fault_applies",
    "known_steps",
    "not_applicable",
    "slam_units",
    "list_slams",
]
