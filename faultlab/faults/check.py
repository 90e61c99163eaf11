"""Equivalent-mutant check: does each fault change the SLAM's output at all?

A fault whose final estimate is bit-identical to the reference on a scenario
that exercises every unit is an *equivalent mutant* (mutation-testing
terminology): no test can ever detect it, so it must not count in detection
rates.  :func:`check_faults` runs every fault against the reference FastSLAM on
a small fixed scenario (:func:`check_scenario`) with fixed SLAM seeds and flags
such faults.  The experiment runner and the statistics should exclude a fault
flagged ``equivalent`` (or report it separately) instead of counting it as
"never detected".

Reference and faulty runs of one SLAM repetition start from the same seed, so
they share every random stream of the units the fault does not replace
(common random numbers by unit, :mod:`faultlab.slam.streams`): a difference in
the output comes from the fault, never from the filter drawing other random
numbers.  A fault that merely draws a different amount of randomness from its
own unit's stream still differs (its unit's later draws move).

Sensor faults (:class:`~faultlab.faults.sensor.SensorFault`) are checked like code faults: a stream
fault runs the unmodified reference on the stream it perturbs
(:func:`~faultlab.scenario.feed.fed_scenario`, as the campaign runner feeds it; the perturbation's
seed is drawn from the repetition's SeedSequence, the SLAM's generator is the reference's), a
hardware limit runs the reference built with its option changed
(:meth:`~faultlab.faults.sensor.SensorFault.configure_options`); either is compared with the
reference's estimate of the same seed.  A stream fault that leaves the stream unchanged on the check
scenario (e.g. a dropout that drew no drop) is reported ``equivalent`` like a code fault.

:func:`unit_outputs` is the unit-level counterpart (cosmic-ray style): it runs
the original and the faulty unit on a fault's :class:`UnitExample` inputs.
"""

from __future__ import annotations

import dataclasses
import enum
import math
from collections.abc import Iterable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from faultlab.errors import FaultError
from faultlab.faults.fault import Fault, UnitExample
from faultlab.faults.discovery import load_plugins
from faultlab.faults.registry import all_faults, resolve_fault
from faultlab.faults.sensor import SensorFault
from faultlab.metrics import map_errors
from faultlab.scenario import fixed_case_scenario
from faultlab.scenario.feed import fed_scenario
from faultlab.slam.fastslam import REFERENCE_STEPS, FastSlam, FastSlamConfig
from faultlab.slam.protocol import run_slam

__all__ = [
    "CheckStatus",
    "FaultCheck",
    "FaultCheckReport",
    "CHECK_CASE_OVERRIDES",
    "CHECK_N_STEPS",
    "check_scenario",
    "check_faults",
    "estimates_identical",
    "estimate_difference",
    "unit_outputs",
    "outputs_equal",
]

#: Changes to :data:`faultlab.space.case.FIXED_VALUES` for the check scenario: a small map (fast), a
#: +2 pi rotation error (every bearing and turn offset by 2 pi, Sec. V-2, so a missing angle wrap
#: matters) and an inactivity phase (empty updates, Sec. V-3, so naive resampling matters).
CHECK_CASE_OVERRIDES: dict[str, float | str] = {
    "map_size": 16.0,
    "rotation_error": 2.0 * math.pi,
    "inactivity": 100,
}

#: Active steps of the check scenario (the inactivity phase comes on top).
CHECK_N_STEPS = 300


class CheckStatus(enum.StrEnum):
    """Outcome of one fault in the equivalent-mutant check."""

    DIFFERS = "differs"  # final estimate differs from the reference (a killable mutant)
    EQUIVALENT = "equivalent"  # identical to the reference on every seed: exclude from detection rates
    CRASH = "crash"  # the faulty SLAM raised (detected trivially)


@dataclass(frozen=True)
class FaultCheck:
    """Result of running one fault against the reference.

    Attributes
    ----------
    name, step : str
        The fault and the unit it replaces.
    status : CheckStatus
    n_seeds : int
        SLAM seeds run.
    n_identical : int
        Seeds on which the final estimate was bit-identical to the reference.
    map_diff_m : float
        Mean over seeds of the RMS distance (m) between the faulty and the
        reference landmark estimates, over landmarks both mapped (NaN if none
        or on crash).  Unaligned: it measures how much the output moved, not
        the map error.
    pose_diff_m : float
        Mean over seeds of the distance (m) between the final pose estimates.
    n_map_mismatch : int
        Total over seeds of landmarks mapped by exactly one of the two.
    rms_mm : float
        Mean over seeds of the faulty SLAM's Kabsch-aligned map RMS error
        against the ground truth, mm (the detection metric, Sec. VII-B; NaN on crash).
    error : str
        The exception of a crashing fault ("" otherwise).
    """

    name: str
    step: str
    status: CheckStatus
    n_seeds: int
    n_identical: int
    map_diff_m: float
    pose_diff_m: float
    n_map_mismatch: int = 0
    rms_mm: float = math.nan
    error: str = ""

    @property
    def equivalent(self) -> bool:
        return self.status is CheckStatus.EQUIVALENT


