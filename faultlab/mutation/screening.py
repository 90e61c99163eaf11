"""Pre-campaign screening of mutants at the unit level: stillborn, equivalent and duplicate mutants.

A SLAM run costs about a second; a unit call costs microseconds.  Before a campaign runs every
mutant on every test case, each mutant's unit is called on the unit examples
(:mod:`faultlab.mutation.examples`) and classified:

* **stillborn** -- the mutated function does not compile, or the unit raises on *every* example
  (a mutant that crashes only on some inputs is live: a campaign may or may not reach them);
* **equivalent** -- the mutated function compiles to the same bytecode as the original (same
  instructions, constants by type and value, names; nested code recursively: e.g. ``2 + 2`` ->
  ``2 * 2`` folds to the same constant), or its outputs *and* its arguments after the call (a
  unit must not modify its inputs; a random generator's state shows how many numbers it drew)
  are bit-identical to the original's on every example, under the same random draws;
* **nondeterministic** -- the outputs differ when the buffers the unit takes from ``np.empty``
  start with a different fill (NaN, then :data:`~faultlab.mutation.source.ALTERNATE_POISON`) on
  some example: in a campaign they would depend on whatever the memory held, so such a mutant is
  reported and never run (or scored);
* **duplicate** -- bit-identical outputs and arguments to an earlier mutant of the same unit on
  every example (including raising the same exception type on the same examples): the mutants
  are grouped and only the first (in generation order) runs.

Every other mutant is *live* and goes to the campaign.  Equivalence on examples is evidence, not
proof: inputs the examples do not contain (a non-diagonal ``Q``, say) could tell a mutant apart,
which is why the examples are recorded from real runs.  "Bit-identical" treats ``-0.0`` as
``0.0`` and all NaNs as one value, as :func:`numpy.array_equal` with ``equal_nan`` does.

Units are built with :data:`~faultlab.mutation.source.POISONED_NUMPY`: arrays from ``np.empty``
start as NaN, so a mutant that leaves part of an output unwritten is classified the same way on
every run instead of by whatever the memory held; each mutant then runs once more against
:data:`~faultlab.mutation.source.ALTERNATE_POISONED_NUMPY` to find the nondeterministic ones.
"""

from __future__ import annotations

import contextlib
import dataclasses
import hashlib
import signal
import threading
import time
import warnings
from collections import Counter
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, field

import numpy as np

from faultlab.errors import FaultError
from faultlab.faults.fault import UnitExample
from faultlab.mutation.mutant import Mutant, MutantSet
from faultlab.mutation.outcome import SCREENED_OUT, MutantOutcome
from faultlab.mutation.source import UnitSource, code_identical

__all__ = ["Screening", "ScreeningReport", "screen_mutants", "unit_fingerprint", "EXAMPLE_TIME_LIMIT_S"]

#: Wall-clock limit of one unit call during screening (a mutant stuck in a loop counts as raising).
EXAMPLE_TIME_LIMIT_S = 10.0


@dataclass(frozen=True)
class Screening:
    """The screening result of one mutant.

    Attributes
    ----------
    mutant : str
        The mutant id.
    outcome : MutantOutcome or None
        STILLBORN, EQUIVALENT, DUPLICATE or NONDETERMINISTIC; None for a live mutant (it runs in a campaign).
    reason : str
        One line: why (the compile error, the exception, "identical bytecode", the examples
        on which it differs...).
    duplicate_of : str or None
        For a duplicate: the id of the mutant that runs in its place.
    """

    mutant: str
    outcome: MutantOutcome | None
    reason: str
    duplicate_of: str | None = None

    @property
    def live(self) -> bool:
        return self.outcome is None

    @property
    def label(self) -> str:
        """The outcome's value, or ``"live"``."""
        return "live" if self.outcome is None else str(self.outcome)


@dataclass(frozen=True, eq=False)
class ScreeningReport:
    """The mutants of a steps table with their screening results.

    Attributes
    ----------
    mutants : MutantSet
    results : dict
        Mutant id -> :class:`Screening`, in generation order.
    n_examples : dict
        Unit name -> number of unit examples its mutants ran on.
    seconds : float
        Wall-clock time of the screening.
    """

    mutants: MutantSet
    results: dict[str, Screening]
    n_examples: dict[str, int] = field(default_factory=dict)
    seconds: float = 0.0

    def __getitem__(self, mutant_id: str) -> Screening:
        return self.results[self.mutants.get(mutant_id).id]

    def live(self) -> tuple[Mutant, ...]:
        """The mutants that go to a campaign (not screened out)."""
        return tuple(m for m in self.mutants if self.results[m.id].live)

    def members(self, mutant_id: str) -> tuple[str, ...]:
        """The ids of the duplicates that ``mutant_id`` runs for."""
        return tuple(s.mutant for s in self.results.values() if s.duplicate_of == mutant_id)

    def counts(self, mutants: Iterable[Mutant] | None = None) -> dict[str, int]:
        """``live`` and each screened-out class -> number of mutants (of ``mutants``)."""
        chosen = self.mutants if mutants is None else mutants
        c = Counter(self.results[m.id].label for m in chosen)
        return {label: c.get(label, 0) for label in ("live", *map(str, SCREENED_OUT))}


