"""The sensor-fault contract: a named, documented perturbation of the input stream a SLAM sees.

A code fault (:class:`~faultlab.faults.fault.Fault`) replaces one unit of a SLAM.  A
:class:`SensorFault` leaves every SLAM's code alone and changes what the SLAM is fed instead --
the paper's future work (Sec. IX) names "hardware limitations or sensor faults" -- so it applies to
every SLAM alike, including one running as a child process (:mod:`faultlab.slam.process`) and GTSAM:

* a *stream fault* (:attr:`SensorFault.perturbation`) maps the scenario's controls and
  observations to the ones a faulty sensor or odometer would have delivered; the ground truth
  (``landmarks``, ``landmark_ids``, ``true_poses``) and therefore the scoring are never touched;
* a *hardware limit* (:attr:`SensorFault.option`) changes one option of the SLAM under test (e.g.
  fewer particles on a smaller computer); it applies only to a SLAM that has that option and is
  reported as not applicable to any other.

Randomness: a stochastic perturbation draws from its own stream, derived from the job's seed and
the fault's name (:func:`faultlab.seeds.sensor_seed_sequence`), never from global state and
never from the SLAM's own stream -- the SLAM is seeded exactly as in the baseline (common random
numbers), so a difference from the baseline comes from the perturbed input alone.

The built-in sensor faults are in :mod:`faultlab.faults.sensorfaults`; third-party ones are
discovered through the entry-point group ``faultlab.sensor_faults`` (:func:`load_sensor_plugins`),
with ``provider/name`` names like code faults.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from faultlab.errors import FaultError
from faultlab.faults.discovery import FaultCatalogue, PluginFailure, PluginWarning
from faultlab.plugins import PluginLoad
from faultlab.scenario.model import Scenario
from faultlab.seeds import sensor_seed_sequence
from faultlab.vocabulary import UNMODIFIED

__all__ = ["SENSOR_ENTRY_POINT_GROUP", "STREAM", "SensorFault", "load_sensor_plugins",
           "step_of_observations", "select_observations", "gather_steps"]

#: Entry-point group a plugin distribution declares its sensor faults in.
SENSOR_ENTRY_POINT_GROUP = "faultlab.sensor_faults"
#: What a stream fault changes, as listed by ``faultlab faults``.
STREAM = "sensor stream"

_BUILTIN_NAME = re.compile(r"[a-z][a-z0-9_]*")
_PLUGIN_NAME = re.compile(r"[a-z0-9][a-z0-9_.-]*/[a-z0-9][a-z0-9_.-]*")


@dataclass(frozen=True)
class SensorFault:
    """A fault of the sensors or the platform, not of the SLAM's code.

    Parameters
    ----------
    name : str
        Stable name used as a variant in experiment files: lower-case ``snake_case`` for built-ins,
        ``provider/name`` for plugins; it must not clash with a code fault.
    description : str
        One line: what goes wrong.
    rationale : str
        One paragraph: the real-world origin and how it shows.
    origin : str
        Where the failure mode comes from (a reference or an engineering source).
    parameters : tuple of (str, float, str)
        ``(name, value, unit)`` of every parameter, for listings; the values are those bound in
        ``perturbation`` or ``configure``.
    perturbation : callable, optional
        ``perturbation(scenario, rng) -> Scenario`` for a stream fault: a module-level function (or
        a :func:`functools.partial` of one, so the fault pickles to workers) returning a new
        scenario whose ``controls`` and ``obs_*`` arrays are the faulty stream; it must not modify
        its input and must keep the ground truth arrays (the same objects).
    option : str, optional
        For a hardware limit: the SLAM option (file key) it changes.
    configure : callable, optional
        ``configure(value) -> new value`` of :attr:`option`.
    stochastic : bool
        Whether the perturbation draws random numbers (then different seeds give different streams).
    """

    name: str
    description: str
    rationale: str
    origin: str
    parameters: tuple[tuple[str, float, str], ...] = ()
    perturbation: Callable[[Scenario, np.random.Generator], Scenario] | None = None
    option: str | None = None
    configure: Callable[[Any], Any] | None = None
    stochastic: bool = True

    def __post_init__(self) -> None:
        name = self.name
        if not isinstance(name, str) or name in UNMODIFIED or not (
                _BUILTIN_NAME.fullmatch(name) or _PLUGIN_NAME.fullmatch(name)):
            raise FaultError(f"sensor fault name {name!r} is invalid: use lower-case snake_case for built-ins or "
                             f"'provider/name' for plugins ('baseline' is reserved)")
        for attr in ("description", "rationale", "origin"):
            value = getattr(self, attr)
            if not isinstance(value, str) or not value.strip():
                raise FaultError(f"sensor fault {name!r}: {attr} must be a non-empty string")
        if (self.perturbation is None) == (self.option is None):
            raise FaultError(f"sensor fault {name!r}: give either a perturbation (stream fault) or an option "
                             f"with configure (hardware limit), not both or neither")
        if self.option is not None and not callable(self.configure):
            raise FaultError(f"sensor fault {name!r}: option {self.option!r} needs a callable configure")
        if self.perturbation is not None and not callable(self.perturbation):
            raise FaultError(f"sensor fault {name!r}: perturbation must be callable (scenario, rng) -> Scenario")

    @property
    def provider(self) -> str | None:
        """The ``provider`` part of a plugin name; None for built-ins."""
        return self.name.split("/", 1)[0] if "/" in self.name else None

    @property
    def step(self) -> str:
        """What the fault changes: :data:`STREAM`, or ``"slam option <key>"`` for a hardware limit."""
        return STREAM if self.option is None else f"slam option {self.option}"

    @property
    def perturbs_stream(self) -> bool:
        """True for a stream fault, False for a hardware limit."""
        return self.perturbation is not None

    def not_applicable(self, options: Mapping[str, Any]) -> str | None:
        """Why the fault does not apply to a SLAM with these (validated) options, or None if it applies."""
        if self.option is None or self.option in options:
            return None
        return (f"sensor fault {self.name!r} changes the SLAM option {self.option!r}, which this SLAM does "
                f"not have")

    def configure_options(self, options: Mapping[str, Any]) -> dict[str, Any]:
        """The SLAM options under this fault (a copy; unchanged for a stream fault).

        Raises
        ------
        FaultError
            A hardware limit on a SLAM without its option.
        """
        options = dict(options)
        if self.option is None:
            return options
        reason = self.not_applicable(options)
        if reason is not None:
            raise FaultError(reason)
        options[self.option] = self.configure(options[self.option])
        return options

    def rng(self, seed: int) -> np.random.Generator:
        """The fault's own generator for the job whose SLAM seed is ``seed``."""
        return np.random.default_rng(sensor_seed_sequence(seed, self.name))

    def perturb(self, scenario: Scenario, *, seed: int) -> Scenario:
        """The stream a SLAM sees under this fault in the job of SLAM seed ``seed`` (``scenario`` for a hardware limit).

        The result keeps ``scenario``'s ground truth arrays and case; it is validated.
        """
        if self.perturbation is None:
            return scenario
        try:
            out = self.perturbation(scenario, self.rng(seed))
        except Exception as exc:
            raise FaultError(f"sensor fault {self.name!r}: perturbation failed: {type(exc).__name__}: {exc}") from exc
        if not isinstance(out, Scenario):
            raise FaultError(f"sensor fault {self.name!r}: perturbation returned {type(out).__name__}, not a Scenario")
        if (out.landmarks is not scenario.landmarks or out.true_poses is not scenario.true_poses
                or out.landmark_ids is not scenario.landmark_ids):
            raise FaultError(f"sensor fault {self.name!r}: a perturbation must not change the ground truth")
        out.validate()
        return out

    def apply(self, slam):
        """A sensor fault leaves the SLAM's code alone: ``slam`` itself (options are set by the runner)."""
        return slam

    def summary(self) -> str:
        """``name  [step]  origin: description`` on one line."""
        return f"{self.name}  [{self.step}]  {self.origin}: {self.description}"

    def parameter_text(self) -> str:
        """``p = 0.2, mean = 10 steps`` (empty without parameters)."""
        return ", ".join(f"{n} = {v:g}{' ' + u if u else ''}" for n, v, u in self.parameters)


