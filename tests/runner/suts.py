"""SLAMs under test and faults for the runner's tests (importable by worker processes).

``TinySlam`` is a fast dead-reckoning mapper with a replaceable step table, so
faults (:class:`faultlab.faults.Fault`) apply to it exactly as to FastSlam.
The faults below make it crash, return NaN, hang, run slowly, or kill its
worker process; experiments name them by import path
(``"tests.runner.suts:CRASH"``).
"""

from __future__ import annotations

import dataclasses
import os
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np

from faultlab.faults import Fault
from faultlab.slam.protocol import Estimate, SlamAdapter

#: Prefix of the faults below as an experiment names them.
SUTS = "tests.runner.suts"
#: Upper bound of a "hang", so that a broken timeout fails a test instead of freezing it.
HANG_LIMIT_S = 60.0


def move(pose: np.ndarray, control: np.ndarray, noise: float, rng: np.random.Generator) -> np.ndarray:
    """Drive v along the heading, then turn omega; Gaussian noise of std ``noise`` on (v, omega)."""
    v, w = control + rng.normal(0.0, noise, 2)
    x, y, th = pose
    return np.array([x + v * np.cos(th), y + v * np.sin(th), th + w])


def place(pose: np.ndarray, ranges: np.ndarray, bearings: np.ndarray) -> np.ndarray:
    """Landmark positions (k, 2) seen from ``pose``."""
    a = pose[2] + bearings
    return np.column_stack([pose[0] + ranges * np.cos(a), pose[1] + ranges * np.sin(a)])


@dataclass(frozen=True)
class TinySteps:
    move: Callable = move
    place: Callable = place


class TinySlam(SlamAdapter):
    """Dead reckoning plus the mean observed position of each landmark (uses its rng: seeds matter)."""

    name = "tiny"

    def __init__(self, noise: float = 0.01, delay: float = 0.0, steps: TinySteps = TinySteps()):
        self.noise, self.delay, self.steps = float(noise), float(delay), steps

    def with_steps(self, steps: TinySteps) -> "TinySlam":
        return TinySlam(self.noise, self.delay, steps)

    def reset(self, pose, *, rng):
        self.pose = np.asarray(pose, dtype=float).copy()
        self.rng = rng
        self.sums: dict[int, np.ndarray] = {}
        self.counts: dict[int, int] = {}

    def update(self, control, observations):
        if self.delay:
            time.sleep(self.delay)
        self.pose = self.steps.move(self.pose, control, self.noise, self.rng)
        xy = self.steps.place(self.pose, observations.ranges, observations.bearings)
        for i, p in zip(observations.ids.tolist(), xy):
            self.sums[i] = self.sums.get(i, 0.0) + p
            self.counts[i] = self.counts.get(i, 0) + 1

    def estimate(self):
        ids = np.array(sorted(self.sums), dtype=np.int64)
        lm = np.array([self.sums[i] / self.counts[i] for i in ids.tolist()]).reshape(-1, 2)
        return Estimate(self.pose.copy(), ids, lm)


def make_tiny(noise: float = 0.01, delay: float = 0.0) -> TinySlam:
    """A factory (``[slam] name = "tests.runner.suts:make_tiny"``)."""
    return TinySlam(noise=noise, delay=delay)


# ------------------------------------------------------------------ faulty units
def _crashing(original):
    def crashing_move(pose, control, noise, rng):
        raise ZeroDivisionError("injected crash")
    return crashing_move


def _nan(original):
    def nan_move(pose, control, noise, rng):
        return original(pose, control, noise, rng) * np.nan
    return nan_move


def _hang(original):
    def hanging_move(pose, control, noise, rng):
        end = time.monotonic() + HANG_LIMIT_S
        while time.monotonic() < end:  # a pure-Python busy loop inside one step
            pass
        return original(pose, control, noise, rng)
    return hanging_move


def _swallow_hang(original):
    def stubborn_move(pose, control, noise, rng):
        end = time.monotonic() + HANG_LIMIT_S
        while time.monotonic() < end:
            try:
                time.sleep(0.01)
            except Exception:  # a SUT that eats exceptions must still be stopped
                pass
        return original(pose, control, noise, rng)
    return stubborn_move


