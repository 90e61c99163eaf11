"""faultlab.space: the parameter space of Table I, coverage and suite builders (Sec. V-VI)."""

from faultlab.space.case import FIXED_VALUES, PARAMETER_NAMES, VALUE_KEYS, CaseSpec
from faultlab.space.constraints import ClassStructure, Constraint
from faultlab.space.coverage import (
    BaseChoiceCoverage,
    Coverage,
    ParameterCoverage,
    TupleCoverage,
    base_choice_coverage,
    coverage,
    t_wise_coverage,
)
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
from faultlab.space.settings import read_class_weights, weights_frame, weights_from_effects
from faultlab.space.strategies import (
    base_choice_suite,
    effect_guided_suite,
    t_wise_kind,
    t_wise_strength,
    t_wise_suite,
)
from faultlab.space.registry import (
    STRATEGIES,
    SUITE_KINDS,
    SuiteStrategy,
    build_suite,
    get_strategy,
    min_suite_size,
    suite_criteria,
    suite_kinds,
)
from faultlab.space.suites import fixed_suite, random_suite, systematic_suite

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
    "Constraint",
    "ClassStructure",
    "table1_space",
    "load_space",
    "space_from_mapping",
    "Coverage",
    "ParameterCoverage",
    "coverage",
    "TupleCoverage",
    "t_wise_coverage",
    "BaseChoiceCoverage",
    "base_choice_coverage",
    "suite_criteria",
    "build_suite",
    "STRATEGIES",
    "SUITE_KINDS",
    "SuiteStrategy",
    "get_strategy",
    "suite_kinds",
    "systematic_suite",
    "random_suite",
    "fixed_suite",
    "base_choice_suite",
    "t_wise_suite",
    "effect_guided_suite",
    "min_suite_size",
    "t_wise_strength",
    "t_wise_kind",
    "read_class_weights",
    "weights_from_effects",
    "weights_frame",
]
