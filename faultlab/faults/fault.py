"""The fault contract: a named, documented mistake that replaces exactly one unit of a SLAM.

A SLAM written as replaceable units -- the reference FastSLAM 1.0 (:class:`faultlab.slam.FastSlam`,
whose units and their exact signatures and shapes are documented in :mod:`faultlab.slam.units`) --
keeps its units in a frozen dataclass (``slam.steps``, e.g. :class:`faultlab.slam.FastSlamSteps`)
and builds a copy of itself with other units through ``slam.with_steps(steps)``.

A :class:`Fault` names one field of that dataclass (:attr:`Fault.step`) and a factory
``replacement(original_unit) -> new_unit``.  :meth:`Fault.apply` returns a *new* SLAM whose step
table has that one unit replaced; the reference units and the SLAM the fault is applied to are
never modified and nothing is written to disk.  This replaces the paper's hand-edited copies of
the SLAM code (Sec. VII-A) by named, documented plugins.

The contract a replacement must honour:

* it has the signature of the unit it replaces and returns outputs of the documented shapes
  (any memory layout; it must not modify its inputs or the original unit's outputs in place);
* its randomness comes only from the ``rng`` argument of the unit it replaces (units that draw
  random numbers get their own stream, so other units' draws stay the same);
* it is a module-level function (a closure over ``original`` is fine), so the fault can be
  pickled to worker processes;
* in a batch of repetitions (:meth:`faultlab.slam.FastSlam.reset_batch`) it sees the particles
  the unit's kind says (:mod:`faultlab.slam.units`, "Batched repetitions"): a replacement of a
  *filter unit* (:data:`~faultlab.slam.contract.FILTER_UNITS`: ``sample_controls``,
  ``combine_weights``, ``effective_sample_size``, ``resample``, ``apply_resample``,
  ``extract_map``) is called once per repetition with that repetition's N particles and its
  own stream, exactly as in a single run; a replacement of a *particle unit*
  (:data:`~faultlab.slam.contract.PARTICLE_UNITS`: ``motion_model``, ``wrap_heading``,
  ``wrap_bearing``, ``init_landmarks``, ``classify_new``, ``predict_measurement``,
  ``innovation``, ``innovation_covariance``, ``log_likelihood``, ``ekf_update``) may receive the
  particles of several repetitions stacked along the particle axis and must treat every
  particle independently (row ``i`` of its outputs from row ``i`` of its per-particle inputs).
  A particle-unit replacement written for one filter that looks across particles (a sum, mean,
  maximum or normalisation over the particle axis, an index such as ``poses[0]``) declares so
  with :func:`faultlab.slam.contract.filter_wise`; it is then called once per repetition too.
  Written this way, a fault gives every repetition of a batch bit for bit its single-run result.

Names: built-in faults have lower-case ``snake_case`` names; third-party faults ``provider/name``
(see :mod:`faultlab.faults.registry`); ``"baseline"`` and ``"baseline_replica"`` are reserved
for the unmodified SLAM.
"""

from __future__ import annotations

import contextlib
import dataclasses
import re
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field
from typing import Any

from faultlab.errors import FaultError
from faultlab.slam.fastslam import FastSlamSteps
from faultlab.slam.registry import BUILTIN_SLAMS
from faultlab.vocabulary import UNMODIFIED

__all__ = ["Fault", "UnitExample", "apply_faults", "step_names", "known_steps"]

_BUILTIN_NAME = re.compile(r"[a-z][a-z0-9_]*")
_PLUGIN_NAME = re.compile(r"[a-z0-9][a-z0-9_.-]*/[a-z0-9][a-z0-9_.-]*")


def step_names(steps: type = FastSlamSteps) -> tuple[str, ...]:
    """Names of the replaceable units of a SLAM, in algorithm order: the fields of its steps table.

    Parameters
    ----------
    steps : type
        A steps dataclass (:class:`~faultlab.slam.FastSlamSteps`, the default,
        :class:`~faultlab.slam.FastSlam2Steps`, :class:`~faultlab.slam.EkfSlamSteps`, ...);
        a built-in SLAM names its table in :attr:`faultlab.slam.registry.SlamKind.steps`.

    Raises
    ------
    FaultError
        If ``steps`` is not a dataclass type.
    """
    if not (isinstance(steps, type) and dataclasses.is_dataclass(steps)):
        raise FaultError(f"step_names: steps must be a steps dataclass type (e.g. FastSlamSteps), got {steps!r}")
    return tuple(f.name for f in dataclasses.fields(steps))


def known_steps() -> tuple[str, ...]:
    """Every unit of every built-in SLAM (the steps a fault may replace), FastSLAM 1.0's first."""
    names = list(step_names())
    for kind in BUILTIN_SLAMS.values():
        names += [u for u in kind.units if u not in names]
    return tuple(names)


@dataclass(frozen=True, eq=False)
class UnitExample:
    """Inputs on which a fault's unit must behave differently from the original unit.

    A cosmic-ray style smoke test for a mutant: calling the original unit and
    the faulty unit with the same inputs must give different outputs (see
    :func:`faultlab.faults.check.unit_outputs`).

    Parameters
    ----------
    make_args : callable
        ``make_args() -> (args, kwargs)``; called once per unit so that
        each call gets fresh arrays (and, for random units, a fresh
        ``numpy.random.Generator`` with the same seed).
    note : str
        What the example shows, one line.
    """

    make_args: Callable[[], tuple[tuple, dict]]
    note: str = ""


