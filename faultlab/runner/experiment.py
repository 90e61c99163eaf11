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
    metric = "rms"          # or "emd", or "ate" (the trajectory error)
    # metrics = ["rms"]     # record only these (default all: rms, emd, ate); the others are stored as NaN
    timeout_s = 600

    [suites]
    systematic = 5          # or "auto": as many cases as full class coverage needs
    random = 5
    fixed = 5

    [slam]
    name = "fastslam"       # or "package.module:factory" with a [slam.options] table
    particles = 200
    # association = "unknown"   # hide the landmark ids (fastslam, fastslam2): metric "emd" (or "ate") then
"""

from __future__ import annotations

import copy
import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from faultlab.config import ExperimentOverrides, Table, merge_tables, read_toml
from faultlab.data import resolve_experiment
from faultlab.errors import ConfigError, FaultlabError
from faultlab.metrics.detection import FAMILIES, RULES, DetectionRule
from faultlab.inference.sequential import StagedDesign
from faultlab.runner.variants import resolve_variant
from faultlab.scenario.config import DEFAULT_MIN_DISTANCE, DEFAULT_N_STEPS, DEFAULT_SENSOR_RANGE
from faultlab.slam.fastslam import FastSlamConfig
from faultlab.slam.profiles import DEFAULT_PROFILE
from faultlab.slam.protocol import SlamAdapter
from faultlab.slam.registry import build_slam, get_slam_kind, normalise_options
from faultlab.space import build_suite, space_from_mapping, suite_kinds, table1_space
from faultlab.vocabulary import BASELINE, DIRECTIONS, KNOWN_ASSOCIATION, MAP_METRICS, METRICS, UNKNOWN_ASSOCIATION

__all__ = [
    "Experiment",
    "SuiteSpec",
    "SlamSpec",
    "load_experiment",
    "parse_experiment",
]


_TOP_KEYS = ("description", "seed", "runs", "suites", "n_steps", "sensor_range", "min_distance", "fov_bug",
             "slam", "variants", "repetitions", "metric", "metrics", "timeout_s", "detection", "space", "adaptive")


@dataclass(frozen=True)
class SuiteSpec:
    """One suite of an experiment: its kind and number of cases (None = the builder's choice)."""

    kind: str
    n_cases: int | None


@dataclass(frozen=True)
class SlamSpec:
    """The SLAM under test: a name and its validated options.

    ``name`` is a built-in SLAM (:data:`faultlab.slam.registry.BUILTIN_SLAMS`: ``"fastslam"``,
    ``"dead_reckoning"``) whose options are its settings in the file's keys and units with every
    default filled in (for ``"fastslam"`` a non-default ``profile`` among them, whose settings are
    the defaults; see :mod:`faultlab.slam.registry`), or an import path ``"package.module:factory"`` called with ``options``
    as keyword arguments, which must return a :class:`~faultlab.slam.protocol.SlamAdapter`.
    """

    name: str = "fastslam"
    options: tuple[tuple[str, Any], ...] = tuple(FastSlamConfig().to_options().items())

    @property
    def config(self):
        """The settings object of a built-in SLAM (e.g. :class:`FastSlamConfig`); None otherwise."""
        kind = get_slam_kind(self.name)
        return None if kind is None else kind.settings(dict(self.options))

    @property
    def profile(self) -> str | None:
        """The FastSLAM profile (:mod:`faultlab.slam.profiles`) of a built-in SLAM that takes one; else None."""
        kind = get_slam_kind(self.name)
        if kind is None or not kind.profiles:
            return None
        return str(dict(self.options).get("profile", DEFAULT_PROFILE))

    @property
    def association(self) -> str:
        """``"unknown"`` if the SLAM's options hide the landmark ids (``association = "unknown"``), else ``"known"``.

        A factory (import path) declares its association on the adapter it builds
        (:attr:`~faultlab.slam.SlamAdapter.association`); the runner checks it when it builds the SLAM.
        """
        kind = get_slam_kind(self.name)
        return KNOWN_ASSOCIATION if kind is None else kind.association(dict(self.options))

    def build(self) -> SlamAdapter:
        """A fresh SLAM adapter instance."""
        return build_slam(self.name, dict(self.options))

    def to_dict(self) -> dict[str, Any]:
        """The ``[slam]`` table: built-in settings flat beside ``name``, a factory's under ``options``."""
        if get_slam_kind(self.name) is not None:
            return {"name": self.name, **dict(self.options)}
        return {"name": self.name, **({"options": dict(self.options)} if self.options else {})}


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
    fov_bug : bool
        Generate the cases with the replication package's field-of-view *defect* (every right-side
        bearing visible; :func:`faultlab.scenario.generate_scenario`), as the paper ran them.  Off by
        default; when off it is left out of the hash, so older campaigns keep theirs.
    slam : SlamSpec
        The SLAM under test.
    variants : tuple of str
        ``"baseline"`` and fault names or ``module:attr`` fault paths.
    repetitions : int
        SLAM repetitions per case (K >= 1), each with its own SLAM seed shared by all variants.
    metric : str
        Primary metric, ``"rms"``, ``"emd"`` or ``"ate"`` (the absolute trajectory error, which
        judges by the SLAM's trajectory instead of its map).  Default ``"rms"``, or ``"emd"`` when
        the SLAM associates landmarks itself (``association = "unknown"`` in ``[slam]``), which then
        rules out ``"rms"``.
    metrics : tuple of str
        The metrics recorded for every job, in :data:`~faultlab.vocabulary.METRICS` order (default
        all: RMS, EMD and the trajectory error ATE, :func:`faultlab.metrics.trajectory_error_mm`).
        A metric left out is stored as NaN and its work is skipped (the EMD is exact optimal
        transport, seconds on large maps; the ATE costs little); the store's metadata lists the
        recorded ones and the analysis refuses to judge by another.  It must hold ``metric``, and
        ``"rms"`` for a SLAM with landmark ids (Table II judges by the RMS, as the paper does).  The
        hash holds the map errors only, and only when one of them is left out, so older campaigns
        keep theirs; whether a store records the ATE is decided when it is created
        (:func:`faultlab.runner.store.job_metrics`).
    timeout_s : float
        Wall-clock limit of one SLAM execution, s.
    detection : DetectionRule
        The paper's detection rule (Sec. VII-A), stored with the results for the statistics.
    space : dict
        Parameter-space overrides (``[space]`` table), see :func:`faultlab.space.space_from_mapping`.
    adaptive : StagedDesign, optional
        ``[adaptive]`` table: run the repetitions in stages and stop decided (case, variant) pairs
        (:mod:`faultlab.runner.staging`); its last stage equals ``repetitions``.  Left out of the
        hash when absent, so fixed-K campaigns keep theirs.
    description : str
    """

    source: str
    text: str
    seed: int
    runs: int = 1
    suites: tuple[SuiteSpec, ...] = (SuiteSpec("systematic", 5), SuiteSpec("random", 5), SuiteSpec("fixed", 5))
    n_steps: int = DEFAULT_N_STEPS
    sensor_range: float = DEFAULT_SENSOR_RANGE
    min_distance: float = DEFAULT_MIN_DISTANCE
    fov_bug: bool = False
    slam: SlamSpec = field(default_factory=SlamSpec)
    variants: tuple[str, ...] = (BASELINE,)
    repetitions: int = 1
    metric: str = "rms"
    metrics: tuple[str, ...] = METRICS
    timeout_s: float = 600.0
    detection: DetectionRule = field(default_factory=DetectionRule)
    space: dict = field(default_factory=dict)
    adaptive: StagedDesign | None = None
    description: str = ""

    # ------------------------------------------------------------------ derived
    def to_dict(self) -> dict:
        """The effective experiment as a TOML-shaped mapping (every default filled in)."""
        return {
            "description": self.description,
            "seed": self.seed,
            "runs": self.runs,
            "suites": {s.kind: ("auto" if s.n_cases is None else s.n_cases) for s in self.suites},
            "n_steps": self.n_steps,
            "sensor_range": self.sensor_range,
            "min_distance": self.min_distance,
            "fov_bug": self.fov_bug,
            "slam": self.slam.to_dict(),
            "variants": list(self.variants),
            "repetitions": self.repetitions,
            "metric": self.metric,
            "metrics": list(self.metrics),
            "timeout_s": self.timeout_s,
            "detection": self.detection.to_dict(),
            "space": copy.deepcopy(self.space),
        } | ({"adaptive": self.adaptive.to_dict()} if self.adaptive is not None else {})

    def canonical_json(self) -> str:
        """Canonical text of everything that affects results (suite order kept, other keys sorted)."""
        d = self.to_dict()
        d.pop("description")
        if not d["fov_bug"]:
            d.pop("fov_bug")  # the default: hashes of campaigns from before the key existed stay valid
        # the map errors only: the trajectory error adds a column and changes no other value, and a
        # store keeps its own choice of it when resumed (runner.store.job_metrics)
        d["metrics"] = [m for m in d["metrics"] if m in MAP_METRICS]
        if tuple(d["metrics"]) == MAP_METRICS:
            d.pop("metrics")  # both map errors, as before the key existed
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
        if not self.space:
            return table1_space()
        return space_from_mapping(self.space, source=f"{self.source} [space]")

    def replace(self, **keys) -> "Experiment":
        """A new validated experiment with top-level keys replaced, tables whole.

        Keys are those of the file (``runs=30``, ``n_steps=200``, ``slam={"name": "ekf"}``, ...); a
        table (``suites``, ``slam``, ``detection``, ``space``, ``adaptive``) replaces the experiment's
        table, whose keys not given take their defaults.  :meth:`merge` changes a table key by key.
        """
        return self._changed(keys, {})

    def merge(self, **tables) -> "Experiment":
        """A new validated experiment with tables merged key by key (``slam={"particles": 30}`` keeps the
        other SLAM settings); a key that is not a table replaces, as in :meth:`replace`."""
        return self._changed({}, tables)

    def apply(self, overrides: ExperimentOverrides) -> "Experiment":
        """A new validated experiment with a campaign's typed :class:`~faultlab.config.ExperimentOverrides`."""
        replaced, merged = overrides.tables()
        return self._changed(replaced, merged)

    def _changed(self, replaced: Mapping, merged: Mapping) -> "Experiment":
        data = merge_tables(self.to_dict() | dict(replaced), merged)
        names = ", ".join([f"{k}={v!r}" for k, v in replaced.items()]
                          + [f"{k}={v!r} (merged)" if isinstance(v, Mapping) else f"{k}={v!r}"
                             for k, v in merged.items()])
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


def parse_experiment(data: Mapping, *, source: str = "<experiment>", text: str = "") -> Experiment:
    """Validate a TOML-shaped mapping (see the module docstring) into an :class:`Experiment`."""
    top = Table(data, "", source)
    top.check_unknown(_TOP_KEYS)
    description = top.str("description", "")
    seed = top.int("seed", minimum=0)
    runs = top.int("runs", 1, minimum=1)
    n_steps = top.int("n_steps", DEFAULT_N_STEPS, minimum=1)
    sensor_range = top.float("sensor_range", DEFAULT_SENSOR_RANGE, positive=True)
    min_distance = top.float("min_distance", DEFAULT_MIN_DISTANCE, minimum=0.0)
    fov_bug = top.bool("fov_bug", False)
    repetitions = top.int("repetitions", 1, minimum=1)
    timeout_s = top.float("timeout_s", 600.0, positive=True)

    suites = _parse_suites(top, source)
    slam = _parse_slam(top, source)
    # a SLAM that sees no landmark ids has no correspondences: its maps are scored by the EMD
    unknown = slam.association == UNKNOWN_ASSOCIATION
    metric = top.str("metric", "emd" if unknown else "rms", choices=METRICS)
    if unknown and metric == "rms":
        raise top.error("metric", f"must be 'emd' with slam.association = 'unknown' (or 'ate'; a map without "
                                  f"landmark ids has no RMS error), got {metric!r}")
    metrics = _parse_metrics(top, metric=metric, unknown=unknown)
    variants = _parse_variants(top, source)
    detection = _parse_detection(top, source)

    space = top.get("space", {})
    if not isinstance(space, Mapping):
        raise top.error("space", f"must be a table, got {type(space).__name__}")
    space = copy.deepcopy(dict(space))

    adaptive = top.get("adaptive", None)
    if adaptive is not None:
        if not isinstance(adaptive, Mapping):
            raise top.error("adaptive", f"must be a table, got {type(adaptive).__name__}")
        adaptive = StagedDesign.from_mapping(adaptive, where=f"{source}: adaptive")
        if adaptive.total != repetitions:
            raise top.error("adaptive", f"the last stage ({adaptive.total}) must equal repetitions ({repetitions})")

    exp = Experiment(source=source, text=text, seed=seed, runs=runs, suites=suites, n_steps=n_steps,
                     sensor_range=sensor_range, min_distance=min_distance, fov_bug=fov_bug, slam=slam, variants=variants,
                     repetitions=repetitions, metric=metric, metrics=metrics, timeout_s=timeout_s, detection=detection,
                     space=space, adaptive=adaptive, description=description)
    _check_suites(exp)
    return exp


def _check_suites(exp: Experiment) -> None:
    """Build each suite once with a throw-away generator: a size the builder rejects fails now."""
    space = exp.parameter_space()  # raises ConfigError naming "<source> [space]"
    for s in exp.suites:
        try:
            build_suite(s.kind, space, rng=np.random.default_rng(0), n_cases=s.n_cases)
        except FaultlabError as exc:
            raise ConfigError(f"{exp.source}: suites.{s.kind} = "
                              f"{'auto' if s.n_cases is None else s.n_cases}: {exc}") from exc


def _parse_suites(top: Table, source: str) -> tuple[SuiteSpec, ...]:
    if not top.has("suites"):
        return Experiment.__dataclass_fields__["suites"].default
    t = top.table("suites")
    t.check_unknown(suite_kinds())
    if not t.data:
        raise top.error("suites", f"must name at least one suite ({', '.join(suite_kinds())})")
    out = []
    for kind, v in t.data.items():
        if v == "auto":
            out.append(SuiteSpec(kind, None))
        else:
            out.append(SuiteSpec(kind, t.int(kind, minimum=1)))
    return tuple(out)


def _parse_slam(top: Table, source: str) -> SlamSpec:
    if not top.has("slam"):
        return SlamSpec()
    t = top.table("slam")
    name = t.str("name", SlamSpec.name)
    where = f"{source}: slam"
    if get_slam_kind(name, where=f"{where}.name") is not None:
        options = {k: v for k, v in t.data.items() if k != "name"}
    else:
        t.check_unknown(("name", "options"))
        options = t.get("options", {})
        if not isinstance(options, Mapping):
            raise t.error("options", f"must be a table, got {type(options).__name__}")
    options = normalise_options(name, options, where=where)
    return SlamSpec(name=name, options=tuple((str(k), v) for k, v in options.items()))


def _parse_metrics(top: Table, *, metric: str, unknown: bool) -> tuple[str, ...]:
    """``metrics``: the recorded metrics, in :data:`METRICS` order (default all of them)."""
    names = top.get("metrics", list(METRICS))
    if (not isinstance(names, list) or not names or any(not isinstance(n, str) for n in names)
            or len(set(names)) != len(names)):
        raise top.error("metrics", f"must be a non-empty list of distinct metric names "
                                   f"({', '.join(map(repr, METRICS))}), got {names!r}")
    bad = [n for n in names if n not in METRICS]
    if bad:
        raise top.error("metrics", f"unknown metric {bad[0]!r}; the metrics are {', '.join(map(repr, METRICS))}")
    if metric not in names:
        raise top.error("metrics", f"must record the experiment's metric {metric!r}, got {names!r}")
    if not unknown and "rms" not in names:
        raise top.error("metrics", f"must record 'rms' for a SLAM with landmark ids (Table II and the per-job "
                                   f"detection figures judge by the RMS error), got {names!r}")
    return tuple(m for m in METRICS if m in names)


def _parse_variants(top: Table, source: str) -> tuple[str, ...]:
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
        try:
            resolve_variant(v)
        except FaultlabError as exc:
            raise ConfigError(f"{source}: {where} = {v!r}: {exc}") from exc
    return tuple(variants)


def _parse_detection(top: Table, source: str) -> DetectionRule:
    if not top.has("detection"):
        return DetectionRule()
    t = top.table("detection")
    d = DetectionRule()
    t.check_unknown(("abs_mm", "rel", "rule", "alpha", "family", "direction"))
    choices = {}
    for key, allowed in (("rule", RULES), ("family", FAMILIES), ("direction", DIRECTIONS)):
        choices[key] = t.data.get(key, getattr(d, key))
        if choices[key] not in allowed:
            raise t.error(key, f"must be one of {', '.join(map(repr, allowed))}, got {choices[key]!r}")
    alpha = t.float("alpha", d.alpha, positive=True)
    if not alpha < 1:
        raise t.error("alpha", f"must lie in (0, 1), got {alpha!r}")
    return DetectionRule(abs_mm=t.float("abs_mm", d.abs_mm, minimum=0.0), rel=t.float("rel", d.rel, minimum=0.0),
                         alpha=alpha, **choices)