# --------------------------------------------------------------------------- stream helpers (vectorised)

def step_of_observations(scenario: Scenario) -> np.ndarray:
    """The step of every observation, shape (M,), int64 (CSR offsets expanded)."""
    counts = np.diff(scenario.obs_offsets)
    return np.repeat(np.arange(scenario.n_steps, dtype=np.int64), counts)


def select_observations(scenario: Scenario, keep: np.ndarray) -> Scenario:
    """The scenario with only the observations where ``keep`` (shape (M,), bool) is true; controls unchanged."""
    keep = np.asarray(keep, dtype=bool)
    counts = np.bincount(step_of_observations(scenario)[keep], minlength=scenario.n_steps)
    offsets = np.concatenate(([0], np.cumsum(counts))).astype(np.int64)
    return replace(scenario, obs_offsets=offsets, obs_range=scenario.obs_range[keep],
                   obs_bearing=scenario.obs_bearing[keep], obs_ids=scenario.obs_ids[keep])


def gather_steps(scenario: Scenario, source: np.ndarray) -> Scenario:
    """The scenario whose step ``t`` delivers the observations made in step ``source[t]`` (none where -1).

    Parameters
    ----------
    source : ndarray of int, shape (T,)
        Values in ``[-1, T)``; a step may be delivered twice or never.
    """
    source = np.asarray(source, dtype=np.int64)
    counts_all = np.diff(scenario.obs_offsets)
    valid = source >= 0
    counts = np.where(valid, counts_all[np.where(valid, source, 0)], 0)
    offsets = np.concatenate(([0], np.cumsum(counts))).astype(np.int64)
    starts = np.where(valid, scenario.obs_offsets[:-1][np.where(valid, source, 0)], 0)
    index = np.repeat(starts - offsets[:-1], counts) + np.arange(int(offsets[-1]), dtype=np.int64)
    return replace(scenario, obs_offsets=offsets, obs_range=scenario.obs_range[index],
                   obs_bearing=scenario.obs_bearing[index], obs_ids=scenario.obs_ids[index])


