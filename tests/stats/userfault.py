"""A fault written as a user would write it, outside faultlab: the filter samples half the turn noise.

Used by the campaign-level verdict tests (``test_pooling``): the FastSLAM's particles spread less in
heading than the motion really does, so its map error moves by a modest amount on most cases -- a
diffuse effect that no 5-case suite can show and the campaign as a whole can.
"""

from __future__ import annotations

import numpy as np

from faultlab.faults import Fault


def sample_half_turn_noise(u: np.ndarray, n: int, rng: np.random.Generator, config) -> np.ndarray:
    """``sample_controls`` with the turn noise halved (one ``standard_normal((n, 2))`` call, as the original)."""
    eps = rng.standard_normal((n, 2))
    return u[None, :] + eps * np.array([config.std_v, 0.5 * config.std_omega])


def _replace(original):
    return sample_half_turn_noise


HALVED_TURN_NOISE = Fault(
    name="user/halved_turn_noise", step="sample_controls",
    description="the particles are sampled with half the configured turn noise",
    rationale="a unit slip (the standard deviation of a half-angle) that tightens the particle cloud in heading",
    origin="test fixture: a user's hand-written fault", replacement=_replace)
