"""A SLAM in any language, run as a child process speaking line-delimited JSON on stdin/stdout.

The protocol (version :data:`PROTOCOL_VERSION`, documented in ``docs/reference/process-protocol.md``)
has four requests, one JSON object per line, each answered by one line (``bye`` excepted):

=============================================================  ==================================================
request                                                        reply
=============================================================  ==================================================
``{"type":"reset","protocol":1,"pose":[x,y,th],"seed":s}``     ``{"type":"ready","protocol":1}``
``{"type":"step","t":k,"control":[v,w],"ranges":[...],``        ``{"type":"ack","t":k}``
``"bearings":[...],"ids":[...]}``
``{"type":"estimate"}``                                        ``{"type":"estimate","pose":[x,y,th],``
                                                               ``"landmarks":[[id,x,y],...]}``, optionally
                                                               with ``"trajectory":[[x,y,th],...]`` and
                                                               ``"covariance":[[...],...]``
``{"type":"bye"}``                                             none; the program exits with status 0
=============================================================  ==================================================

The optional ``trajectory`` of an estimate holds one pose per step sent since the reset, in step
order: row ``t`` is the pose after step ``t`` (it becomes :attr:`Estimate.trajectory
<faultlab.slam.protocol.Estimate>`; without it the job's absolute trajectory error is NaN).
The optional ``covariance`` is the covariance of the final state, a list of ``3 + 2M`` rows of
``3 + 2M`` numbers: the pose (x, y, theta) first, then each landmark's (x, y) in the order of
``landmarks``; finite, symmetric and positive semi-definite to rounding (it becomes
:attr:`Estimate.covariance <faultlab.slam.protocol.Estimate>`, judged by the consistency oracle of
``faultlab check``).

Any request may instead be answered by ``{"type":"error","message":"..."}``.  Units are SI (m, rad);
``seed`` is an integer in [0, 2**53) drawn from the execution's generator, so it is exact in any
JSON reader.

:class:`ProcessSlam` starts a fresh process at every :meth:`~ProcessSlam.reset` (one per execution),
waits at most ``reply_timeout_s`` for each reply and at most ``execution_timeout_s`` from the reset,
and turns every failure -- a reply that breaks the protocol, an ``error`` reply, a timeout, the
process's death -- into a :class:`~faultlab.errors.SlamProcessError` whose message holds the exit
status and the tail of the program's stderr (which the runner records in the job's ``crash`` row).

Every program runs in a session and process group of its own, and faultlab stops the whole group
(SIGKILL) when an execution fails, times out or ends: a program behind a wrapper (``sh -c``, ``env``,
``conda run``) leaves no descendant behind.  A process that runs programs also starts one small
*reaper* (:func:`watched`): a Python process in its own session that holds the read end of a pipe
from it and the list of its live program groups; when the pipe closes -- whatever ended the
process, SIGKILL and the OOM killer included -- the reaper kills those groups.  (A program that
starts a session of its own, such as a daemon, leaves faultlab's reach.)
"""

from __future__ import annotations

import json
import math
import os
import selectors
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import weakref
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Iterator

import numpy as np

from faultlab.config import check_number
from faultlab.errors import ConfigError, SlamProcessError
from faultlab.slam.protocol import (Estimate, Observations, SlamAdapter, as_start_pose, check_generator,
                                      covariance_problem)

__all__ = ["PROTOCOL_VERSION", "RULES", "ProcessSlamConfig", "ProcessSlam", "Program", "ReplyRule", "transcript",
           "draw_seed", "reset_message", "step_message", "estimate_from_reply", "encode", "parse_reply",
           "describe_status", "watched", "kill_group",
           "STDERR_TAIL"]

#: Version of the protocol spoken by :class:`ProcessSlam`, sent in every ``reset``.
PROTOCOL_VERSION = 1

#: Characters of the program's stderr kept in a failure message (its end).
STDERR_TAIL = 2000