def _spin_compiled(original):
    import numba

    @numba.njit(cache=False)
    def spin(x):  # xorshift never reaches 0 from a non-zero state: an endless loop holding the GIL
        x = np.uint64(x)
        while x != np.uint64(0):
            x ^= x << np.uint64(13)
            x ^= x >> np.uint64(7)
            x ^= x << np.uint64(17)
        return x

    def spinning_move(pose, control, noise, rng):
        spin(88172645463325252)  # only a kill from outside the worker ends it
        return original(pose, control, noise, rng)
    return spinning_move


def _slow(original):
    def slow_move(pose, control, noise, rng):
        time.sleep(0.05)  # short steps: the cooperative deadline check stops it between steps
        return original(pose, control, noise, rng)
    return slow_move


def _exit(original):
    def exiting_move(pose, control, noise, rng):
        os._exit(3)  # kills the worker process
    return exiting_move


def _segfault(original):
    def segfaulting_move(pose, control, noise, rng):
        import ctypes
        ctypes.string_at(0)  # reads address 0: SIGSEGV
    return segfaulting_move


def _bias(original):
    def biased_move(pose, control, noise, rng):
        return original(pose, control + np.array([0.02, 0.0]), noise, rng)
    return biased_move


def _unbuildable(original):
    raise ValueError("cannot wrap this unit")


def _fault(name: str, replacement, description: str) -> Fault:
    return Fault(name=name, step="move", description=description, rationale="Test double for the runner.",
                 origin="tests/runner/suts.py", replacement=replacement)


CRASH = _fault("tiny_crash", _crashing, "raises ZeroDivisionError")
NAN = _fault("tiny_nan", _nan, "returns a NaN pose")
HANG = _fault("tiny_hang", _hang, "busy-loops for a minute inside one step")
STUBBORN = _fault("tiny_stubborn", _swallow_hang, "sleeps for a minute and swallows exceptions")
SPIN = _fault("tiny_spin", _spin_compiled, "spins for ever in a numba loop that holds the GIL")
SLOW = _fault("tiny_slow", _slow, "sleeps 50 ms per step")
EXIT = _fault("tiny_exit", _exit, "kills its process with os._exit(3)")
SEGV = _fault("tiny_segv", _segfault, "dies of SIGSEGV")
BIAS = _fault("tiny_bias", _bias, "adds 2 cm to every forward motion")
UNBUILDABLE = _fault("tiny_unbuildable", _unbuildable, "its replacement factory fails")

assert dataclasses.is_dataclass(TinySteps)


def _identity(original):
    def same_move(pose, control, noise, rng):
        return original(pose, control, noise, rng)
    return same_move


#: Behaves exactly like the baseline: with common random numbers its rows equal the baseline's.
IDENTITY = _fault("tiny_identity", _identity, "calls the original unit unchanged")


# ------------------------------------------------------------------ faults of the reference FastSLAM
# FastSlam runs the repetitions of a (case, variant) as one batched job; these faults make some of
# the repetitions fail in ways the batch can or cannot attribute to one repetition.

def _unlucky_resample(original):
    def resample(w, n_eff, empty, rng, config):
        idx = original(w, n_eff, empty, rng, config)
        if idx is not None and rng.random() < 0.02:  # depends on the repetition's own stream
            raise RuntimeError("unlucky draw")
        return idx
    return resample


def _raise_if_far(original):
    def predict_measurement(poses, mu):
        # sees the particles of every repetition of a batch at once: a batch cannot tell whose
        if np.any(np.abs(np.asarray(poses)[:, :2]) > 0.9):
            raise FloatingPointError("far from the start")
        return original(poses, mu)
    return predict_measurement


def _hang_motion(original):
    def motion_model(poses, u, *, wrap):
        end = time.monotonic() + HANG_LIMIT_S
        while time.monotonic() < end:
            pass
        return original(poses, u, wrap=wrap)
    return motion_model


