"""The built-in sensor and hardware faults (the contract: :mod:`faultlab.faults.sensor`).

Every perturbation below is a module-level function ``f(scenario, rng, *, parameters...)``,
vectorised over steps and observations, bound to its default parameters with
:func:`functools.partial`.  Units: ranges in m, bearings in rad, controls ``(v, omega)`` per step
(m and rad per step of dt = 1, the scenario's convention), durations and delays in steps.
Observations are the scenario's CSR arrays (``obs_offsets``, ``obs_range``, ``obs_bearing``,
``obs_ids``); the ground truth is never touched.
"""

from __future__ import annotations

import math
from dataclasses import replace
from functools import partial

import numpy as np

from faultlab.faults.sensor import SensorFault, gather_steps, select_observations, step_of_observations
from faultlab.scenario.model import Scenario

__all__ = ["BUILTIN_SENSOR_FAULTS", "drop_observations", "drop_bursts", "stick_ranges", "delay_observations",
           "reorder_observations", "quantise_ranges", "drift_range_bias", "scale_wheels", "slip_wheels",
           "jitter_time_steps", "reduce_particles", "episodes"]


def episodes(n_steps: int, rng: np.random.Generator, *, rate: float, mean_length: float) -> np.ndarray:
    """Which steps lie in an episode (burst): episodes start at each step with probability ``rate``
    and last a geometric number of steps of mean ``mean_length`` (>= 1).  Returns bool (n_steps,)."""
    starts = np.flatnonzero(rng.random(n_steps) < rate)
    lengths = rng.geometric(1.0 / max(float(mean_length), 1.0), size=starts.size)
    edge = np.zeros(n_steps + 1, dtype=np.int64)
    np.add.at(edge, starts, 1)
    np.add.at(edge, np.minimum(starts + lengths, n_steps), -1)
    return np.cumsum(edge[:-1]) > 0


def drop_observations(scenario: Scenario, rng: np.random.Generator, *, p: float) -> Scenario:
    """Each observation is lost independently with probability ``p``."""
    return select_observations(scenario, rng.random(scenario.obs_range.shape[0]) >= p)


def drop_bursts(scenario: Scenario, rng: np.random.Generator, *, rate: float, mean_length: float) -> Scenario:
    """Every observation of the steps inside a burst (:func:`episodes`) is lost."""
    blind = episodes(scenario.n_steps, rng, rate=rate, mean_length=mean_length)
    return select_observations(scenario, ~blind[step_of_observations(scenario)])


def stick_ranges(scenario: Scenario, rng: np.random.Generator, *, rate: float, mean_length: float) -> Scenario:
    """Inside a stuck episode (:func:`episodes`) the range channel repeats the last range it read before it."""
    stuck = episodes(scenario.n_steps, rng, rate=rate, mean_length=mean_length)[step_of_observations(scenario)]
    index = np.arange(stuck.size)
    last_good = np.maximum.accumulate(np.where(stuck, -1, index)) if stuck.size else index
    frozen = stuck & (last_good >= 0)
    ranges = scenario.obs_range.copy()
    ranges[frozen] = scenario.obs_range[last_good[frozen]]
    return replace(scenario, obs_range=ranges)


def delay_observations(scenario: Scenario, rng: np.random.Generator, *, delay: int) -> Scenario:
    """Step ``t`` delivers the observations made ``delay`` steps earlier (none in the first steps)."""
    source = np.arange(scenario.n_steps, dtype=np.int64) - int(delay)
    return gather_steps(scenario, np.where(source >= 0, source, -1))


def reorder_observations(scenario: Scenario, rng: np.random.Generator, *, p: float) -> Scenario:
    """The observation batches of steps ``2k`` and ``2k + 1`` arrive swapped, each pair with probability ``p``."""
    T = scenario.n_steps
    source = np.arange(T, dtype=np.int64)
    pairs = np.arange(0, T - 1, 2)
    swap = pairs[rng.random(pairs.size) < p]
    source[swap], source[swap + 1] = swap + 1, swap
    return gather_steps(scenario, source)


def quantise_ranges(scenario: Scenario, rng: np.random.Generator, *, step: float) -> Scenario:
    """Every range is rounded to the nearest multiple of ``step``."""
    return replace(scenario, obs_range=np.round(scenario.obs_range / step) * step)