#: Upper bound (exclusive) of the ``seed`` of a reset: integers below it are exact as JSON doubles.
SEED_BOUND = 2 ** 53


@dataclass(frozen=True)
class ReplyRule:
    """A rule of the protocol a reply can break: its name (reported by ``faultlab adapter check``) and text."""

    name: str
    text: str


#: The protocol's rules for replies, by name; every :class:`SlamProcessError` about a reply names one.
RULES: dict[str, ReplyRule] = {r.name: r for r in (
    ReplyRule("one-json-object-per-line", "every reply is one JSON object on one line, and nothing else is "
                                          "written to stdout (diagnostics go to stderr)"),
    ReplyRule("reply-type", "a reply's \"type\" answers the request: ready to reset, ack to step, estimate to "
                            "estimate (or error)"),
    ReplyRule("ready-protocol", "the ready reply carries \"protocol\": the version given in the reset"),
    ReplyRule("ack-step", "the ack of a step carries the step's \"t\""),
    ReplyRule("estimate-pose", "an estimate's \"pose\" is [x, y, theta], three finite numbers"),
    ReplyRule("estimate-landmarks", "an estimate's \"landmarks\" is a list of [id, x, y] with an integer id "
                                    "(unique) and finite x, y"),
    ReplyRule("estimate-trajectory", "an estimate's \"trajectory\", if present, is a list of [x, y, theta] (three "
                                     "finite numbers), one per step since the reset: the pose after each step"),
    ReplyRule("estimate-covariance", "an estimate's \"covariance\", if present, is 3 + 2M rows of 3 + 2M finite "
                                     "numbers (pose, then each landmark in the order of \"landmarks\"), symmetric "
                                     "and positive semi-definite"),
    ReplyRule("reply-timeout", "every request is answered within reply_timeout_s"),
    ReplyRule("execution-timeout", "an execution (reset to estimate) ends within execution_timeout_s"),
    ReplyRule("stays-alive", "the program keeps running until it is sent bye (or its stdin closes)"),
    ReplyRule("error-reply", "the program answers every valid request without an error reply"),
)}


@dataclass(frozen=True)
class ProcessSlamConfig:
    """Settings of ``[slam] name = "process"``.

    Attributes
    ----------
    command : tuple of str
        The program and its arguments (the file gives a list, or one string split like a shell's words).
    reply_timeout_s : float
        Longest wait for one reply, s (> 0).
    execution_timeout_s : float
        Longest execution from reset to estimate, s (> 0); in a campaign the experiment's
        ``timeout_s`` applies as well (and is recorded as ``timeout``, this one as ``crash``).
    env : tuple of (str, str)
        Environment variables set for the program, on top of faultlab's environment.
    """

    command: tuple[str, ...] = ()
    reply_timeout_s: float = 10.0
    execution_timeout_s: float = 3600.0
    env: tuple[tuple[str, str], ...] = ()

    KEYS = ("command", "reply_timeout_s", "execution_timeout_s", "env")

    def __post_init__(self) -> None:
        for name in ("reply_timeout_s", "execution_timeout_s"):
            object.__setattr__(self, name, check_number(getattr(self, name), name=f"slam.{name}", positive=True))

    @classmethod
    def from_options(cls, options: Mapping[str, Any], *, where: str | None = None) -> "ProcessSlamConfig":
        where = where or "slam"
        unknown = [k for k in options if k not in cls.KEYS]
        if unknown:
            raise ConfigError(f"{where}.{unknown[0]} is not a known key (known: {', '.join(cls.KEYS)})")
        if "command" not in options:
            raise ConfigError(f"{where}.command is required: the program to run and its arguments")
        command = options["command"]
        if isinstance(command, str):
            command = shlex.split(command)
        if (not isinstance(command, (list, tuple)) or not command
                or not all(isinstance(w, str) and w for w in command)):
            raise ConfigError(f"{where}.command must be a non-empty list of strings (or one string), got "
                              f"{options['command']!r}")
        env = options.get("env", {})
        if isinstance(env, (list, tuple)):
            env = dict(env)
        if not isinstance(env, Mapping) or not all(isinstance(k, str) and isinstance(v, str)
                                                   for k, v in env.items()):
            raise ConfigError(f"{where}.env must be a table of strings, got {env!r}")
        kwargs = {k: options[k] for k in ("reply_timeout_s", "execution_timeout_s") if k in options}
        try:
            return cls(command=tuple(command), env=tuple(sorted(env.items())), **kwargs)
        except ConfigError as exc:
            raise ConfigError(f"{where}: {exc}") from exc

    def to_options(self) -> dict[str, Any]:
        out: dict[str, Any] = {"command": list(self.command), "reply_timeout_s": self.reply_timeout_s,
                               "execution_timeout_s": self.execution_timeout_s}
        if self.env:
            out["env"] = dict(self.env)
        return out


