"""The variant names of an experiment, resolved to the fault each runs.

A variant is the unmodified SLAM (``"baseline"``, ``"baseline_replica"``), a fault
(:func:`faultlab.faults.resolve_fault`: a registered name or a ``module:attr`` import path) or a
mutant of the reference's units (``"mutant:<id>"``, :mod:`faultlab.mutation.variants`).
"""

from __future__ import annotations

from faultlab.faults import Fault, resolve_fault
from faultlab.vocabulary import MUTANT_PREFIX, UNMODIFIED

__all__ = ["resolve_variant"]


def resolve_variant(spec: str | Fault) -> Fault | None:
    """The fault variant ``spec`` runs; None for the unmodified variants.

    Raises
    ------
    FaultError
        For an unknown fault or mutant (the message names close matches).
    """
    if isinstance(spec, str) and spec in UNMODIFIED:
        return None
    if isinstance(spec, str) and spec.startswith(MUTANT_PREFIX):
        # imported here: the mutation package (libcst) loads only for an experiment that names a mutant
        from faultlab.mutation.variants import resolve_mutant_variant

        return resolve_mutant_variant(spec)
    return resolve_fault(spec)