def drift_range_bias(scenario: Scenario, rng: np.random.Generator, *, rate: float, walk: float) -> Scenario:
    """Ranges carry a bias ``rate * t`` plus a random walk of step deviation ``walk`` (clipped at 0 m)."""
    T = scenario.n_steps
    bias = rate * np.arange(1, T + 1) + np.cumsum(rng.normal(0.0, walk, size=T))
    return replace(scenario, obs_range=np.maximum(scenario.obs_range + bias[step_of_observations(scenario)], 0.0))


def scale_wheels(scenario: Scenario, rng: np.random.Generator, *, scale: float) -> Scenario:
    """Reported speeds ``v`` are multiplied by ``scale`` (turn rates unchanged)."""
    controls = scenario.controls.copy()
    controls[:, 0] *= scale
    return replace(scenario, controls=controls)


def slip_wheels(scenario: Scenario, rng: np.random.Generator, *, p: float, max_slip: float) -> Scenario:
    """In a step with probability ``p`` the wheels slip by a fraction ``s ~ U(0, max_slip)``: the odometer
    reports ``v / (1 - s)``."""
    T = scenario.n_steps
    slip = np.where(rng.random(T) < p, rng.uniform(0.0, max_slip, size=T), 0.0)
    controls = scenario.controls.copy()
    controls[:, 0] /= 1.0 - slip
    return replace(scenario, controls=controls)


def jitter_time_steps(scenario: Scenario, rng: np.random.Generator, *, sigma: float) -> Scenario:
    """The true interval of step ``t`` is ``1 + e_t`` with ``e_t ~ N(0, sigma)`` (clipped to [-0.9, 0.9]) but the
    SLAM integrates over the nominal step: both ``v`` and ``omega`` it is fed are off by the factor ``1 + e_t``."""
    factor = 1.0 + np.clip(rng.normal(0.0, sigma, size=scenario.n_steps), -0.9, 0.9)
    return replace(scenario, controls=scenario.controls * factor[:, None])


def reduce_particles(n: int, *, fraction: float) -> int:
    """``ceil(fraction * n)`` particles, at least 1."""
    return max(1, math.ceil(fraction * int(n)))


_SENSOR_ORIGIN = "paper Sec. IX (future work: hardware limitations or sensor faults)"