# ------------------------------------------------------------------ messages
def encode(message: dict) -> str:
    """One protocol line (no newline): compact JSON, no NaN."""
    return json.dumps(message, separators=(",", ":"), allow_nan=False)


def draw_seed(rng: np.random.Generator) -> int:
    """The ``seed`` a reset sends: one integer in [0, :data:`SEED_BOUND`) drawn from the execution's ``rng``."""
    return int(rng.integers(0, SEED_BOUND))


def reset_message(pose, *, seed: int) -> str:
    """The ``reset`` line (no newline) for start pose ``pose`` (3,) and integer ``seed``."""
    p = as_start_pose(pose, where="process SLAM reset")
    return encode({"type": "reset", "protocol": PROTOCOL_VERSION, "pose": p.tolist(), "seed": int(seed)})


def step_message(t: int, control, observations: Observations) -> str:
    """The ``step`` line (no newline) of step ``t``: control (2,) and the step's observations."""
    return encode({"type": "step", "t": int(t), "control": np.asarray(control, dtype=float).tolist(),
                  "ranges": observations.ranges.tolist(), "bearings": observations.bearings.tolist(),
                  "ids": observations.ids.tolist()})


def transcript(scenario, *, seed: int) -> Iterator[str]:
    """Every request of one execution of ``scenario`` (a :class:`~faultlab.scenario.model.Scenario`), as lines.

    ``reset``, one ``step`` per step, ``estimate``, ``bye``: exactly what :func:`~faultlab.slam.run_slam`
    sends a :class:`ProcessSlam` given a generator ``rng`` with ``draw_seed(rng) == seed``.  A program run on
    these lines (``program < case.jsonl``) prints its estimate as its last line.
    """
    yield reset_message(scenario.start_pose, seed=seed)
    off = scenario.obs_offsets
    for t in range(scenario.n_steps):
        a, b = int(off[t]), int(off[t + 1])
        obs = Observations(scenario.obs_range[a:b], scenario.obs_bearing[a:b], scenario.obs_ids[a:b])
        yield step_message(t, scenario.controls[t], obs)
    yield encode({"type": "estimate"})
    yield encode({"type": "bye"})


def _broken(rule: str, detail: str, *, where: str) -> SlamProcessError:
    return SlamProcessError(f"{where}: {detail} (rule {rule}: {RULES[rule].text})", rule=rule, detail=detail)


