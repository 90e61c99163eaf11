"""Random streams per replaceable unit: common random numbers that survive a fault.

A SLAM built from replaceable units gives every unit that draws random numbers its own
:class:`numpy.random.Generator`.  The streams are derived from the generator the SLAM is reset
with, keyed by the unit's *name* (never by the order in which units are created or called), so a
fault that changes how one unit uses randomness -- more draws, fewer draws, another distribution --
leaves the draws of every other unit bit-identical.  A faulty run and its baseline with the same
seed therefore share all random numbers except those of the replaced unit.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from faultlab.errors import SlamInputError
from faultlab.seeds import stable_code

__all__ = ["unit_streams"]


def unit_streams(rng: np.random.Generator, names: Iterable[str]) -> dict[str, np.random.Generator]:
    """One independent generator per unit name, derived from ``rng``.

    Draws 128 bits of entropy from ``rng`` once, then gives unit ``name`` the generator of
    ``SeedSequence(entropy, spawn_key=(stable_code(name),))``.  The stream of a name does not
    depend on which other names are requested nor on their order.

    Parameters
    ----------
    rng : numpy.random.Generator
        The SLAM's generator (advanced by exactly one draw of two 64-bit integers).
    names : iterable of str
        Unit names (distinct).

    Returns
    -------
    dict
        ``name -> numpy.random.Generator`` (PCG64).
    """
    if not isinstance(rng, np.random.Generator):
        raise SlamInputError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    names = list(names)
    if len(set(names)) != len(names):
        raise SlamInputError(f"unit stream names must be distinct, got {names!r}")
    entropy = [int(x) for x in rng.integers(0, 2 ** 63, size=2, dtype=np.int64)]
    return {name: np.random.Generator(np.random.PCG64(np.random.SeedSequence(
        entropy=entropy, spawn_key=(stable_code(name),)))) for name in names}