@dataclass(frozen=True)
class FaultCheckReport(Sequence):
    """The checks of :func:`check_faults` (a sequence of :class:`FaultCheck`) plus context.

    Attributes
    ----------
    checks : tuple of FaultCheck
    scenario : str
        One-line description of the check scenario.
    seeds : tuple of int
        The SLAM repetitions k used; repetition k draws from ``SeedSequence([seed, 1, k])``,
        the same for the reference and every fault (hence the same per-unit random streams).
    plugin_errors : tuple of str
        Plugins that failed to load (their faults were not checked).
    reference_spread_m : float
        RMS distance (m) between the reference's landmark estimates of the first
        two SLAM repetitions (NaN with one repetition): the scale of seed-to-seed
        variation to read ``map_diff_m`` against.
    reference_rms_mm : float
        Mean over seeds of the reference's Kabsch-aligned map RMS error, mm.
    """

    checks: tuple[FaultCheck, ...]
    scenario: str = ""
    seeds: tuple[int, ...] = ()
    plugin_errors: tuple[str, ...] = ()
    reference_spread_m: float = math.nan
    reference_rms_mm: float = math.nan

    def __getitem__(self, i):
        return self.checks[i]

    def __len__(self) -> int:
        return len(self.checks)

    def __iter__(self) -> Iterator[FaultCheck]:
        return iter(self.checks)

    @property
    def equivalent(self) -> list[str]:
        """Names of the equivalent faults (to exclude from detection rates)."""
        return [c.name for c in self.checks if c.equivalent]

    @property
    def ok(self) -> bool:
        """No equivalent fault and no plugin load error."""
        return not self.equivalent and not self.plugin_errors

    def format(self) -> str:
        header = ("fault", "step", "status", "rms mm", "map diff mm", "pose diff mm", "identical")
        rows = [("baseline (reference)", "-", "-", _num(self.reference_rms_mm), "0.0", "0.0", "-")]
        rows += [(c.name, c.step, str(c.status), _num(c.rms_mm), _mm(c.map_diff_m), _mm(c.pose_diff_m),
                  f"{c.n_identical}/{c.n_seeds}") for c in self.checks]
        widths = [max(len(r[i]) for r in [header, *rows]) for i in range(len(header))]
        lines = [f"equivalent-mutant check on {self.scenario}; SLAM repetitions {list(self.seeds)}"]
        lines.append("rms mm: Kabsch-aligned map error vs. ground truth; map/pose diff: unaligned distance "
                     "of the final estimate from the reference's (same seed)")
        if np.isfinite(self.reference_spread_m):
            lines.append(f"reference seed-to-seed map diff: {_mm(self.reference_spread_m)} mm")
        for j, r in enumerate([header, *rows]):
            lines.append("  ".join(c.rjust(w) if i >= 3 else c.ljust(w)
                                   for i, (c, w) in enumerate(zip(r, widths))).rstrip())
            if j == 0:
                lines.append("  ".join("-" * w for w in widths))
        for c in self.checks:
            if c.error:
                lines.append(f"crash of {c.name}: {c.error}")
        for e in self.plugin_errors:
            lines.append(f"error: {e}")
        if self.equivalent:
            lines.append(f"EQUIVALENT (output identical to the reference; exclude from detection rates): "
                         f"{', '.join(self.equivalent)}")
        else:
            lines.append(f"all {len(self.checks)} faults change the output")
        return "\n".join(lines)

    def __str__(self) -> str:
        return self.format()


def _mm(x: float) -> str:
    return "-" if not np.isfinite(x) else f"{1000.0 * x:.1f}"


def _num(x: float) -> str:
    return "-" if not np.isfinite(x) else f"{x:.1f}"


def _rms_mm(scenario, estimate) -> float:
    try:
        return float(map_errors(scenario, estimate, metrics=("rms",)).rms_mm)
    except Exception:  # a malformed faulty estimate has no map error
        return math.nan


def check_scenario(*, seed: int = 0, n_steps: int = CHECK_N_STEPS):
    """The small fixed scenario of the check: FIXED_VALUES with :data:`CHECK_CASE_OVERRIDES`.

    Parameters
    ----------
    seed : int
        Entropy of the scenario's SeedSequence.
    n_steps : int
        Active steps.

    Returns
    -------
    faultlab.scenario.model.Scenario
    """
    return fixed_case_scenario(CHECK_CASE_OVERRIDES, seed=seed, n_steps=n_steps)