# --------------------------------------------------------------------------- fingerprints

def _feed(h, value, depth: int = 0) -> None:
    """Feed a canonical byte form of a unit's output (or argument) into hash ``h``."""
    if depth > 20:
        h.update(b"<deep>")
        return
    if value is None or isinstance(value, (bool, str, bytes)):
        h.update(f"{type(value).__name__}:{value!r};".encode())
    elif isinstance(value, (int, float, complex, np.generic)) and not isinstance(value, np.void):
        _feed(h, np.asarray(value), depth + 1)
    elif isinstance(value, np.ndarray):
        a = value
        h.update(f"ndarray:{a.dtype.str}:{a.shape};".encode())
        if a.dtype.kind in "fc":
            a = np.ascontiguousarray(a + 0.0)  # a C-ordered copy in which -0.0 is 0.0 (as for array_equal)
            nan = np.isnan(a)
            if nan.any():
                a[nan] = np.nan  # one NaN bit pattern
            h.update(a.data)
        elif a.dtype.kind == "O":
            for x in a.ravel():
                _feed(h, x, depth + 1)
        else:
            h.update(np.ascontiguousarray(a).data)
    elif isinstance(value, (tuple, list)):
        h.update(f"{type(value).__name__}:{len(value)}(".encode())
        for x in value:
            _feed(h, x, depth + 1)
        h.update(b")")
    elif isinstance(value, dict):
        h.update(f"dict:{len(value)}(".encode())
        for k in sorted(value, key=repr):
            _feed(h, k, depth + 1)
            _feed(h, value[k], depth + 1)
        h.update(b")")
    elif isinstance(value, np.random.Generator):
        h.update(f"Generator:{value.bit_generator.state!r};".encode())
    elif dataclasses.is_dataclass(value) and not isinstance(value, type):
        h.update(f"{type(value).__qualname__}(".encode())
        for f in dataclasses.fields(value):
            h.update(f"{f.name}=".encode())
            _feed(h, getattr(value, f.name), depth + 1)
        h.update(b")")
    elif callable(value):
        h.update(f"callable:{getattr(value, '__module__', '')}.{getattr(value, '__qualname__', '')};".encode())
    else:
        text = repr(value)
        h.update(f"{type(value).__qualname__}:{text if ' at 0x' not in text else ''};".encode())


def unit_fingerprint(output, args: tuple, kwargs: Mapping) -> str:
    """Hex digest of a unit call's output and of its arguments after the call."""
    h = hashlib.sha256()  # about twice as fast as blake2b here (SHA extensions)
    _feed(h, output)
    h.update(b"|args|")
    _feed(h, args)
    _feed(h, dict(kwargs))
    return h.hexdigest()[:32]


class _ExampleTimeout(Exception):
    """A unit call during screening exceeded :data:`EXAMPLE_TIME_LIMIT_S`."""


def _on_alarm(signum, frame):
    raise _ExampleTimeout("no result within the time limit")


@contextlib.contextmanager
def _alarm_handler(seconds: float | None):
    """Install the SIGALRM handler of the time limit for a screening (main thread only).

    Yields the limit to arm per call, or None where no limit can be enforced.
    """
    if (not seconds or seconds <= 0 or threading.current_thread() is not threading.main_thread()
            or not hasattr(signal, "setitimer")):
        yield None
        return
    previous = signal.signal(signal.SIGALRM, _on_alarm)
    try:
        yield seconds
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
        signal.signal(signal.SIGALRM, previous)


def _call(unit: Callable, example: UnitExample, time_limit: float | None) -> tuple[str, str | None]:
    """(fingerprint, error) of one unit call; a raising call's fingerprint is its exception type."""
    args, kwargs = example.make_args()
    try:
        if time_limit:
            signal.setitimer(signal.ITIMER_REAL, time_limit)
        try:
            out = unit(*args, **kwargs)
        finally:
            if time_limit:
                signal.setitimer(signal.ITIMER_REAL, 0)
    except Exception as exc:  # a mutant may raise anything
        return f"raises {type(exc).__name__}", f"{type(exc).__name__}: {exc}"
    return unit_fingerprint(out, args, kwargs), None


def _unsteady(unit: Callable, examples: tuple[UnitExample, ...], fingerprints: tuple[str, ...],
              time_limit: float | None) -> list[int]:
    """The examples on which ``unit`` (built with the alternate poison) differs from ``fingerprints``."""
    return [i for i, (ex, fp) in enumerate(zip(examples, fingerprints)) if _call(unit, ex, time_limit)[0] != fp]


# --------------------------------------------------------------------------- screening

