"""The units of unknown data association on hand-built cases (faultlab.slam.associationunits)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from faultlab.slam.associationunits import NEW_LANDMARK, associate, new_landmark_log_likelihood
from tests.slam.association_oracle import log_p0


def test_new_landmark_log_likelihood_is_the_gaussian_density_at_that_distance():
    Q = np.diag([0.04, 0.01])
    assert new_landmark_log_likelihood(Q, 2.0) == pytest.approx(log_p0(Q, 2.0), abs=1e-12)
    # at distance 0 it is the density's peak, 1 / (2 pi sqrt(det Q))
    assert math.exp(new_landmark_log_likelihood(Q, 0.0)) == pytest.approx(1 / (2 * math.pi * 0.02))


def test_a_particle_without_landmarks_creates_one_per_observation():
    out = associate(np.zeros((2, 3, 4)), np.zeros((2, 4), dtype=bool), -5.0)
    assert (out == NEW_LANDMARK).all() and out.shape == (2, 3)


def test_best_likelihood_below_p0_creates_a_landmark_and_invalid_slots_never_win():
    ll = np.array([[[-1.0, -9.0, 50.0],      # slot 2 is padding: ignored although most likely
                    [-9.0, -7.0, 50.0]]])    # best valid -7 < p0 = -6: new
    valid = np.array([[True, True, False]])
    assert associate(ll, valid, -6.0).tolist() == [[0, NEW_LANDMARK]]
    assert associate(ll, valid, -8.0).tolist() == [[0, 1]]


def test_one_observation_per_landmark_the_most_likely_keeps_it():
    ll = np.array([[[-1.0, -3.0], [-0.5, -2.0], [-4.0, -1.0]]])  # observations 0 and 1 both prefer slot 0
    out = associate(ll, np.ones((1, 2), dtype=bool), -10.0)
    assert out.tolist() == [[NEW_LANDMARK, 0, 1]]
    tie = associate(np.array([[[-1.0], [-1.0]]]), np.ones((1, 1), dtype=bool), -10.0)
    assert tie.tolist() == [[0, NEW_LANDMARK]]  # exact tie: the lower observation index