def estimate_from_reply(line: str, *, where: str = "process SLAM", n_steps: int | None = None) -> Estimate:
    """The :class:`Estimate` of an ``estimate`` reply line; :class:`SlamProcessError` naming the broken rule.

    ``n_steps``: the steps sent since the reset, the length an optional ``trajectory`` must have
    (None: any length).
    """
    reply = parse_reply(line, where=where)
    _expect_type(reply, "estimate", where=where)
    pose = reply.get("pose")
    if (not isinstance(pose, list) or len(pose) != 3
            or not all(_is_number(x) and math.isfinite(x) for x in pose)):
        raise _broken("estimate-pose", f"estimate pose is {_short(pose)}", where=where)
    rows = reply.get("landmarks")
    if not isinstance(rows, list):
        raise _broken("estimate-landmarks", f"estimate landmarks is {_short(rows)}", where=where)
    for i, row in enumerate(rows):
        if (not isinstance(row, list) or len(row) != 3 or not isinstance(row[0], int) or isinstance(row[0], bool)
                or not all(_is_number(x) and math.isfinite(x) for x in row[1:])):
            raise _broken("estimate-landmarks", f"estimate landmarks[{i}] is {_short(row)}", where=where)
    ids = np.array([r[0] for r in rows], dtype=np.int64)
    if np.unique(ids).size != ids.size:
        raise _broken("estimate-landmarks", "estimate has duplicate landmark ids", where=where)
    xy = np.array([r[1:] for r in rows], dtype=float).reshape(len(rows), 2)
    return Estimate(np.array(pose, dtype=float), ids, xy, trajectory=_trajectory(reply, n_steps, where=where),
                    covariance=_covariance(reply, ids.size, where=where))


def _covariance(reply: dict, n_landmarks: int, *, where: str) -> np.ndarray | None:
    """The covariance of an estimate reply (None if it has none), checked against its rule."""
    if "covariance" not in reply:
        return None
    rows = reply["covariance"]
    if (not isinstance(rows, list) or not all(isinstance(r, list) for r in rows)
            or not all(_is_number(x) for r in rows for x in r)):
        raise _broken("estimate-covariance", f"estimate covariance is {_short(rows)}", where=where)
    dim = 3 + 2 * n_landmarks
    if len(rows) != dim or any(len(r) != dim for r in rows):
        raise _broken("estimate-covariance", f"estimate covariance is not {dim} rows of {dim} numbers "
                                             f"({n_landmarks} landmarks)", where=where)
    cov = np.array(rows, dtype=float).reshape(dim, dim)
    problem = covariance_problem(cov, dim)
    if problem:
        raise _broken("estimate-covariance", f"estimate covariance {problem}", where=where)
    return cov


def _trajectory(reply: dict, n_steps: int | None, *, where: str) -> np.ndarray | None:
    """The (T, 3) ``trajectory`` of an estimate reply (None if it has none), checked against its rule."""
    if "trajectory" not in reply:
        return None
    rows = reply["trajectory"]
    if not isinstance(rows, list):
        raise _broken("estimate-trajectory", f"estimate trajectory is {_short(rows)}", where=where)
    for i, row in enumerate(rows):
        if (not isinstance(row, list) or len(row) != 3
                or not all(_is_number(x) and math.isfinite(x) for x in row)):
            raise _broken("estimate-trajectory", f"estimate trajectory[{i}] is {_short(row)}", where=where)
    if n_steps is not None and len(rows) != n_steps:
        raise _broken("estimate-trajectory", f"estimate trajectory has {len(rows)} poses after {n_steps} steps",
                      where=where)
    return np.array(rows, dtype=float).reshape(len(rows), 3)


def _is_number(x) -> bool:
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _short(value, n: int = 80) -> str:
    text = json.dumps(value) if not isinstance(value, str) else repr(value)
    return text if len(text) <= n else text[:n] + "..."


def parse_reply(line: str, *, where: str) -> dict:
    """A reply line as a dict; :class:`SlamProcessError` if it is no JSON object or an ``error`` reply."""
    try:
        reply = json.loads(line)
    except ValueError:
        raise _broken("one-json-object-per-line", f"reply is not JSON: {_short(line)}", where=where) from None
    if not isinstance(reply, dict):
        raise _broken("one-json-object-per-line", f"reply is not a JSON object: {_short(line)}", where=where)
    if reply.get("type") == "error":
        raise _broken("error-reply", f"the program replied with an error: {_short(reply.get('message'), 300)}",
                      where=where)
    return reply


def _expect_type(reply: dict, kind: str, *, where: str) -> None:
    if reply.get("type") != kind:
        raise _broken("reply-type", f"expected a {kind!r} reply, got type {_short(reply.get('type'))}",
                      where=where)


