"""Conformance of a process SLAM (:mod:`faultlab.slam.process`): the protocol's edge cases, each pass or fail.

``faultlab adapter check CMD...`` runs :func:`check_program`.  Every check starts the program afresh
(as a campaign does for every execution), drives it through a small noise-free scene and checks
the replies against the protocol's rules (:data:`faultlab.slam.process.RULES`) and the estimate
against the truth.  The scenes are exact (controls and observations without noise), so any SLAM
should recover them; the comparison allows :data:`TOLERANCE_M` (m) and :data:`TOLERANCE_RAD` (rad)
for filters that sample.  A failing check says what went wrong and what to change.

Checks (:data:`CHECKS`, in order):

``empty-run``
    reset, then estimate at once: the start pose and an empty map.
``empty-steps``
    steps without observations between steps with observations (empty ``ranges``/``bearings``/``ids``).
``zero-observations``
    a whole run without a single observation: the odometry pose and ``"landmarks": []``.
``inactivity``
    many steps with control (0, 0) re-observing the same landmarks: the pose stays put.
``rotation-offsets``
    a start heading far outside [-pi, pi), bearings offset by multiples of 2 pi, full turns: headings
    are angles, compared modulo 2 pi; landmarks land at the truth.
``large-map``
    3000 landmarks with non-consecutive ids beyond 32 bits observed in one step: all mapped, ids kept.
``trajectory``
    the empty-steps scene again: an estimate without ``trajectory`` passes (it is optional); one
    with it must hold the pose after every step, each within the tolerances of the truth.
``same-seed``
    two executions with the same seed give the same estimate (one process each).
``protocol-version``
    a reset with an unknown protocol version is answered by an ``error`` reply, not ``ready``.
``exit-on-bye``
    after ``bye`` the program exits with status 0 within the reply timeout.
``exit-on-eof``
    after a reset, when its stdin closes, the program exits with status 0 within the reply timeout.
"""

from __future__ import annotations

import math
import shlex
import subprocess
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from faultlab.errors import SlamProcessError
from faultlab.slam.process import (PROTOCOL_VERSION, ProcessSlam, ProcessSlamConfig, Program, describe_status,
                                   encode, parse_reply, reset_message)
from faultlab.slam.protocol import Estimate, Observations

__all__ = ["CheckResult", "ConformanceReport", "CHECKS", "check_program", "TOLERANCE_M", "TOLERANCE_RAD"]

#: Position error allowed between a check's estimate and its exact truth, m.
TOLERANCE_M = 0.05
#: Heading error allowed (modulo 2 pi), rad.
TOLERANCE_RAD = 0.01
#: Landmarks of the ``large-map`` check.
LARGE_MAP = 3000
#: First landmark id of the ``large-map`` check: beyond 32 bits (ids are integers below 2**53 in magnitude).
LARGE_ID = 2 ** 33 + 7


@dataclass(frozen=True)
class CheckResult:
    """One check: its name, whether it passed, and (on failure) what to fix."""

    name: str
    passed: bool
    message: str = ""


@dataclass(frozen=True)
class ConformanceReport:
    """Every check's result for one program."""

    command: tuple[str, ...]
    results: tuple[CheckResult, ...]
    #: Checks not run because an earlier one timed out (a program that stops replying is not waited for again).
    not_run: tuple[str, ...] = ()

    @property
    def passed(self) -> bool:
        return all(r.passed for r in self.results) and not self.not_run

    def format(self) -> str:
        lines = [f"protocol {PROTOCOL_VERSION} conformance of {shlex.join(self.command)}"]
        for r in self.results:
            lines.append(f"  {'pass' if r.passed else 'FAIL'}  {r.name}" + ("" if r.passed else f": {r.message}"))
        if self.not_run:
            lines.append(f"  not run (the program stopped replying in time): {', '.join(self.not_run)}")
        n_fail = sum(not r.passed for r in self.results)
        lines.append(f"{len(self.results) - n_fail} of {len(CHECKS)} checks passed"
                     + ("" if not n_fail else f"; {n_fail} failed") + (f", {len(self.not_run)} not run"
                                                                       if self.not_run else ""))
        return "\n".join(lines)


class _Mismatch(Exception):
    """A check's estimate differs from the truth (the message says how and what to fix)."""