def estimates_identical(a, b) -> bool:
    """True if two :class:`~faultlab.slam.protocol.Estimate` are bit-identical (NaN == NaN)."""
    return (np.array_equal(np.asarray(a.pose), np.asarray(b.pose), equal_nan=True)
            and np.array_equal(np.asarray(a.landmark_ids), np.asarray(b.landmark_ids))
            and np.array_equal(np.asarray(a.landmarks), np.asarray(b.landmarks), equal_nan=True))


def estimate_difference(a, b) -> tuple[float, float, int]:
    """(landmark RMS distance m over common ids, pose distance m, landmarks mapped by only one)."""
    ids_a, ids_b = np.asarray(a.landmark_ids), np.asarray(b.landmark_ids)
    common, ia, ib = np.intersect1d(ids_a, ids_b, return_indices=True)
    if common.size:
        d = np.asarray(a.landmarks, float)[ia] - np.asarray(b.landmarks, float)[ib]
        rms = float(np.sqrt(np.mean(np.sum(d * d, axis=1))))
    else:
        rms = math.nan
    pose = float(np.hypot(*(np.asarray(a.pose, float)[:2] - np.asarray(b.pose, float)[:2])))
    mismatch = int(ids_a.size + ids_b.size - 2 * common.size)
    return rms, pose, mismatch


def _slam_seeds(seed: int, n_seeds: int) -> list[np.random.SeedSequence]:
    return [np.random.SeedSequence([seed, 1, k]) for k in range(n_seeds)]


def check_faults(
    faults: Iterable[Fault | str] | None = None,
    *,
    seed: int = 0,
    n_seeds: int = 2,
    scenario=None,
    n_steps: int | None = None,
    config=None,
    particles: int | None = None,
    plugins: bool = True,
) -> FaultCheckReport:
    """Run each fault against the reference and flag equivalent mutants.

    Parameters
    ----------
    faults : iterable of Fault or str, optional
        Faults (or names / ``module:attr`` specs); default: every built-in
        fault and, with ``plugins``, every plugin fault.
    seed : int
        Seed of the check scenario and of the SLAM runs.  Reference and faulty
        runs of seed k use the same ``SeedSequence([seed, 1, k])``.
    n_seeds : int
        SLAM repetitions per fault (a fault is equivalent only if identical on all).
    scenario : Scenario, optional
        Defaults to :func:`check_scenario` ``(seed=seed, n_steps=n_steps)``.
    n_steps : int, optional
        Active steps of the default scenario (default :data:`CHECK_N_STEPS`).
    config : FastSlamConfig, optional
        Defaults to ``FastSlamConfig()`` (the paper's 200 particles).
    particles : int, optional
        Overrides ``config.particles``.
    plugins : bool
        Include plugin faults when ``faults`` is None.

    Returns
    -------
    FaultCheckReport
        One :class:`FaultCheck` per fault, in input order.
    """
    if n_seeds < 1:
        raise FaultError(f"check_faults: n_seeds must be >= 1, got {n_seeds}")
    faults, plugin_errors = _faults_to_check(faults, plugins=plugins)
    scenario, origin = _scenario_to_check(scenario, seed=seed, n_steps=n_steps)
    config = FastSlamConfig() if config is None else config
    if particles is not None:
        config = dataclasses.replace(config, particles=particles)
    reference = FastSlam(config)
    seeds = _slam_seeds(seed, n_seeds)
    ref_estimates = [run_slam(reference, scenario, rng=np.random.default_rng(ss)) for ss in seeds]
    if not estimates_identical(run_slam(reference, scenario, rng=np.random.default_rng(seeds[0])),
                               ref_estimates[0]):
        raise FaultError("check_faults: the reference FastSLAM is not deterministic for a fixed seed; "
                         "the equivalence check is meaningless")
    checks = tuple(_check_one(_faulty(reference, config, fault), fault, scenario, seeds, ref_estimates)
                   for fault in faults)
    desc = (f"{origin}: {scenario.n_steps} steps, {scenario.landmarks.shape[0]} landmarks, "
            f"scenario seed {scenario.seed}, {config.particles} particles")
    spread = estimate_difference(ref_estimates[0], ref_estimates[1])[0] if n_seeds > 1 else math.nan
    ref_rms = _nanmean([_rms_mm(scenario, e) for e in ref_estimates])
    return FaultCheckReport(checks=checks, scenario=desc, seeds=tuple(range(n_seeds)),
                            plugin_errors=plugin_errors, reference_spread_m=spread, reference_rms_mm=ref_rms)


def _faults_to_check(faults, *, plugins: bool) -> tuple[list[Fault], tuple[str, ...]]:
    """The faults to check (default: all built-ins, plus plugins) and the plugin load errors."""
    plugin_errors: tuple[str, ...] = ()
    if faults is None:
        faults = all_faults(plugins=False)
        if plugins:
            report = load_plugins(warn=False)
            faults += list(report.items)
            plugin_errors = tuple(str(e) for e in report.errors)
    return [resolve_fault(f) for f in faults], plugin_errors