BUILTIN_SENSOR_FAULTS: tuple[SensorFault, ...] = (
    SensorFault(
        name="obs_dropout",
        description="each observation is lost independently (p = 0.2)",
        rationale="Range-bearing detections fail at random: occlusion, specular surfaces, a detector "
                  "threshold, dropped packets on the sensor bus. The SLAM sees fewer landmarks per step, so "
                  "its map converges more slowly; it must not treat a missing detection as evidence.",
        origin=_SENSOR_ORIGIN + "; Thrun et al., Probabilistic Robotics, Sec. 6.1 (measurement failures)",
        parameters=(("p", 0.2, ""),),
        perturbation=partial(drop_observations, p=0.2)),
    SensorFault(
        name="obs_burst_dropout",
        description="every observation is lost during bursts (start rate 0.02 per step, mean 10 steps)",
        rationale="A sensor goes blind for a while: a driver restart, a USB reset, sun glare, a dust cloud. "
                  "The SLAM dead-reckons through the burst and must re-associate afterwards; errors grow "
                  "with the burst length.",
        origin=_SENSOR_ORIGIN + "; Gilbert-Elliott burst-loss channel model",
        parameters=(("rate", 0.02, "1/step"), ("mean_length", 10.0, "steps")),
        perturbation=partial(drop_bursts, rate=0.02, mean_length=10.0)),
    SensorFault(
        name="stuck_range",
        description="the range channel freezes at its last value during episodes (rate 0.02 per step, mean 10 steps)",
        rationale="A stuck sensor repeats a stale reading (a frozen ADC, a driver serving its last buffer), "
                  "while the bearings still move. The SLAM receives plausible but wrong ranges; a filter "
                  "without outlier gating pulls its landmarks towards them.",
        origin=_SENSOR_ORIGIN + "; stuck-at faults in sensor fault-detection literature",
        parameters=(("rate", 0.02, "1/step"), ("mean_length", 10.0, "steps")),
        perturbation=partial(stick_ranges, rate=0.02, mean_length=10.0)),
    SensorFault(
        name="obs_delay",
        description="observations arrive one step late (latency 1 step)",
        rationale="Sensor latency not compensated by time stamps: processing or transport delay. The SLAM "
                  "fuses each observation at the pose one step after the one it was made from, which "
                  "biases landmarks along the path, most when driving fast or turning.",
        origin=_SENSOR_ORIGIN + "; sensor-to-odometry time offset (e.g. Furgale et al., IROS 2013)",
        parameters=(("delay", 1.0, "steps"),),
        perturbation=partial(delay_observations, delay=1),
        stochastic=False),
    SensorFault(
        name="obs_out_of_order",
        description="the observation batches of adjacent steps arrive swapped (p = 0.2 per pair)",
        rationale="Out-of-order delivery: several sensor threads or a network reorder messages and the "
                  "consumer fuses them on arrival. Each swapped batch is fused at a pose one step off.",
        origin=_SENSOR_ORIGIN + "; message reordering in publish-subscribe middleware (e.g. ROS)",
        parameters=(("p", 0.2, ""),),
        perturbation=partial(reorder_observations, p=0.2)),
    SensorFault(
        name="range_quantisation",
        description="ranges are rounded to multiples of 0.1 m",
        rationale="A low-resolution range sensor (or a fixed-point encoding) reports ranges on a grid "
                  "coarser than the noise the SLAM assumes, adding up to half a step of error that is "
                  "neither Gaussian nor in the model.",
        origin=_SENSOR_ORIGIN + "; quantisation noise, Widrow & Kollar, Quantization Noise (2008)",
        parameters=(("step", 0.1, "m"),),
        perturbation=partial(quantise_ranges, step=0.1),
        stochastic=False),
    SensorFault(
        name="range_bias_drift",
        description="ranges drift by 0.5 mm per step plus a random walk of 2 mm per step",
        rationale="A range bias that grows with temperature or ageing (thermal drift of a time-of-flight "
                  "sensor). The SLAM assumes unbiased ranges, so its landmarks move outwards with time.",
        origin=_SENSOR_ORIGIN + "; bias instability, IEEE Std 952 (random walk and rate ramp)",
        parameters=(("rate", 0.0005, "m/step"), ("walk", 0.002, "m/sqrt(step)")),
        perturbation=partial(drift_range_bias, rate=0.0005, walk=0.002)),
    SensorFault(
        name="wheel_scale",
        description="odometry speeds are 5 % too high (wheel-radius calibration error, scale 1.05)",
        rationale="A wrong wheel radius (tyre wear, pressure, load) scales every odometry distance. The "
                  "SLAM's motion model assumes unbiased noise, so the error accumulates until observations "
                  "correct it.",
        origin=_SENSOR_ORIGIN + "; Borenstein & Feng, UMBmark (1996): systematic odometry errors",
        parameters=(("scale", 1.05, ""),),
        perturbation=partial(scale_wheels, scale=1.05),
        stochastic=False),
    SensorFault(
        name="wheel_slip",
        description="in 10 % of the steps the wheels slip by up to 30 % (odometry over-reports v)",
        rationale="Wheel slip on loose or wet ground: the wheels turn but the vehicle moves less, so the "
                  "odometer over-reports the distance in that step. Non-systematic, heavy-tailed motion error.",
        origin=_SENSOR_ORIGIN + "; Borenstein & Feng, UMBmark (1996): non-systematic odometry errors",
        parameters=(("p", 0.1, ""), ("max_slip", 0.3, "")),
        perturbation=partial(slip_wheels, p=0.1, max_slip=0.3)),
    SensorFault(
        name="step_jitter",
        description="the true step interval jitters by 10 % (sigma 0.1) while the SLAM integrates the nominal step",
        rationale="Time-step jitter: a control loop on a loaded computer does not run at its nominal rate, "
                  "and a SLAM that integrates rates over the nominal interval moves its pose by the wrong "
                  "amount in both distance and heading.",
        origin=_SENSOR_ORIGIN + "; scheduling jitter on non-real-time operating systems",
        parameters=(("sigma", 0.1, ""),),
        perturbation=partial(jitter_time_steps, sigma=0.1)),
    SensorFault(
        name="particle_budget",
        description="a quarter of the configured particles (hardware limit: fraction 0.25)",
        rationale="A smaller on-board computer cannot afford the particle count the SLAM was tuned with. "
                  "Fewer particles mean more sample impoverishment and a larger map error; only SLAMs with "
                  "a particle option are affected (the fault does not apply to the others).",
        origin=_SENSOR_ORIGIN + "; Montemerlo et al., FastSLAM (2002): error against number of particles",
        parameters=(("fraction", 0.25, ""),),
        option="particles",
        configure=partial(reduce_particles, fraction=0.25),
        stochastic=False),
)