@dataclass(frozen=True)
class _Scene:
    """An exact run: start pose, controls (T, 2), per step the observed landmark ids, the landmarks."""

    start: np.ndarray
    controls: np.ndarray
    seen: tuple[np.ndarray, ...]
    landmark_ids: np.ndarray
    landmarks: np.ndarray
    bearing_offset: float = 0.0

    def poses(self) -> np.ndarray:
        """Poses (T + 1, 3) by the motion model (drive, then turn), headings unwrapped."""
        p = [self.start.astype(float)]
        for v, w in self.controls:
            x, y, th = p[-1]
            p.append(np.array([x + v * math.cos(th), y + v * math.sin(th), th + w]))
        return np.array(p)

    def observations(self, t: int, pose: np.ndarray) -> Observations:
        ids = self.seen[t]
        rows = np.searchsorted(self.landmark_ids, ids)
        d = self.landmarks[rows] - pose[:2]
        r = np.hypot(d[:, 0], d[:, 1])
        b = np.arctan2(d[:, 1], d[:, 0]) - pose[2] + self.bearing_offset
        return Observations(r, b, ids)

    def mapped(self) -> np.ndarray:
        """Ids of the landmarks observed at least once, sorted."""
        return np.unique(np.concatenate([np.empty(0, dtype=np.int64), *self.seen]))


def _drive(slam: ProcessSlam, scene: _Scene, *, seed: int) -> Estimate:
    poses = scene.poses()
    slam.reset(scene.start, rng=np.random.default_rng(seed))
    for t, u in enumerate(scene.controls):
        slam.step(u, scene.observations(t, poses[t + 1]))
    return slam.estimate()


def _compare(est: Estimate, scene: _Scene, *, what: str) -> None:
    truth = scene.poses()[-1]
    pose = np.asarray(est.pose, dtype=float)
    if np.hypot(*(pose[:2] - truth[:2])) > TOLERANCE_M:
        raise _Mismatch(f"{what}: estimated position {pose[:2].round(4).tolist()} is more than {TOLERANCE_M} m "
                        f"from the true {truth[:2].round(4).tolist()}; integrate each control as drive v along "
                        f"the heading, then turn by omega")
    dth = (pose[2] - truth[2] + math.pi) % (2 * math.pi) - math.pi
    if abs(dth) > TOLERANCE_RAD:
        raise _Mismatch(f"{what}: estimated heading {pose[2]:.4f} rad differs from the true {truth[2]:.4f} rad by "
                        f"{dth:.4f} rad modulo 2 pi; treat headings and bearings as angles (any multiple of 2 pi "
                        f"may be added)")
    expected = scene.mapped()
    ids = np.asarray(est.landmark_ids)
    if not np.array_equal(np.sort(ids), expected):
        missing = np.setdiff1d(expected, ids)
        extra = np.setdiff1d(ids, expected)
        raise _Mismatch(f"{what}: the map has {ids.size} landmarks, expected the {expected.size} observed ones"
                        + (f"; missing ids {missing[:5].tolist()}" if missing.size else "")
                        + (f"; unobserved ids {extra[:5].tolist()}" if extra.size else "")
                        + "; map exactly the observed landmarks under the ids the observations carry")
    if ids.size:
        rows = np.searchsorted(scene.landmark_ids, ids)
        err = np.hypot(*(np.asarray(est.landmarks) - scene.landmarks[rows]).T)
        worst = int(np.argmax(err))
        if err[worst] > TOLERANCE_M:
            raise _Mismatch(f"{what}: landmark {int(ids[worst])} is {err[worst]:.4f} m from its true position "
                            f"(allowed {TOLERANCE_M} m); place a landmark at pose + range * (cos, sin)(heading "
                            f"+ bearing)")


def _ring(n: int, *, radius: float, first_id: int = 0, step_id: int = 1) -> tuple[np.ndarray, np.ndarray]:
    a = np.linspace(0, 2 * np.pi, n, endpoint=False)
    ids = first_id + step_id * np.arange(n, dtype=np.int64)
    return ids, np.stack([radius * np.cos(a), radius * np.sin(a)], axis=1)


def _scene_empty_steps() -> _Scene:
    ids, xy = _ring(8, radius=3.0)
    T = 20
    seen = tuple(ids[t % 8:t % 8 + 2] if t % 3 == 0 else np.empty(0, dtype=np.int64) for t in range(T))
    return _Scene(np.array([0.5, -0.2, 0.3]), np.tile([0.1, 0.05], (T, 1)), seen, ids, xy)


def _scene_zero_observations() -> _Scene:
    ids, xy = _ring(4, radius=3.0)
    T = 15
    return _Scene(np.array([0.0, 0.0, -1.0]), np.tile([0.2, -0.1], (T, 1)),
                  tuple(np.empty(0, dtype=np.int64) for _ in range(T)), ids, xy)


