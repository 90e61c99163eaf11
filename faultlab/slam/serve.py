"""Serve a Python SLAM over the process protocol, so that ``faultlab adapter check`` can judge it.

The process protocol (``docs/reference/process-protocol.md``) is how faultlab drives a SLAM written in
any language.  A SLAM written as a :class:`~faultlab.slam.protocol.SlamAdapter` in Python is normally
run in-process; :func:`serve` puts the same adapter behind the protocol (one JSON object per line on
stdin and stdout), so the conformance checks of :mod:`faultlab.slam.conformance` apply to it unchanged:

    python -m my_package          # whose __main__ calls serve(MySlam)
    faultlab adapter check python -m my_package

Each ``reset`` builds a fresh adapter from ``factory`` and resets it with a generator seeded by the
reset's ``seed`` (so the same seed gives the same estimate); each ``step`` calls
:meth:`~faultlab.slam.protocol.SlamAdapter.step`; ``estimate`` replies with the adapter's estimate.
Anything the adapter raises becomes an ``error`` reply naming the exception, never a traceback on
stdout.
"""

from __future__ import annotations

import json
import sys
from collections.abc import Callable
from typing import TextIO

import numpy as np

from faultlab.slam.process import PROTOCOL_VERSION, encode
from faultlab.slam.protocol import Estimate, Observations, SlamAdapter

__all__ = ["serve", "estimate_message"]


def estimate_message(est: Estimate) -> dict:
    """The ``estimate`` reply of ``est``: pose, ``[id, x, y]`` rows and, if the SLAM reports one, the trajectory."""
    reply = {"type": "estimate", "pose": np.asarray(est.pose, dtype=float).tolist(),
             "landmarks": [[int(i), float(x), float(y)]
                           for i, (x, y) in zip(np.asarray(est.landmark_ids).tolist(),
                                                np.asarray(est.landmarks, dtype=float).tolist())]}
    if est.trajectory is not None:
        reply["trajectory"] = np.asarray(est.trajectory, dtype=float).tolist()
    return reply


def _answer(request: dict, state: dict, factory: Callable[[], SlamAdapter]) -> dict | None:
    """The reply to one request (None for ``bye``); ``state`` holds the current adapter."""
    kind = request.get("type")
    if kind == "reset":
        if request.get("protocol") != PROTOCOL_VERSION:
            return {"type": "error", "message": f"protocol {request.get('protocol')!r} is not spoken here "
                                                f"(only {PROTOCOL_VERSION})"}
        slam = factory()
        slam.reset(np.asarray(request["pose"], dtype=float),
                   rng=np.random.default_rng(int(request["seed"])))
        state["slam"] = slam
        return {"type": "ready", "protocol": PROTOCOL_VERSION}
    slam = state.get("slam")
    if slam is None:
        return {"type": "error", "message": f"{kind!r} before any reset"}
    if kind == "step":
        slam.step(request["control"], Observations(request["ranges"], request["bearings"],
                                                   np.asarray(request["ids"], dtype=np.int64)))
        return {"type": "ack", "t": request["t"]}
    if kind == "estimate":
        return estimate_message(slam.estimate().validate(where=f"{slam.name} estimate"))
    return {"type": "error", "message": f"unknown request type {kind!r}"}


def serve(factory: Callable[[], SlamAdapter], *, stdin: TextIO | None = None, stdout: TextIO | None = None) -> int:
    """Answer process-protocol requests from ``stdin`` on ``stdout`` until ``bye`` or end of input; return 0.

    Parameters
    ----------
    factory : callable
        ``factory()`` returns a fresh :class:`~faultlab.slam.protocol.SlamAdapter` (called on every reset).
    stdin, stdout : text streams, optional
        Default: the process's own.
    """
    stdin = sys.stdin if stdin is None else stdin
    stdout = sys.stdout if stdout is None else stdout
    state: dict = {}
    for line in stdin:
        if not line.strip():
            continue
        try:
            request = json.loads(line)
            if not isinstance(request, dict):
                raise ValueError("a request must be a JSON object")
            if request.get("type") == "bye":
                return 0
            reply = _answer(request, state, factory)
        except Exception as exc:  # any failure of the SLAM is the peer's to record, not a crash of the server
            reply = {"type": "error", "message": f"{type(exc).__name__}: {exc}"}
        stdout.write(encode(reply) + "\n")
        stdout.flush()
    return 0
