"""Progress of long-running work: a tqdm bar on a terminal, log lines everywhere else.

tqdm draws a bar only when its stream is a terminal; in a CI log, under ``nohup`` or in a
pipe it stays silent, and a campaign of minutes would print nothing until it ends.
:func:`progress` keeps the bar on a terminal and otherwise writes one plain line each time
another tenth of the work is done (and at least every ``interval_s`` seconds while work
completes), with done/total, the counts the caller tracks (e.g. crashes and timeouts),
the elapsed time and an estimate of the time left::

    faultlab run: 180 jobs, 0 already done, 180 to run
    faultlab run: 18/180 jobs (10 %), 0 crash, 0 timeout, elapsed 19.8 s, ETA 2 min 58 s
    ...

>>> import io
>>> log = io.StringIO()                       # not a terminal
>>> with progress(4, desc="demo", stream=log) as p:
...     for _ in range(4):
...         p.update(1, crash=0)
>>> len(log.getvalue().splitlines())           # a start line and one line per job (4 < 10 steps)
5
"""

from __future__ import annotations

import contextlib
import math
import sys
import time
from typing import Callable, Iterator, Mapping, TextIO

from tqdm.auto import tqdm

__all__ = ["Progress", "progress", "format_duration"]


def format_duration(seconds: float) -> str:
    """``"12.3 s"``, ``"4 min 5 s"`` or ``"1 h 2 min 3 s"``; ``"?"`` for a missing or non-finite time."""
    if seconds is None or not math.isfinite(seconds):
        return "?"
    if seconds < 60:
        return f"{seconds:.1f} s"
    m, s = divmod(int(round(seconds)), 60)
    return f"{m} min {s} s" if m < 60 else f"{m // 60} h {m % 60} min {s} s"


def _is_terminal(stream) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):  # no isatty, or a closed stream
        return False


class Progress:
    """Handle yielded by :func:`progress`; the caller reports finished work through it.

    Attributes
    ----------
    total : int
        Units of work in all (including those done before).
    done : int
        Units done so far (including those done before).
    counts : dict
        The counts last passed to :meth:`update` (shown beside done/total).
    mode : {"bar", "log", "off"}
        How progress is shown.
    """

    def __init__(self, total: int, *, done: int, desc: str, unit: str, mode: str, stream: TextIO,
                 steps: int, interval_s: float, clock: Callable[[], float]):
        self.total, self.done, self.desc, self.unit, self.mode = total, done, desc, unit, mode
        self.counts: dict[str, int] = {}
        self._stream, self._steps, self._interval_s, self._clock = stream, steps, interval_s, clock
        self._initial = done
        self._start = self._last_time = clock()
        self._last_step = self._step(done)
        self._bar = None

    def _step(self, done: int) -> int:
        return math.floor(self._steps * done / self.total) if self.total > 0 else 0

    def _write(self, line: str) -> None:
        print(f"{self.desc}: {line}" if self.desc else line, file=self._stream, flush=True)

    def _start_line(self) -> None:
        self._write(f"{self.total} {self.unit}s, {self.done} already done, "
                    f"{self.total - self.done} to run")

    def line(self, now: float | None = None) -> str:
        """The state at time ``now`` (default: the clock's): done/total (percent), counts,
        elapsed time and time left (from the rate of the work done since the start)."""
        elapsed = (self._clock() if now is None else now) - self._start
        new = self.done - self._initial
        eta = elapsed / new * (self.total - self.done) if new > 0 else math.nan
        pct = 100 * self.done / self.total if self.total > 0 else 100.0
        parts = [f"{self.done}/{self.total} {self.unit}s ({pct:.0f} %)"]
        parts += [f"{v} {k}" for k, v in self.counts.items()]
        parts += [f"elapsed {format_duration(elapsed)}",
                  f"ETA {format_duration(eta) if math.isfinite(eta) else '?'}"]
        return ", ".join(parts)

    def update(self, n: int = 1, **counts: int) -> None:
        """Record ``n`` more units done and the current ``counts`` (e.g. ``crash=1, timeout=0``)."""
        self.done += n
        self.counts.update(counts)
        if self.mode == "bar":
            if counts:
                self._bar.set_postfix(self.counts, refresh=False)
            self._bar.update(n)
        elif self.mode == "log":
            step, now = self._step(self.done), self._clock()
            if step > self._last_step or now - self._last_time >= self._interval_s:
                self._last_step, self._last_time = step, now
                self._write(self.line(now))


@contextlib.contextmanager
def progress(total: int, *, done: int = 0, desc: str = "", unit: str = "job", enabled: bool = True,
             counts: Mapping[str, int] | None = None, stream: TextIO | None = None, steps: int = 10,
             interval_s: float = 60.0, clock: Callable[[], float] = time.monotonic) -> Iterator[Progress]:
    """Show the progress of ``total`` units of work while the block runs.

    On a terminal this is a tqdm bar.  Elsewhere one line goes to ``stream`` when the block
    starts and each time the work done crosses another ``1/steps`` of ``total`` (so at least
    ``steps`` lines for ``total >= steps`` units run from zero), or when ``interval_s``
    seconds have passed since the last line at the next update.  ``enabled=False`` shows
    nothing.

    Parameters
    ----------
    total : int
        Units of work in all.
    done : int
        Units already done before (a resumed run); they count towards the total, not the rate.
    desc, unit : str
        Label (``"faultlab run"``) and unit name (``"job"``; shown as ``"jobs"``).
    enabled : bool
        False: silent.
    counts : mapping, optional
        Initial counts shown beside done/total (e.g. ``{"crash": 0, "timeout": 0}``), in order.
    stream : text stream, optional
        Where to write; default ``sys.stderr`` at the time of the call.
    steps : int
        Log lines per complete run when not on a terminal (10: every 10 %).
    interval_s : float
        Longest time between log lines while work completes, s.
    clock : callable
        Monotonic time in seconds (injectable for tests).

    Yields
    ------
    Progress
        Call :meth:`Progress.update` as work finishes.
    """
    stream = sys.stderr if stream is None else stream
    mode = "off" if not enabled else ("bar" if _is_terminal(stream) else "log")
    p = Progress(total, done=done, desc=desc, unit=unit, mode=mode, stream=stream, steps=steps,
                 interval_s=interval_s, clock=clock)
    p.counts.update(counts or {})
    if mode == "bar":
        with tqdm(total=total, initial=done, unit=unit, desc=desc or None, file=stream,
                  dynamic_ncols=True) as bar:
            p._bar = bar
            if p.counts:
                bar.set_postfix(p.counts, refresh=False)
            yield p
        return
    if mode == "log":
        p._start_line()
    yield p
