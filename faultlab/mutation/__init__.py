"""Automatic mutation analysis of SLAM code: mutants of the replaceable units, generated from source.

Mutation testing asks whether a test suite notices small changes to the code.  For a randomised,
numerical SLAM the usual tools do not apply: they rewrite files and rerun a test suite, their
operators know nothing of arrays, and a SLAM's output differs from run to run anyway.  faultlab
mutates the *units* of a SLAM (the fields of its steps dataclass, see :mod:`faultlab.faults.fault`)
in process, one unit per mutant, so a mutant is just another fault and runs with the same seeds
as the baseline.

* :mod:`~faultlab.mutation.operatorbase` -- the :class:`MutationOperator` contract (libcst trees);
  :mod:`~faultlab.mutation.operators` -- the built-in operators, classic and numpy-aware;
  :mod:`~faultlab.mutation.registry` -- operators by name, plugins (entry-point group
  ``faultlab.mutation_operators``).
* :mod:`~faultlab.mutation.source` -- the source of units and their private helpers, and
  rebuilding a unit from changed source; :mod:`~faultlab.mutation.mutant` -- :class:`Mutant`
  records, :func:`generate_mutants`, a mutant as a picklable :class:`~faultlab.faults.Fault`.
* :mod:`~faultlab.mutation.examples` -- unit examples (recorded calls); :mod:`~faultlab.mutation.screening`
  -- stillborn, equivalent and duplicate mutants before any campaign;
  :mod:`~faultlab.mutation.outcome` -- :class:`MutantOutcome`.
* :mod:`~faultlab.mutation.catalogue` -- the screened mutants of a SLAM by name, cached, and the
  listings of ``faultlab mutate``.
"""

import warnings

with warnings.catch_warnings():  # libcst 1.0 imports mypy_extensions.TypedDict, deprecated upstream
    warnings.simplefilter("ignore", DeprecationWarning)
    import libcst  # noqa: F401  (first import, here: every submodule import runs this file first)
    import libcst.metadata  # noqa: F401

from faultlab.mutation.catalogue import Catalogue, cache_dir, list_mutants, mutant_catalogue, show_mutant
from faultlab.mutation.examples import record_unit_examples, unit_examples
from faultlab.mutation.mutant import Mutant, MutantSet, build_mutant_unit, generate_mutants, mutant_fault
from faultlab.mutation.operatorbase import MutationOperator, MutationPoint, NodeOperator, OperatorExample
from faultlab.mutation.operators import BUILTIN_OPERATORS
from faultlab.mutation.outcome import SCREENED_OUT, MutantOutcome
from faultlab.mutation.registry import (
    OPERATOR_ENTRY_POINT_GROUP,
    all_operators,
    get_operator,
    load_operator_plugins,
)
from faultlab.mutation.screening import Screening, ScreeningReport, screen_mutants
from faultlab.mutation.source import UnitSource, unit_sources

__all__ = [
    "BUILTIN_OPERATORS",
    "Catalogue",
    "Mutant",
    "MutantOutcome",
    "MutantSet",
    "MutationOperator",
    "MutationPoint",
    "NodeOperator",
    "OPERATOR_ENTRY_POINT_GROUP",
    "OperatorExample",
    "SCREENED_OUT",
    "Screening",
    "ScreeningReport",
    "UnitSource",
    "all_operators",
    "build_mutant_unit",
    "cache_dir",
    "generate_mutants",
    "get_operator",
    "list_mutants",
    "load_operator_plugins",
    "mutant_catalogue",
    "mutant_fault",
    "record_unit_examples",
    "screen_mutants",
    "show_mutant",
    "unit_examples",
    "unit_sources",
]
