"""Declarative experiments: the TOML file that describes a test campaign.

An experiment file names everything a campaign needs (Sec. VII of the paper):
the suites and their sizes, how many evaluation runs (each draws new suites),
the SLAM under test and its settings, the variants (baseline plus faults by
name), SLAM repetitions per case, the metric, the wall-clock limit per job, the
detection rule, parameter-space overrides and the root seed.  A malformed file
raises :class:`~faultlab.errors.ConfigError` naming the file, the key and the
reason, before any work starts.

Example (``experiments/paper.toml`` is the paper's protocol)::

    seed = 20240501
    runs = 3
    n_steps = 1000
    sensor_range = 2.0
    variants = ["baseline", "naive_resampling", "missing_angle_wrap", "motion_sign_error"]
    repetitions = 1
    metric = "rms"
    timeout_s = 600

    [suites]
    systematic = 5          # or "auto": as many cases as full class coverage needs
    random = 5
    fixed = 5

    [slam]
    name = "fastslam"       # or "package.module:factory" with a [slam.options] table
    particles = 200
"""

from __future__ import annotations

import copy
import hashlib
import importlib
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

from faultlab.data import resolve_experiment
from faultlab.errors import ConfigError, FaultlabError
from faultlab.tomlfile import read_toml
from faultlab.vocabulary import BASELINE, METRICS, SUITE_KINDS

__all__ = [
    "Experiment",
    "SuiteSpec",
    "SlamSpec",
    "DetectionSpec",
    "load_experiment",
    "parse_experiment",
    "import_object",
    "resolve_variant",
]


_TOP_KEYS = ("description", "seed", "runs", "suites", "n_steps", "sensor_range", "min_distance", "slam",
             "variants", "repetitions", "metric", "timeout_s", "detection", "space")
_FASTSLAM_KEYS = ("particles", "std_v", "std_omega_deg", "std_range", "std_bearing_deg", "resample_ratio")
_BUILTIN_SLAMS = ("fastslam", "dead_reckoning")


@dataclass(frozen=True)
class SuiteSpec:
    """One suite of an experiment: its kind and number of cases (None = the builder's choice)."""

    kind: str
    n_cases: int | None


@dataclass(frozen=True)
class DetectionSpec:
    """The paper's detection rule thresholds (Sec. VII-A), stored for the statistics."""

    abs_mm: float = 250.0
    rel: float = 0.25

    def rule(self):
        """The equivalent :class:`faultlab.stats.DetectionRule`."""
        from faultlab.stats import DetectionRule

        return DetectionRule(abs_mm=self.abs_mm, rel=self.rel)


@dataclass(frozen=True)
class SlamSpec:
    """The SLAM under test.

    ``name`` is ``"fastslam"`` (the reference FastSLAM 1.0, configured by the
    other fields; angles in degrees here, radians in :class:`FastSlamConfig`),
    ``"dead_reckoning"``, or an import path ``"package.module:attr"`` whose
    attribute is called with ``options`` as keyword arguments and must return
    a :class:`~faultlab.slam.protocol.SlamAdapter`.
    """

    name: str = "fastslam"
    particles: int = 200
    std_v: float = 0.1
    std_omega_deg: float = 20.0
    std_range: float = 0.3
    std_bearing_deg: float = 10.0
    resample_ratio: float = 1.5
    options: tuple[tuple[str, Any], ...] = ()

    def fastslam_config(self):
        """The :class:`faultlab.slam.FastSlamConfig` of these settings (SI units)."""
        from faultlab.slam import FastSlamConfig

        return FastSlamConfig(n_particles=self.particles, std_v=self.std_v,
                              std_omega=math.radians(self.std_omega_deg), std_range=self.std_range,
                              std_bearing=math.radians(self.std_bearing_deg),
                              resample_ratio=self.resample_ratio)

    def build(self):
        """A fresh SLAM adapter instance."""
        if self.name == "fastslam":
            from faultlab.slam import FastSlam

            return FastSlam(self.fastslam_config())
        if self.name == "dead_reckoning":
            from faultlab.slam import DeadReckoning

            return DeadReckoning()
        factory = import_object(self.name, what="[slam] name")
        return factory(**dict(self.options))