def _scene_inactivity() -> _Scene:
    ids, xy = _ring(5, radius=2.0, first_id=10)
    T = 60
    controls = np.zeros((T, 2))
    controls[:5] = [0.1, 0.0]
    return _Scene(np.array([1.0, 1.0, 0.0]), controls, tuple(ids for _ in range(T)), ids, xy)


def _scene_rotation() -> _Scene:
    ids, xy = _ring(6, radius=2.5, first_id=100)
    T = 40
    controls = np.tile([0.05, 2 * np.pi / 10], (T, 1))  # four full turns
    seen = tuple(ids[[t % 6, (t + 3) % 6]] for t in range(T))
    return _Scene(np.array([0.2, 0.1, 3 * np.pi / 4 + 4 * np.pi]), controls, seen, ids, xy,
                  bearing_offset=-6 * np.pi)


def _scene_large_map() -> _Scene:
    ids, xy = _ring(LARGE_MAP, radius=20.0, first_id=LARGE_ID, step_id=7919)
    controls = np.array([[0.0, 0.0], [0.1, 0.0]])
    return _Scene(np.array([0.0, 0.0, 0.0]), controls, (ids, np.empty(0, dtype=np.int64)), ids, xy)


def _scene_check(scene: Callable[[], _Scene], what: str) -> Callable[[ProcessSlamConfig], None]:
    def run(config: ProcessSlamConfig) -> None:
        slam = ProcessSlam(config)
        try:
            s = scene()
            _compare(_drive(slam, s, seed=1), s, what=what)
        finally:
            slam.close()
    return run


def _check_empty_run(config: ProcessSlamConfig) -> None:
    ids, xy = _ring(3, radius=1.0)
    s = _Scene(np.array([0.3, -0.4, 2.0]), np.empty((0, 2)), (), ids, xy)
    slam = ProcessSlam(config)
    try:
        _compare(_drive(slam, s, seed=1), s, what="estimate right after reset")
    finally:
        slam.close()


def _check_trajectory(config: ProcessSlamConfig) -> None:
    s = _scene_empty_steps()
    slam = ProcessSlam(config)
    try:
        est = _drive(slam, s, seed=1)  # a malformed trajectory fails here, naming its rule
    finally:
        slam.close()
    if est.trajectory is None:
        return
    truth = s.poses()[1:]
    traj = np.asarray(est.trajectory, dtype=float)
    dist = np.hypot(*(traj[:, :2] - truth[:, :2]).T)
    dth = np.abs((traj[:, 2] - truth[:, 2] + math.pi) % (2 * math.pi) - math.pi)
    bad = np.flatnonzero((dist > TOLERANCE_M) | (dth > TOLERANCE_RAD))
    if bad.size:
        t = int(bad[0])
        raise _Mismatch(f"trajectory[{t}] = {traj[t].round(4).tolist()} is not the true pose after step {t}, "
                        f"{truth[t].round(4).tolist()} (allowed {TOLERANCE_M} m, {TOLERANCE_RAD} rad); row t of "
                        f"\"trajectory\" is the pose after step t (the start pose is not repeated)")


def _check_same_seed(config: ProcessSlamConfig) -> None:
    s = _scene_empty_steps()
    out = []
    for _ in range(2):
        slam = ProcessSlam(config)
        try:
            out.append(_drive(slam, s, seed=12345))
        finally:
            slam.close()
    a, b = out
    same = (np.array_equal(a.pose, b.pose) and np.array_equal(np.sort(a.landmark_ids), np.sort(b.landmark_ids))
            and np.array_equal(a.landmarks[np.argsort(a.landmark_ids)], b.landmarks[np.argsort(b.landmark_ids)]))
    if not same:
        raise _Mismatch("two executions with seed 12345 gave different estimates; draw all randomness from a "
                        "generator seeded with the reset's \"seed\" and nothing else (no clock, no address)")


def _check_version(config: ProcessSlamConfig) -> None:
    child = Program(config)
    try:
        deadline = time.monotonic() + config.reply_timeout_s
        child.send(encode({"type": "reset", "protocol": 999, "pose": [0.0, 0.0, 0.0], "seed": 1}),
                   deadline=deadline, what="reset with protocol 999")
        line = child.receive(deadline=deadline, what="reset with protocol 999")
        try:
            reply = parse_reply(line, where="reset with protocol 999")
        except SlamProcessError as exc:
            if exc.rule == "error-reply":
                return
            raise
        raise _Mismatch(f"a reset with protocol 999 was answered with type {reply.get('type')!r}; reply "
                        f"{{\"type\":\"error\",\"message\":...}} to a protocol version the program does not speak")
    finally:
        child.close()


