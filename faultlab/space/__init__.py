"""faultlab.space: the parameter space of Table I, coverage and suite builders (Sec. V-VI)."""

from faultlab.space.case import FIXED_VALUES, PARAMETER_NAMES, VALUE_KEYS, CaseSpec
from faultlab.space.coverage import Coverage, ParameterCoverage, coverage
from faultlab.space.parameters import (
    DIRECTIONALITY_LABELS,
    EquivalenceClass,
    Kind,
    Parameter,
    ParameterSpace,
    load_space,
    space_from_mapping,
    table1_space,
)
from faultlab.space.suites import build_suite, fixed_suite, random_suite, systematic_suite

__all__ = [
    "CaseSpec",
    "VALUE_KEYS",
    "PARAMETER_NAMES",
    "FIXED_VALUES",
    "Kind",
    "EquivalenceClass",
    "Parameter",
    "ParameterSpace",
    "DIRECTIONALITY_LABELS",
    "table1_space",
    "load_space",
    "space_from_mapping",
    "Coverage",
    "ParameterCoverage",
    "coverage",
    "build_suite",
    "systematic_suite",
    "random_suite",
    "fixed_suite",
]