def _scenario_to_check(scenario, *, seed: int, n_steps: int | None):
    """The scenario of the check and a phrase saying where it comes from."""
    if scenario is None:
        scenario = check_scenario(seed=seed, n_steps=CHECK_N_STEPS if n_steps is None else n_steps)
        overrides = ", ".join(f"{k}={v:.6g}" for k, v in CHECK_CASE_OVERRIDES.items())
        return scenario, f"the check scenario (FIXED_VALUES with {overrides})"
    if n_steps is not None:
        raise FaultError("check_faults: give either scenario or n_steps, not both")
    return scenario, "the given scenario"


def _faulty(reference: FastSlam, config: FastSlamConfig, fault) -> FastSlam:
    """The reference with ``fault``: its unit replaced, or (a hardware limit) its option changed."""
    if isinstance(fault, SensorFault):
        return FastSlam(FastSlamConfig.from_options(fault.configure_options(config.to_options()),
                                                    where=f"sensor fault {fault.name!r}"))
    return fault.apply(reference)


def _perturbation_seed(ss: np.random.SeedSequence) -> int:
    """The integer seed a sensor fault's perturbation is keyed by in the repetition of ``ss``."""
    return int(ss.generate_state(1, dtype=np.uint64)[0])


def _check_one(faulty, fault: Fault, scenario, seeds, ref_estimates) -> FaultCheck:
    """Run ``faulty`` with every seed and compare each estimate with the reference's."""
    n_same, maps, poses, rms, mismatch, error = 0, [], [], [], 0, ""
    for ss, ref in zip(seeds, ref_estimates):
        try:
            fed = fed_scenario(fault, scenario, seed=_perturbation_seed(ss))
            with np.errstate(all="ignore"):  # a faulty SLAM may produce NaN on its way to a crash
                est = run_slam(faulty, fed, rng=np.random.default_rng(ss))
        except Exception as exc:  # a crash is an outcome (the runner records it as such)
            error = f"{type(exc).__name__}: {exc}"
            break
        n_same += estimates_identical(est, ref)
        m, p, k = estimate_difference(est, ref)
        maps.append(m)
        poses.append(p)
        rms.append(_rms_mm(scenario, est))
        mismatch += k
    if error:
        status = CheckStatus.CRASH
    elif n_same == len(seeds):
        status = CheckStatus.EQUIVALENT
    else:
        status = CheckStatus.DIFFERS
    return FaultCheck(name=fault.name, step=fault.step, status=status, n_seeds=len(seeds), n_identical=n_same,
                      map_diff_m=_nanmean(maps), pose_diff_m=_nanmean(poses), n_map_mismatch=mismatch,
                      rms_mm=_nanmean(rms) if not error else math.nan, error=error)


def _nanmean(values: list[float]) -> float:
    arr = np.asarray(values, dtype=float)
    arr = arr[np.isfinite(arr)]
    return float(arr.mean()) if arr.size else math.nan


# --------------------------------------------------------------------------- unit level

def unit_outputs(fault: Fault, example: UnitExample, steps=None) -> tuple[object, object]:
    """Outputs of the original and of the faulty unit on ``example``'s inputs.

    Parameters
    ----------
    fault : Fault
    example : UnitExample
        ``example.make_args()`` is called once per unit (fresh arrays and rng).
    steps : FastSlamSteps, optional
        Defaults to :data:`faultlab.slam.REFERENCE_STEPS`.

    Returns
    -------
    (original_output, faulty_output)
    """
    if steps is None:
        steps = REFERENCE_STEPS
    original = getattr(steps, fault.step)
    faulty = getattr(fault.patch(steps), fault.step)
    args, kwargs = example.make_args()
    out_original = original(*args, **kwargs)
    args, kwargs = example.make_args()
    out_faulty = faulty(*args, **kwargs)
    return out_original, out_faulty


def outputs_equal(a, b) -> bool:
    """Bitwise equality of nested unit outputs (arrays, tuples, dataclasses, scalars)."""
    if isinstance(a, (tuple, list)) and isinstance(b, (tuple, list)):
        return len(a) == len(b) and all(outputs_equal(x, y) for x, y in zip(a, b))
    if hasattr(a, "__dataclass_fields__") and type(a) is type(b):
        return all(outputs_equal(getattr(a, f), getattr(b, f)) for f in a.__dataclass_fields__)
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(outputs_equal(a[k], b[k]) for k in a)
    try:
        return bool(np.array_equal(np.asarray(a), np.asarray(b), equal_nan=True))
    except TypeError:
        return bool(np.array_equal(np.asarray(a), np.asarray(b)))