# ------------------------------------------------------------------ the reaper
_REAPER = r"""
import os, signal, sys
for s in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
    signal.signal(s, signal.SIG_IGN)
groups = set()
for line in sys.stdin.buffer:
    if line[:1] == b"+":
        groups.add(int(line[1:]))
    elif line[:1] == b"-":
        groups.discard(int(line[1:]))
for g in groups:
    try:
        os.killpg(g, signal.SIGKILL)
    except OSError:
        pass
"""


class _Reaper:
    """This process's reaper (module docstring): told of every program group started and stopped."""

    def __init__(self) -> None:
        self.owner = os.getpid()
        self.proc = subprocess.Popen([sys.executable, "-I", "-S", "-c", _REAPER], stdin=subprocess.PIPE,
                                     stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                     start_new_session=True, bufsize=0)
        self.lock = threading.Lock()

    def tell(self, line: str) -> None:
        with self.lock:
            try:
                self.proc.stdin.write(line.encode())
            except (OSError, ValueError):  # the reaper is gone: the groups are still killed by close()
                pass


_reaper: _Reaper | None = None
_reaper_lock = threading.Lock()


def watched(pgid: int, *, live: bool = True) -> None:
    """Tell this process's reaper (started on first use) that group ``pgid`` is live (or gone)."""
    global _reaper
    with _reaper_lock:
        if _reaper is None or _reaper.owner != os.getpid() or _reaper.proc.poll() is not None:
            _reaper = _Reaper()
        reaper = _reaper
    reaper.tell(f"{'+' if live else '-'}{pgid}\n")


def kill_group(proc: subprocess.Popen) -> None:
    """SIGKILL the process group led by ``proc`` (its own, see :class:`Program`), then reap ``proc``."""
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except OSError:  # the group is gone
        pass
    if proc.poll() is None:
        proc.kill()
    proc.wait()
    watched(proc.pid, live=False)


# ------------------------------------------------------------------ the child process
def describe_status(code: int | None) -> str:
    """``"exit status 3"``, ``"killed by SIGKILL"`` or ``"still running (...)"`` for a Popen return code."""
    if code is None:
        return "still running (then stopped by faultlab)"
    if code < 0:
        try:
            return f"killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"killed by signal {-code}"
    return f"exit status {code}"