@dataclass(frozen=True)
class Experiment:
    """A validated experiment (frozen and picklable).

    Attributes
    ----------
    source : str
        Where it came from (file path), used in messages and stored with the results.
    text : str
        The file's text as read ("" when built from a mapping).
    seed : int
        Root seed: every random draw of the campaign derives from it.
    runs : int
        Evaluation runs; each run draws new suites.
    suites : tuple of SuiteSpec
        Suites in file order.
    n_steps, sensor_range, min_distance : int, float, float
        Scenario generation settings (steps, m, m).
    slam : SlamSpec
        The SLAM under test.
    variants : tuple of str
        ``"baseline"`` and fault names or ``module:attr`` fault paths.
    repetitions : int
        SLAM repetitions per case (K >= 1), each with its own SLAM seed shared by all variants.
    metric : str
        Primary metric, ``"rms"`` or ``"emd"`` (both are recorded).
    timeout_s : float
        Wall-clock limit of one SLAM execution, s.
    detection : DetectionSpec
    space : dict
        Parameter-space overrides (``[space]`` table), see :func:`faultlab.space.space_from_mapping`.
    description : str
    """

    source: str
    text: str
    seed: int
    runs: int = 1
    suites: tuple[SuiteSpec, ...] = (SuiteSpec("systematic", 5), SuiteSpec("random", 5), SuiteSpec("fixed", 5))
    n_steps: int = 1000
    sensor_range: float = 2.0
    min_distance: float = 0.1
    slam: SlamSpec = field(default_factory=SlamSpec)
    variants: tuple[str, ...] = (BASELINE,)
    repetitions: int = 1
    metric: str = "rms"
    timeout_s: float = 600.0
    detection: DetectionSpec = field(default_factory=DetectionSpec)
    space: dict = field(default_factory=dict)
    description: str = ""

    # ------------------------------------------------------------------ derived
    def to_dict(self) -> dict:
        """The effective experiment as a TOML-shaped mapping (every default filled in)."""
        slam: dict[str, Any] = {"name": self.slam.name}
        if self.slam.name == "fastslam":
            slam.update({k: getattr(self.slam, k) for k in _FASTSLAM_KEYS})
        if self.slam.options:
            slam["options"] = dict(self.slam.options)
        return {
            "description": self.description,
            "seed": self.seed,
            "runs": self.runs,
            "suites": {s.kind: ("auto" if s.n_cases is None else s.n_cases) for s in self.suites},
            "n_steps": self.n_steps,
            "sensor_range": self.sensor_range,
            "min_distance": self.min_distance,
            "slam": slam,
            "variants": list(self.variants),
            "repetitions": self.repetitions,
            "metric": self.metric,
            "timeout_s": self.timeout_s,
            "detection": {"abs_mm": self.detection.abs_mm, "rel": self.detection.rel},
            "space": copy.deepcopy(self.space),
        }

    def canonical_json(self) -> str:
        """Canonical text of everything that affects results (suite order kept, other keys sorted)."""
        d = self.to_dict()
        d.pop("description")
        d["suites"] = [[s.kind, s.n_cases] for s in self.suites]
        return json.dumps(d, sort_keys=True, separators=(",", ":"), allow_nan=False)

    @property
    def hash(self) -> str:
        """sha256 (hex) of :meth:`canonical_json`: identifies the experiment in a results store."""
        return hashlib.sha256(self.canonical_json().encode()).hexdigest()

    @property
    def suite_kinds(self) -> tuple[str, ...]:
        return tuple(s.kind for s in self.suites)

    def parameter_space(self):
        """Table I with this experiment's ``[space]`` overrides applied."""
        from faultlab.space import space_from_mapping, table1_space

        if not self.space:
            return table1_space()
        return space_from_mapping(self.space, source=f"{self.source} [space]")

    def replace(self, **overrides) -> "Experiment":
        """A new validated experiment with top-level keys replaced.

        Keys are those of the file (``runs=30``, ``n_steps=200``, ...).  A table
        key (``suites``, ``slam``, ``detection``, ``space``) given as a mapping is
        merged into the existing table key by key (``slam={"particles": 30}``).
        """
        data = self.to_dict()
        for key, value in overrides.items():
            if isinstance(value, Mapping) and isinstance(data.get(key), dict):
                merged = dict(data[key])
                merged.update(copy.deepcopy(dict(value)))
                data[key] = merged
            else:
                data[key] = copy.deepcopy(value)
        names = ", ".join(f"{k}={v!r}" for k, v in overrides.items())
        return parse_experiment(data, source=f"{self.source} (with {names})" if names else self.source,
                                text=self.text)


# ---------------------------------------------------------------------- loading
def load_experiment(path: str | Path) -> Experiment:
    """Read and validate an experiment TOML file, or a shipped experiment by name.

    Parameters
    ----------
    path : str or Path
        A file, or the name of an experiment shipped with faultlab (``"paper"``,
        ``"smoke"``; see :func:`faultlab.data.resolve_experiment`).  The experiment's
        ``source`` is ``path`` as given.

    Raises
    ------
    ConfigError
        If the file is missing (or the name unknown: the message lists the shipped
        names), not TOML, or any key is unknown, of the wrong type or out of range
        (the message names the file, key and reason).
    """
    file = resolve_experiment(path, what="experiment file")
    data, text = read_toml(file, what="experiment file")
    return parse_experiment(data, source=str(path), text=text)