# --------------------------------------------------------------------------- plugins

@dataclass(frozen=True)
class SensorFaultCatalogue(FaultCatalogue):
    """The sensor-fault plugins: ``provider/name`` :class:`SensorFault` instances (or iterables of them).

    Entry points are described and failures recorded as for code faults
    (:class:`~faultlab.plugins.PluginFailure`, of kind ``"sensor-fault"``).
    """

    def failure(self, plugin: str, source: str, error: str, *, loading: bool) -> PluginFailure:
        return PluginFailure(plugin, source, error, kind="sensor-fault")

    def instances(self, obj: Any) -> list[Any]:
        if isinstance(obj, SensorFault):
            return [obj]
        if isinstance(obj, (str, bytes, Mapping)) or not isinstance(obj, Iterable):
            raise TypeError(f"entry point must load to a SensorFault or an iterable of them, got {type(obj).__name__}")
        return list(obj)

    def is_builtin(self, item: Any) -> bool:
        return False

    def problem(self, item: Any, taken: dict[str, str], source: str) -> str | None:
        if not isinstance(item, SensorFault):
            return f"yielded {type(item).__name__} {item!r}, not a SensorFault"
        if item.provider is None:
            return f"sensor fault {item.name!r} needs a 'provider/name' name (plain names are reserved for built-ins)"
        if item.name in taken:
            return f"duplicate sensor fault name {item.name!r}: defined by {taken[item.name]} and by {source}"
        return None

    def collect(self, items: list, sources: dict[str, str], errors: list) -> PluginLoad:
        ordered = tuple(sorted(items, key=lambda f: f.name))
        return PluginLoad(items=ordered, sources={f.name: sources[f.name] for f in ordered}, errors=tuple(errors))


def load_sensor_plugins(*, group: str = SENSOR_ENTRY_POINT_GROUP, warn: bool = True) -> PluginLoad:
    """Discover third-party sensor faults in the entry-point group ``faultlab.sensor_faults``.

    Each entry point loads to a :class:`SensorFault` or an iterable of them, named ``provider/name``;
    a plugin that fails is reported (and warned about) and the others still load.
    """
    catalogue = SensorFaultCatalogue(kind="sensor fault", group=group, base=SensorFault, builtins=(),
                                     warning=PluginWarning)
    return catalogue.load(group=group, warn=warn)