class Program:
    """One running program (started by the constructor).

    Writes request lines, reads reply lines with a deadline, keeps the program's stderr in a temporary file.
    """

    def __init__(self, config: ProcessSlamConfig):
        self.label = shlex.join(config.command)
        self.stderr = tempfile.TemporaryFile()
        env = {**os.environ, **dict(config.env)}
        try:
            self.proc = subprocess.Popen(list(config.command), stdin=subprocess.PIPE, stdout=subprocess.PIPE,
                                         stderr=self.stderr, env=env, bufsize=0, start_new_session=True)
        except OSError as exc:
            self.stderr.close()
            raise SlamProcessError(f"process SLAM {self.label}: cannot start it ({exc.strerror or exc})") from None
        watched(self.proc.pid)
        os.set_blocking(self.proc.stdin.fileno(), False)
        self.buffer = bytearray()
        self._finalizer = weakref.finalize(self, _stop, self.proc, self.stderr)

    def stderr_tail(self) -> str:
        self.stderr.flush()
        size = self.stderr.seek(0, os.SEEK_END)
        self.stderr.seek(max(0, size - 4 * STDERR_TAIL))
        text = self.stderr.read().decode("utf-8", "replace")
        return text[-STDERR_TAIL:].strip()

    def failure(self, what: str, *, rule: str | None = None, wait_s: float = 1.0) -> SlamProcessError:
        """Stop the program and describe it: ``what``, exit status, stderr tail."""
        try:
            self.proc.wait(timeout=wait_s)
        except subprocess.TimeoutExpired:
            pass
        status = describe_status(self.proc.poll())
        _kill(self.proc)
        tail = self.stderr_tail()
        self.close()
        text = f"process SLAM {self.label}: {what}"
        if rule is not None:
            text += f" (rule {rule}: {RULES[rule].text})"
        text += f"; {status}; stderr: " + (tail.replace("\n", " | ") if tail else "(empty)")
        return SlamProcessError(text, rule=rule, detail=what)

    def send(self, line: str, *, deadline: float, what: str, rule: str = "reply-timeout") -> None:
        data = memoryview((line + "\n").encode())
        fd = self.proc.stdin.fileno()
        with selectors.DefaultSelector() as sel:
            sel.register(fd, selectors.EVENT_WRITE)
            while data:
                left = deadline - time.monotonic()
                if left <= 0 or not sel.select(left):
                    raise self.failure(f"did not read {what} in time", rule=rule, wait_s=0)
                try:
                    n = os.write(fd, data)
                except BrokenPipeError:
                    raise self.failure(f"died before reading {what}", rule="stays-alive") from None
                except BlockingIOError:
                    continue
                data = data[n:]

    def receive(self, *, deadline: float, what: str, rule: str = "reply-timeout") -> str:
        fd = self.proc.stdout.fileno()
        with selectors.DefaultSelector() as sel:
            sel.register(fd, selectors.EVENT_READ)
            while b"\n" not in self.buffer:
                left = deadline - time.monotonic()
                if left <= 0 or not sel.select(left):
                    raise self.failure(f"no reply to {what} in time", rule=rule, wait_s=0)
                chunk = os.read(fd, 1 << 16)
                if not chunk:
                    try:
                        self.proc.wait(timeout=1.0)
                    except subprocess.TimeoutExpired:
                        pass
                    ended = "died" if self.proc.poll() is not None else "closed its output"
                    raise self.failure(f"{ended} while answering {what}", rule="stays-alive", wait_s=0)
                self.buffer += chunk
        i = self.buffer.index(b"\n")
        line = bytes(self.buffer[:i]).decode("utf-8", "replace")
        del self.buffer[:i + 1]
        return line

    def bye(self, *, timeout_s: float) -> int | None:
        """Send ``bye`` and wait for the exit; its return code (None if it did not exit in time: killed)."""
        try:
            self.send(encode({"type": "bye"}), deadline=time.monotonic() + timeout_s, what="bye")
        except SlamProcessError:
            return self.proc.poll()
        try:
            return self.proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            return None
        finally:
            self.close()

    def close(self) -> None:
        """Kill the program if it still runs, reap it, release its pipes and stderr file."""
        _kill(self.proc)
        self._finalizer.detach()
        _close_pipes(self.proc)
        self.stderr.close()


def _kill(proc: subprocess.Popen) -> None:
    """Stop the program's whole group (a wrapper's descendants too), even if the program itself has exited."""
    if proc.returncode is None or not getattr(proc, "_group_killed", False):
        kill_group(proc)
        proc._group_killed = True


def _close_pipes(proc: subprocess.Popen) -> None:
    for pipe in (proc.stdin, proc.stdout):
        try:
            pipe.close()
        except OSError:
            pass


def _stop(proc: subprocess.Popen, stderr) -> None:
    """Finaliser of an abandoned program: close its stdin, give it a moment, kill it."""
    try:
        proc.stdin.close()
    except OSError:
        pass
    try:
        proc.wait(timeout=0.5)
    except subprocess.TimeoutExpired:
        pass
    _kill(proc)
    _close_pipes(proc)
    stderr.close()


