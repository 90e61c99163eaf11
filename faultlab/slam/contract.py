"""The unit contract: which replaceable units draw random numbers, and which see which particles.

A SLAM written as replaceable units (:class:`faultlab.slam.FastSlamSteps` and the other steps
tables) and every fault that replaces one of them follow this contract; the reference units are in
:mod:`faultlab.slam.units`.

Batched repetitions: which units see which particles
----------------------------------------------------
:meth:`faultlab.slam.FastSlam.reset_batch` runs ``B`` independent repetitions of one scenario
(each with its own particles, weights, resampling and random streams) as one particle set of
``B N`` particles: filter ``b`` holds rows ``b N .. (b + 1) N - 1`` of every per-particle array.
All repetitions see the same controls and observations, so their landmark columns align.  The
"N" in the shapes below then means:

* :data:`PARTICLE_UNITS` (``motion_model``, ``wrap_heading``, ``wrap_bearing``,
  ``init_landmarks``, ``classify_new``, ``predict_measurement``, ``innovation``,
  ``innovation_covariance``, ``log_likelihood``, ``ekf_update``) are called **once per step
  with all B N particles**.  A replacement must be *particle-wise*: row ``i`` of every output
  depends only on row ``i`` of the per-particle inputs (and on the shared ``z``, ``Q``,
  ``seen``, ``wrap``), never on other particles -- every reference unit and every built-in fault
  is.  The wrap units must moreover be element-wise (any shape in, same shape out).  A
  replacement of one of the other particle units that does look across particles (a reduction
  or a normalisation over the particle axis, an index like ``poses[0]``) keeps its
  single-filter meaning by declaring it with :func:`filter_wise`: the batched filter then calls
  it once per filter with that filter's (N, ...) slices and stacks the outputs.
* :data:`FILTER_UNITS` (``sample_controls``, ``combine_weights``, ``effective_sample_size``,
  ``resample``, ``apply_resample``, ``extract_map``) are called **once per filter** with that
  filter's N particles: ``sample_controls`` and ``resample`` with the filter's own streams
  (derived from that repetition's generator), ``combine_weights`` with its (N,) weights and
  (N, k) slices, ``apply_resample`` and ``extract_map`` with its own :class:`ParticleState`
  (whose arrays are views of the batch's; storage rows are numbered per filter, from 0).  The
  weight normalisation (log-sum-exp) is per filter too.

So a unit or fault written for one filter stays correct batched: a filter unit never sees
another filter's particles, a particle unit never needs to.  The filter itself checks nothing
about particle-wise behaviour; ``tests/slam/test_batch.py`` checks that every built-in fault
gives each repetition bit for bit its single-filter result.
"""

from __future__ import annotations

__all__ = ["STREAM_UNITS", "PARTICLE_UNITS", "FILTER_UNITS", "filter_wise"]

#: Units that receive a random stream as ``rng``, each its own one, keyed by this name
#: (``unit_streams(rng, STREAM_UNITS)[name]``).  Part of the unit contract: another SLAM built from
#: replaceable units, and every fault, follows it.
STREAM_UNITS: tuple[str, ...] = ("sample_controls", "resample")

#: Units a batch of repetitions calls once per step with the particles of all its filters (B N rows);
#: they must treat every particle independently (see "Batched repetitions" above).
PARTICLE_UNITS: tuple[str, ...] = ("motion_model", "wrap_heading", "wrap_bearing", "init_landmarks",
                                   "classify_new", "predict_measurement", "innovation", "innovation_covariance",
                                   "log_likelihood", "ekf_update")

#: Units a batch of repetitions calls once per filter, with that filter's N particles and its own streams.
FILTER_UNITS: tuple[str, ...] = ("sample_controls", "combine_weights", "effective_sample_size", "resample",
                                 "apply_resample", "extract_map")


def filter_wise(unit):
    """Declare a replacement of a particle unit that must see one filter at a time.

    A batch of repetitions calls a unit marked this way once per filter with that filter's
    (N, ...) slices of the per-particle arguments and stacks the outputs along the particle
    axis, instead of once with all B N particles.  Needed only for a replacement of one of the
    :data:`PARTICLE_UNITS` other than the wrap units that looks across particles; a single
    filter (B = 1) calls it as it is.  Returns ``unit`` itself, marked (attribute
    ``filter_wise = True``).

    >>> @filter_wise
    ... def log_likelihood(nu, S):          # doctest: +SKIP
    ...     ll = reference_log_likelihood(nu, S)
    ...     return ll - ll.mean(axis=0)     # centred over the filter's particles
    """
    unit.filter_wise = True
    return unit