def _screen_unit(source: UnitSource, mutants: list[Mutant], examples: tuple[UnitExample, ...],
                 time_limit: float) -> dict[str, Screening]:
    reference = source.build(poison=True)
    alternate = source.build(poison="alternate")
    expected = []
    for i, ex in enumerate(examples):
        fp, error = _call(reference, ex, time_limit)
        if error is not None:
            raise FaultError(f"unit {source.unit!r}: the original unit raises on example {i} "
                             f"({ex.note or 'no note'}): {error}; the examples are broken")
        if _call(alternate, ex, time_limit)[0] != fp:
            raise FaultError(f"unit {source.unit!r}: the original unit's output on example {i} "
                             f"({ex.note or 'no note'}) depends on memory it never wrote (np.empty); "
                             "fill its buffers (np.zeros) before mutating it")
        expected.append(fp)
    expected_t = tuple(expected)
    groups: dict[tuple, str] = {}
    out: dict[str, Screening] = {}
    for m in mutants:
        try:
            code = source.compile(m.function, m.mutated_source)
        except (SyntaxError, ValueError) as exc:
            out[m.id] = Screening(m.id, MutantOutcome.STILLBORN, f"does not compile: {type(exc).__name__}: {exc}")
            continue
        if code_identical(source.function_code(m.function, code), source.function_code(m.function)):
            out[m.id] = Screening(m.id, MutantOutcome.EQUIVALENT, "identical bytecode")
            continue
        if not examples:
            out[m.id] = Screening(m.id, None, "no unit examples: not screened by outputs")
            continue
        try:
            unit = source.build({m.function: code}, poison=True)
        except Exception as exc:  # e.g. a decorator or default value that raises
            out[m.id] = Screening(m.id, MutantOutcome.STILLBORN, f"does not build: {type(exc).__name__}: {exc}")
            continue
        fps, errors = [], []
        for ex in examples:
            fp, error = _call(unit, ex, time_limit)
            fps.append(fp)
            errors.append(error)
        key = tuple(fps)
        if all(e is not None for e in errors):
            out[m.id] = Screening(m.id, MutantOutcome.STILLBORN,
                                  f"raises on every unit example ({len(examples)}): {errors[0]}")
            continue
        unsteady = _unsteady(source.build({m.function: code}, poison="alternate"), examples, key, time_limit)
        if unsteady:
            out[m.id] = Screening(m.id, MutantOutcome.NONDETERMINISTIC,
                                  f"outputs on unit examples {', '.join(map(str, unsteady))} of {len(examples)} "
                                  "depend on the initial contents of np.empty buffers")
        elif key == expected_t:
            out[m.id] = Screening(m.id, MutantOutcome.EQUIVALENT,
                                  f"bit-identical outputs on all {len(examples)} unit examples")
        elif key in groups:
            out[m.id] = Screening(m.id, MutantOutcome.DUPLICATE,
                                  f"bit-identical outputs to {groups[key]} on all {len(examples)} unit examples",
                                  duplicate_of=groups[key])
        else:
            groups[key] = m.id
            differs = [str(i) for i, (a, b) in enumerate(zip(key, expected_t)) if a != b]
            raised = sum(e is not None for e in errors)
            reason = f"differs from the original on unit examples {', '.join(differs)} of {len(examples)}"
            if raised:
                reason += f"; raises on {raised} ({next(e for e in errors if e)})"
            out[m.id] = Screening(m.id, None, reason)
    return out


def screen_mutants(mutants: MutantSet, examples: Mapping[str, tuple[UnitExample, ...]], *,
                   time_limit: float = EXAMPLE_TIME_LIMIT_S) -> ScreeningReport:
    """Classify every mutant as stillborn, equivalent, duplicate or live (see the module docstring).

    Parameters
    ----------
    mutants : MutantSet
        From :func:`faultlab.mutation.mutant.generate_mutants`.
    examples : mapping
        Unit name -> unit examples (:func:`faultlab.mutation.examples.unit_examples`).  A unit
        without examples is screened by compilation and bytecode only.
    time_limit : float
        Seconds one unit call may take (main thread only).

    Returns
    -------
    ScreeningReport

    Raises
    ------
    FaultError
        If an original unit raises on one of its own examples.
    """
    start = time.perf_counter()
    by_unit: dict[str, list[Mutant]] = {}
    for m in mutants:
        by_unit.setdefault(m.unit, []).append(m)
    results: dict[str, Screening] = {}
    with _alarm_handler(time_limit) as limit, np.errstate(all="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore")  # mutants divide by zero, take logs of negatives, ...
        for unit, ms in by_unit.items():
            results.update(_screen_unit(mutants.sources[unit], ms, tuple(examples.get(unit, ())), limit))
    ordered = {m.id: results[m.id] for m in mutants}
    return ScreeningReport(mutants=mutants, results=ordered,
                           n_examples={u: len(examples.get(u, ())) for u in by_unit},
                           seconds=time.perf_counter() - start)