def _exit_controls(original):
    def sample_controls(u, n, rng, config):
        os._exit(3)
    return sample_controls


def _fs_fault(name: str, step: str, replacement, description: str) -> Fault:
    return Fault(name=name, step=step, description=description, rationale="Test double for the runner.",
                 origin="tests/runner/suts.py", replacement=replacement)


FS_UNLUCKY = _fs_fault("fs_unlucky", "resample", _unlucky_resample,
                       "raises in some repetitions, from the repetition's resampling stream")
FS_FAR = _fs_fault("fs_far", "predict_measurement", _raise_if_far,
                   "raises once a particle is 0.9 m from the origin (a unit that sees the whole batch)")
FS_HANG = _fs_fault("fs_hang", "motion_model", _hang_motion, "busy-loops for a minute")
FS_EXIT = _fs_fault("fs_exit", "sample_controls", _exit_controls, "kills its process with os._exit(3)")


# ------------------------------------------------------------------ experiment files
def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, str):
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    return repr(v)


def to_toml(data: dict) -> str:
    """Minimal TOML writer for experiment mappings (scalars, lists, nested tables)."""
    lines, tables = [], []

    def emit(prefix: str, table: dict) -> None:
        scalars = {k: v for k, v in table.items() if not isinstance(v, dict)}
        subs = {k: v for k, v in table.items() if isinstance(v, dict)}
        if prefix:
            tables.append(f"\n[{prefix}]")
        for k, v in scalars.items():
            (tables if prefix else lines).append(f"{k} = {_toml_value(v)}")
        for k, v in subs.items():
            emit(f"{prefix}.{k}" if prefix else k, v)

    emit("", data)
    return "\n".join(lines + tables) + "\n"


#: Parameter-space overrides with small maps and short idle phases: fast test cases.
SMALL_SPACE = {
    "map_size": {"classes": {"small": [4, 9], "medium": [9, 16], "large": [16, 25]}},
    "landmark_density": {"classes": {"low": [1, 2], "medium": [2, 4], "high": [4, 6]}},
    "inactivity": {"classes": {"none": 0, "inactive": 30}},
}


def tiny_experiment(**overrides) -> dict:
    """A small TinySlam experiment mapping: 2 runs x (random 2, fixed 1) x 2 variants x K=2 = 24 jobs."""
    data = {
        "seed": 11,
        "runs": 2,
        "n_steps": 40,
        "variants": ["baseline", "tests.runner.suts:BIAS"],
        "repetitions": 2,
        "timeout_s": 300.0,
        "suites": {"random": 2, "fixed": 1},
        "slam": {"name": "tests.runner.suts:make_tiny", "options": {"noise": 0.02}},
        "space": SMALL_SPACE,
    }
    for k, v in overrides.items():
        if v is None:
            data.pop(k, None)
        else:
            data[k] = v
    return data


def write_experiment(path, **overrides):
    """Write :func:`tiny_experiment` (with overrides) to ``path``; returns the path."""
    from pathlib import Path

    path = Path(path)
    path.write_text(to_toml(tiny_experiment(**overrides)))
    return path


def without_runtime(df):
    """``df`` without ``runtime_s``, the one column that differs between runs of the same jobs."""
    return df.drop(columns=["runtime_s"])


def one_case(**kw):
    """Overrides of :func:`tiny_experiment` for one random case, one repetition."""
    base = dict(runs=1, suites={"random": 1}, repetitions=1)
    base.update(kw)
    return base


def fastslam_batches(tmp_path, **overrides):
    """A small FastSLAM experiment whose repetitions run in batches (with overrides); returns its path."""
    data = dict(runs=1, n_steps=40, repetitions=3, timeout_s=300.0, suites={"random": 1, "fixed": 1},
                variants=["baseline", "missing_angle_wrap", f"{SUTS}:FS_UNLUCKY", f"{SUTS}:FS_FAR"],
                slam={"name": "fastslam", "particles": 12})
    data.update(overrides)
    return write_experiment(tmp_path / "batches.toml", **data)