def import_object(spec: str, *, what: str = "import path"):
    """Import ``"package.module:attr"`` (attr may be dotted); raise ConfigError naming ``what``."""
    module_name, sep, attr = spec.partition(":")
    if not sep or not module_name or not attr:
        raise ConfigError(f"{what} = {spec!r}: expected 'package.module:attr'")
    try:
        obj = importlib.import_module(module_name)
    except ImportError as exc:
        raise ConfigError(f"{what} = {spec!r}: cannot import module {module_name!r} ({exc})") from exc
    for part in attr.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError as exc:
            raise ConfigError(f"{what} = {spec!r}: module {module_name!r} has no attribute {attr!r}") from exc
    return obj


class _Table:
    """Typed access to one TOML table; remembers which keys were used."""

    def __init__(self, data: Any, where: str, source: str):
        if not isinstance(data, Mapping):
            raise ConfigError(f"{source}: {where or 'the file'} must be a table, got {type(data).__name__}")
        self.data, self.where, self.source = data, where, source
        self.used: set[str] = set()

    def name(self, key: str) -> str:
        return f"{self.where}.{key}" if self.where else key

    def error(self, key: str, reason: str) -> ConfigError:
        return ConfigError(f"{self.source}: {self.name(key)} {reason}")

    def get(self, key: str, default: Any = None) -> Any:
        self.used.add(key)
        return self.data.get(key, default)

    def has(self, key: str) -> bool:
        return key in self.data

    def int(self, key: str, default: int | None = None, *, minimum: int | None = None) -> int:
        self.used.add(key)
        if key not in self.data:
            if default is None:
                raise self.error(key, "is required")
            return default
        v = self.data[key]
        if isinstance(v, bool) or not isinstance(v, int):
            raise self.error(key, f"must be an integer, got {v!r}")
        if minimum is not None and v < minimum:
            raise self.error(key, f"must be >= {minimum}, got {v}")
        return int(v)

    def float(self, key: str, default: float, *, positive: bool = False, minimum: float | None = None) -> float:
        self.used.add(key)
        if key not in self.data:
            return default
        v = self.data[key]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise self.error(key, f"must be a number, got {v!r}")
        v = float(v)
        if not math.isfinite(v):
            raise self.error(key, f"must be finite, got {v}")
        if positive and v <= 0:
            raise self.error(key, f"must be > 0, got {v}")
        if minimum is not None and v < minimum:
            raise self.error(key, f"must be >= {minimum}, got {v}")
        return v

    def str(self, key: str, default: str, *, choices: tuple[str, ...] | None = None) -> str:
        self.used.add(key)
        if key not in self.data:
            return default
        v = self.data[key]
        if not isinstance(v, str):
            raise self.error(key, f"must be a string, got {v!r}")
        if choices is not None and v not in choices:
            raise self.error(key, f"must be one of {', '.join(map(repr, choices))}, got {v!r}")
        return v

    def check_unknown(self, allowed: tuple[str, ...]) -> None:
        for key in self.data:
            if key not in allowed:
                raise self.error(key, f"is not a known key (known: {', '.join(allowed)})")


def parse_experiment(data: Mapping, *, source: str = "<experiment>", text: str = "") -> Experiment:
    """Validate a TOML-shaped mapping (see the module docstring) into an :class:`Experiment`."""
    top = _Table(data, "", source)
    top.check_unknown(_TOP_KEYS)
    description = top.str("description", "")
    seed = top.int("seed", minimum=0)
    runs = top.int("runs", 1, minimum=1)
    n_steps = top.int("n_steps", 1000, minimum=1)
    sensor_range = top.float("sensor_range", 2.0, positive=True)
    min_distance = top.float("min_distance", 0.1, minimum=0.0)
    repetitions = top.int("repetitions", 1, minimum=1)
    metric = top.str("metric", "rms", choices=METRICS)
    timeout_s = top.float("timeout_s", 600.0, positive=True)

    suites = _parse_suites(top, source)
    slam = _parse_slam(top, source)
    variants = _parse_variants(top, source)
    detection = _parse_detection(top, source)

    space = top.get("space", {})
    if not isinstance(space, Mapping):
        raise top.error("space", f"must be a table, got {type(space).__name__}")
    space = copy.deepcopy(dict(space))

    exp = Experiment(source=source, text=text, seed=seed, runs=runs, suites=suites, n_steps=n_steps,
                     sensor_range=sensor_range, min_distance=min_distance, slam=slam, variants=variants,
                     repetitions=repetitions, metric=metric, timeout_s=timeout_s, detection=detection,
                     space=space, description=description)
    _check_suites(exp)
    return exp


