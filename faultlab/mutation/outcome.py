"""Outcome classes of a mutant: from pre-campaign screening and from a mutation campaign."""

from __future__ import annotations

from enum import StrEnum

__all__ = ["MutantOutcome", "SCREENED_OUT"]


class MutantOutcome(StrEnum):
    """What became of one mutant.

    The last four are decided before any campaign, by screening at the unit level
    (:mod:`faultlab.mutation.screening`); such mutants never run.  The first four are the
    outcomes of a campaign run of a mutant that passed screening (a *live* mutant).
    """

    KILLED = "killed"  # some test case detected it
    SURVIVED = "survived"  # ran to the end on every test case and no test case detected it
    CRASH = "crash"  # the SLAM raised or returned a non-finite estimate
    TIMEOUT = "timeout"  # a SLAM execution exceeded its time limit
    EQUIVALENT = "equivalent"  # identical bytecode, or bit-identical unit outputs on every unit example
    STILLBORN = "stillborn"  # does not compile, or raises on every unit example
    DUPLICATE = "duplicate"  # bit-identical unit outputs to an earlier mutant of the same unit, which runs
    NONDETERMINISTIC = "nondeterministic"  # unit outputs depend on the initial contents of np.empty buffers
    INVALID = "invalid"  # a mutant of user source that cannot be imported or built: neither killed nor survived


#: The outcomes screening assigns; a mutant with none of them is live.
SCREENED_OUT: tuple[MutantOutcome, ...] = (MutantOutcome.STILLBORN, MutantOutcome.EQUIVALENT,
                                           MutantOutcome.DUPLICATE, MutantOutcome.NONDETERMINISTIC)