def _check_bye(config: ProcessSlamConfig) -> None:
    slam = ProcessSlam(config)
    s = _scene_zero_observations()
    _drive(slam, s, seed=1)
    code = slam.close(timeout_s=config.reply_timeout_s)
    if code != 0:
        ended = "no exit in time" if code is None else describe_status(code)
        raise _Mismatch(f"after bye the program ended with {ended}; "
                        f"exit with status 0 on {{\"type\":\"bye\"}} (and when stdin closes)")


def _check_eof(config: ProcessSlamConfig) -> None:
    child = Program(config)
    try:
        deadline = time.monotonic() + config.reply_timeout_s
        child.send(reset_message([0.0, 0.0, 0.0], seed=1), deadline=deadline, what="reset")
        child.receive(deadline=deadline, what="reset")
        child.proc.stdin.close()
        try:
            code = child.proc.wait(timeout=config.reply_timeout_s)
        except subprocess.TimeoutExpired:
            code = None
    finally:
        child.close()
    if code != 0:
        raise _Mismatch(f"when its stdin closed the program ended with "
                        f"{'no exit in time' if code is None else describe_status(code)}; exit with status 0 "
                        f"at the end of input (faultlab closes stdin of a program it abandons)")


#: The checks by name, in the order they run.
CHECKS: dict[str, Callable[[ProcessSlamConfig], None]] = {
    "empty-run": _check_empty_run,
    "empty-steps": _scene_check(_scene_empty_steps, "steps without observations among steps with some"),
    "zero-observations": _scene_check(_scene_zero_observations, "a run without any observation"),
    "inactivity": _scene_check(_scene_inactivity, "60 steps, 55 of them with control (0, 0)"),
    "rotation-offsets": _scene_check(_scene_rotation, "start heading 4.75 pi, bearings offset by -6 pi, four "
                                                      "full turns"),
    "large-map": _scene_check(_scene_large_map, f"{LARGE_MAP} landmarks with ids from 2**33 + 7 in one step"),
    "trajectory": _check_trajectory,
    "same-seed": _check_same_seed,
    "protocol-version": _check_version,
    "exit-on-bye": _check_bye,
    "exit-on-eof": _check_eof,
}


#: The rules of a program that did not reply in time: the checks after it are not run.
_TIMEOUT_RULES = ("reply-timeout", "execution-timeout")


def _check_start(config: ProcessSlamConfig) -> None:
    """Start the program and reset it once (the start of every check)."""
    slam = ProcessSlam(config)
    try:
        slam.reset(np.zeros(3), rng=np.random.default_rng(1))
    finally:
        slam.close()


def check_program(command: Sequence[str], *, env: Sequence[tuple[str, str]] = (), reply_timeout_s: float = 10.0,
                  execution_timeout_s: float = 60.0) -> ConformanceReport:
    """Run every check of :data:`CHECKS` against the program ``command``.

    The program is first started and reset once; if that fails (it does not exist, exits, or does not
    answer the reset within ``reply_timeout_s``), no check can run and one error says why.  A check
    that times out ends the run: the checks after it are reported as not run, so the whole check takes
    at most one start, the checks that answered, and one timeout.

    Parameters
    ----------
    command : sequence of str
        The program and its arguments.
    env : sequence of (str, str)
        Extra environment variables.
    reply_timeout_s, execution_timeout_s : float
        The limits of :class:`~faultlab.slam.process.ProcessSlamConfig`; a slower program fails the check.

    Returns
    -------
    ConformanceReport

    Raises
    ------
    SlamProcessError
        The program cannot be started and reset.
    """
    config = ProcessSlamConfig(command=tuple(command), env=tuple(env), reply_timeout_s=reply_timeout_s,
                               execution_timeout_s=execution_timeout_s)
    try:
        _check_start(config)
    except SlamProcessError as exc:
        raise SlamProcessError(f"{exc}; no check was run (each starts the program and resets it)",
                               rule=exc.rule, detail=exc.detail) from None
    results = []
    names = list(CHECKS)
    for i, name in enumerate(names):
        try:
            CHECKS[name](config)
        except (SlamProcessError, _Mismatch) as exc:
            results.append(CheckResult(name, False, str(exc)))
            if getattr(exc, "rule", None) in _TIMEOUT_RULES:
                return ConformanceReport(tuple(command), tuple(results), not_run=tuple(names[i + 1:]))
        else:
            results.append(CheckResult(name, True))
    return ConformanceReport(tuple(command), tuple(results))