@dataclass(frozen=True)
class Fault:
    """A mutation-style fault that replaces one unit of the reference FastSLAM.

    Parameters
    ----------
    name : str
        Stable name used in experiment files and results tables: lower-case
        ``snake_case`` for built-ins, ``provider/name`` for third-party faults.
        ``"baseline"`` is reserved.
    step : str
        The :class:`~faultlab.slam.FastSlamSteps` field (unit) the fault replaces.
    description : str
        One line: what is wrong.
    rationale : str
        One paragraph: why this is a realistic mistake and how it shows.
    origin : str
        Where the failure mode comes from, e.g. ``"paper Sec. VII-A"``,
        ``"public bug report: ..."``, ``"textbook pitfall: ..."``.
    replacement : callable
        ``replacement(original_unit) -> new_unit``.  It receives the unit it
        replaces (so a fault can wrap the original) and must return a callable
        with the same signature.  Use a module-level function (not a lambda) so
        that the fault can be pickled to worker processes.
    examples : tuple of UnitExample
        Optional unit-level inputs on which the new unit differs from the
        original (not compared, not hashed).
    """

    name: str
    step: str
    description: str
    rationale: str
    origin: str
    replacement: Callable[[Callable], Callable]
    examples: tuple[UnitExample, ...] = field(default=(), compare=False, repr=False)

    def __post_init__(self) -> None:
        name = self.name
        if not isinstance(name, str) or not name:
            raise FaultError(f"fault name must be a non-empty string, got {name!r}")
        if name in UNMODIFIED:
            raise FaultError(f"fault name {name!r} is reserved for the unmodified reference")
        if not (_BUILTIN_NAME.fullmatch(name) or _PLUGIN_NAME.fullmatch(name)):
            raise FaultError(
                f"fault name {name!r} is invalid: use lower-case snake_case for built-ins or "
                f"'provider/name' for third-party faults (letters, digits, '_', '.', '-')")
        if not isinstance(self.step, str) or not self.step.isidentifier():
            raise FaultError(f"fault {name!r}: step must be the name of a FastSlamSteps field, "
                             f"got {self.step!r}")
        for attr in ("description", "rationale", "origin"):
            value = getattr(self, attr)
            if not isinstance(value, str) or not value.strip():
                raise FaultError(f"fault {name!r}: {attr} must be a non-empty string")
        if "\n" in self.description.strip():
            raise FaultError(f"fault {name!r}: description must be one line")
        if not callable(self.replacement):
            raise FaultError(f"fault {name!r}: replacement must be callable (original_unit) -> new_unit, "
                             f"got {type(self.replacement).__name__}")
        examples = tuple(self.examples)
        if not all(isinstance(e, UnitExample) for e in examples):
            raise FaultError(f"fault {name!r}: examples must be UnitExample instances")
        object.__setattr__(self, "examples", examples)

    @property
    def provider(self) -> str | None:
        """The ``provider`` part of a third-party name; None for built-ins."""
        return self.name.split("/", 1)[0] if "/" in self.name else None

    def patch(self, steps):
        """Return a copy of ``steps`` with unit :attr:`step` replaced.

        Parameters
        ----------
        steps : FastSlamSteps
            Any frozen dataclass of units (normally ``slam.steps``); not modified.

        Raises
        ------
        FaultError
            If :attr:`step` is not a field of ``steps`` or the replacement
            factory fails or returns something that is not callable.
        """
        if not dataclasses.is_dataclass(steps) or isinstance(steps, type):
            raise FaultError(f"fault {self.name!r}: can only patch a steps dataclass (FastSlamSteps), "
                             f"got {type(steps).__name__}")
        names = [f.name for f in dataclasses.fields(steps)]
        if self.step not in names:
            raise FaultError(f"fault {self.name!r} patches unknown step {self.step!r}; "
                             f"{type(steps).__name__} has: {', '.join(names)}")
        original = getattr(steps, self.step)
        try:
            unit = self.replacement(original)
        except Exception as exc:
            raise FaultError(f"fault {self.name!r}: building the replacement for step {self.step!r} "
                             f"failed: {type(exc).__name__}: {exc}") from exc
        if not callable(unit):
            raise FaultError(f"fault {self.name!r}: replacement for step {self.step!r} returned "
                             f"{type(unit).__name__}, not a callable unit")
        return dataclasses.replace(steps, **{self.step: unit})

    def apply(self, slam):
        """Return a new SLAM instance with this fault injected; ``slam`` is unchanged.

        Parameters
        ----------
        slam : FastSlam
            Any SLAM with a ``steps`` table and ``with_steps(steps)``.
        """
        if not (hasattr(slam, "steps") and callable(getattr(slam, "with_steps", None))):
            raise FaultError(f"fault {self.name!r} can only be applied to a SLAM with replaceable steps "
                             f"(FastSlam); {type(slam).__name__} has no steps/with_steps")
        return slam.with_steps(self.patch(slam.steps))

    @contextlib.contextmanager
    def applied(self, slam) -> Iterator[Any]:
        """Context-manager form of :meth:`apply`: ``with fault.applied(slam) as faulty: ...``.

        Yields a new instance; nothing global is modified, so there is nothing
        to undo on exit (``slam`` itself stays the reference).
        """
        yield self.apply(slam)

    def summary(self) -> str:
        """``name  step  origin  description`` on one line."""
        return f"{self.name}  [{self.step}]  {self.origin}: {self.description}"


def apply_faults(slam, faults: Iterable[Fault]):
    """Apply several faults in order (a higher-order mutant); returns a new instance."""
    for fault in faults:
        slam = fault.apply(slam)
    return slam