def _check_suites(exp: Experiment) -> None:
    """Build each suite once with a throw-away generator: a size the builder rejects fails now."""
    import numpy as np

    from faultlab.space import build_suite

    space = exp.parameter_space()  # raises ConfigError naming "<source> [space]"
    for s in exp.suites:
        try:
            build_suite(s.kind, space, rng=np.random.default_rng(0), n_cases=s.n_cases)
        except FaultlabError as exc:
            raise ConfigError(f"{exp.source}: suites.{s.kind} = "
                              f"{'auto' if s.n_cases is None else s.n_cases}: {exc}") from exc


def _parse_suites(top: _Table, source: str) -> tuple[SuiteSpec, ...]:
    if not top.has("suites"):
        top.used.add("suites")
        return Experiment.__dataclass_fields__["suites"].default
    t = _Table(top.get("suites"), "suites", source)
    t.check_unknown(SUITE_KINDS)
    if not t.data:
        raise top.error("suites", "must name at least one suite (systematic, random, fixed)")
    out = []
    for kind, v in t.data.items():
        if v == "auto":
            out.append(SuiteSpec(kind, None))
        else:
            out.append(SuiteSpec(kind, t.int(kind, minimum=1)))
    return tuple(out)


def _parse_slam(top: _Table, source: str) -> SlamSpec:
    if not top.has("slam"):
        top.used.add("slam")
        return SlamSpec()
    t = _Table(top.get("slam"), "slam", source)
    name = t.str("name", "fastslam")
    if name not in _BUILTIN_SLAMS and ":" not in name:
        raise t.error("name", f"must be one of {', '.join(map(repr, _BUILTIN_SLAMS))} or "
                              f"'package.module:factory', got {name!r}")
    if name == "fastslam":
        t.check_unknown(("name",) + _FASTSLAM_KEYS)
        d = SlamSpec()
        spec = SlamSpec(
            name=name,
            particles=t.int("particles", d.particles, minimum=1),
            std_v=t.float("std_v", d.std_v, minimum=0.0),
            std_omega_deg=t.float("std_omega_deg", d.std_omega_deg, minimum=0.0),
            std_range=t.float("std_range", d.std_range, positive=True),
            std_bearing_deg=t.float("std_bearing_deg", d.std_bearing_deg, positive=True),
            resample_ratio=t.float("resample_ratio", d.resample_ratio, minimum=1.0),
        )
        try:
            spec.fastslam_config()
        except FaultlabError as exc:
            raise ConfigError(f"{source}: [slam] {exc}") from exc
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"{source}: [slam] settings rejected by FastSlamConfig ({exc})") from exc
        return spec
    t.check_unknown(("name", "options"))
    options = t.get("options", {})
    if not isinstance(options, Mapping):
        raise t.error("options", f"must be a table, got {type(options).__name__}")
    if name == "dead_reckoning" and options:
        raise t.error("options", "is not accepted by 'dead_reckoning'")
    if name != "dead_reckoning":
        factory = import_object(name, what=f"{source}: slam.name")
        if not callable(factory):
            raise t.error("name", f"= {name!r} is not callable")
    return SlamSpec(name=name, options=tuple(sorted((str(k), v) for k, v in options.items())))


def _parse_variants(top: _Table, source: str) -> tuple[str, ...]:
    variants = top.get("variants", [BASELINE])
    if not isinstance(variants, list) or not variants:
        raise top.error("variants", f"must be a non-empty list of names, got {variants!r}")
    seen: set[str] = set()
    for i, v in enumerate(variants):
        where = f"variants[{i}]"
        if not isinstance(v, str) or not v:
            raise ConfigError(f"{source}: {where} must be a variant name, got {v!r}")
        if v in seen:
            raise ConfigError(f"{source}: {where} = {v!r} appears twice")
        seen.add(v)
        if v != BASELINE:
            resolve_variant(v, where=f"{source}: {where}")
    return tuple(variants)


def resolve_variant(name: str, *, where: str = "variant"):
    """The fault object of a variant name (None for the baseline); ConfigError if unknown."""
    if name == BASELINE:
        return None
    from faultlab.faults import resolve_fault

    try:
        return resolve_fault(name)
    except FaultlabError as exc:
        raise ConfigError(f"{where} = {name!r}: {exc}") from exc


def _parse_detection(top: _Table, source: str) -> DetectionSpec:
    if not top.has("detection"):
        top.used.add("detection")
        return DetectionSpec()
    t = _Table(top.get("detection"), "detection", source)
    t.check_unknown(("abs_mm", "rel"))
    d = DetectionSpec()
    return DetectionSpec(abs_mm=t.float("abs_mm", d.abs_mm, minimum=0.0), rel=t.float("rel", d.rel, minimum=0.0))