class ProcessSlam(SlamAdapter):
    """A SLAM program run as a child process (module docstring), one fresh process per execution.

    Parameters
    ----------
    config : ProcessSlamConfig
    """

    name = "process"

    def __init__(self, config: ProcessSlamConfig):
        if not isinstance(config, ProcessSlamConfig):
            raise ConfigError(f"ProcessSlam: config must be a ProcessSlamConfig, got {type(config).__name__}")
        if not config.command:
            raise ConfigError("ProcessSlam: config.command is empty")
        self._config = config
        self._child: Program | None = None
        self._t = 0
        self._deadline = math.inf

    @property
    def config(self) -> ProcessSlamConfig:
        return self._config

    @property
    def pid(self) -> int | None:
        """The running program's process id (None before the first reset or after a failure)."""
        return None if self._child is None else self._child.proc.pid

    def _request(self, line: str, *, what: str) -> str:
        child = self._child
        now = time.monotonic()
        rule = "reply-timeout"
        deadline = now + self._config.reply_timeout_s
        if self._deadline < deadline:
            deadline, rule = self._deadline, "execution-timeout"
        try:
            child.send(line, deadline=deadline, what=what, rule=rule)  # the deadline's own rule
            return child.receive(deadline=deadline, what=what, rule=rule)
        except SlamProcessError:
            self._child = None
            raise
        except BaseException:  # e.g. the runner's wall-clock alarm: never leave the program running
            self._child = None
            child.close()
            raise

    def _fail(self, exc: SlamProcessError) -> SlamProcessError:
        """A protocol violation found in a reply: stop the program and add its status and stderr."""
        child, self._child = self._child, None
        return child.failure(exc.detail, rule=exc.rule, wait_s=0)

    def reset(self, pose: np.ndarray, *, rng: np.random.Generator) -> None:
        check_generator(rng, where=self.name)
        line = reset_message(pose, seed=draw_seed(rng))
        self.close()
        self._child = Program(self._config)
        self._t = 0
        self._deadline = time.monotonic() + self._config.execution_timeout_s
        reply = self._request(line, what="reset")
        try:
            parsed = parse_reply(reply, where=self.name)
            _expect_type(parsed, "ready", where=self.name)
            if parsed.get("protocol") != PROTOCOL_VERSION:
                raise _broken("ready-protocol", f"ready reply has protocol {_short(parsed.get('protocol'))}, "
                                                f"expected {PROTOCOL_VERSION}", where=self.name)
        except SlamProcessError as exc:
            raise self._fail(exc) from None

    def update(self, control: np.ndarray, observations: Observations) -> None:
        if self._child is None:
            raise SlamProcessError(f"process SLAM {shlex.join(self._config.command)}: step before reset "
                                   f"(or after the program failed)")
        t = self._t
        reply = self._request(step_message(t, control, observations), what=f"step {t}")
        try:
            parsed = parse_reply(reply, where=self.name)
            _expect_type(parsed, "ack", where=self.name)
            if parsed.get("t") != t:
                raise _broken("ack-step", f"ack of step {t} has t = {_short(parsed.get('t'))}", where=self.name)
        except SlamProcessError as exc:
            raise self._fail(exc) from None
        self._t = t + 1

    def estimate(self) -> Estimate:
        if self._child is None:
            raise SlamProcessError(f"process SLAM {shlex.join(self._config.command)}: estimate before reset "
                                   f"(or after the program failed)")
        reply = self._request(encode({"type": "estimate"}), what="estimate")
        try:
            return estimate_from_reply(reply, where=self.name, n_steps=self._t)
        except SlamProcessError as exc:
            raise self._fail(exc) from None

    def check_startable(self, *, where: str) -> None:
        """ConfigError unless the command's program is an executable file (a path, or found on ``PATH``).

        Called before a campaign, so that a program that cannot start is refused once instead of
        failing every job; ``where`` names the setting for the message.
        """
        program = self._config.command[0]
        path = {**os.environ, **dict(self._config.env)}.get("PATH", os.defpath)
        if shutil.which(program, path=path) is None:
            what = "no executable file" if os.sep in program else "not found on PATH (or not executable)"
            raise ConfigError(f"{where}: the program {program!r} cannot be started: {what}")

    def close(self, *, timeout_s: float = 1.0) -> int | None:
        """Send ``bye`` to the running program and wait for it to exit; its return code (None if none ran
        or it had to be killed)."""
        child, self._child = self._child, None
        return None if child is None else child.bye(timeout_s=timeout_s)
