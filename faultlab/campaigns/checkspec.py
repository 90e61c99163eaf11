"""What ``faultlab check`` runs (:class:`CheckSpec`), how the SLAM under test is built from it, and
judging one scenario with it (:func:`judge_scenario`, also what a generated reproducer calls)."""

from __future__ import annotations

import functools
import hashlib
import json
import os
import shlex
import sys
from collections.abc import Mapping, Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from faultlab.errors import ConfigError
from faultlab.oracles import DEFAULT_OPTIONS, CaseJudgement, Outcome, execute, get_oracle, judge_case, repetition_seeds
from faultlab.runner import TimeLimitExceeded, time_limit
from faultlab.scenario.model import Scenario
from faultlab.slam.registry import build_slam, get_slam_kind, normalise_options
from faultlab.vocabulary import DEFAULT_ALPHA

__all__ = ["DEFAULT_SUITE", "DEFAULT_ORACLES", "DEFAULT_TIMEOUT_S", "CheckSpec", "use_paths", "slam_factory",
           "reference_factory", "execute_limited", "executor", "judge_scenario"]

#: The default suite kind (:mod:`faultlab.campaigns.check`: why pairwise).
DEFAULT_SUITE = "pairwise"
#: Wall-clock limit of one execution of the SLAM under test, s (``--timeout``): a run past it is a
#: ``timeout`` of the execution oracle.  Generous: faultlab's EKF-SLAM runs a 200-step case of a
#: large Table I map in a few seconds.
DEFAULT_TIMEOUT_S = 60.0
#: The oracles applied by default.  ``consistency`` is asked for by name: Table I's scenarios carry
#: noise no filter models (outliers, biases, variances above a filter's own), on which even a correct
#: EKF-SLAM is overconfident; judge it on a space matched to the SLAM's noise model
#: (:mod:`faultlab.oracles.consistency`).
DEFAULT_ORACLES = ("execution", "metamorphic", "floor", "differential")


@dataclass(frozen=True)
class CheckSpec:
    """What ``faultlab check`` runs: the SLAM, the suite, K, the level and the oracles' margins.

    ``slam`` is a built-in name or ``package.module:factory``; ``command`` (a process SLAM's argv)
    replaces it.  ``space`` overrides Table I's classes (the format of ``experiments/space_table1.toml``,
    e.g. smaller maps for a fast check).  ``paths`` are put at the front of the import path (in the workers too) before the
    factory is imported.
    """

    slam: str = ""
    command: tuple[str, ...] = ()
    slam_options: Mapping[str, Any] = field(default_factory=dict)
    reference: str = "ekf"
    suite: str = DEFAULT_SUITE
    n_cases: int | None = None
    n_steps: int = 200
    seed: int = 1
    repetitions: int = 8
    alpha: float = DEFAULT_ALPHA
    oracles: tuple[str, ...] = DEFAULT_ORACLES
    options: Mapping[str, Any] = field(default_factory=dict)
    paths: tuple[str, ...] = ()
    space: Mapping[str, Any] = field(default_factory=dict)
    timeout_s: float = DEFAULT_TIMEOUT_S

    def validate(self) -> "CheckSpec":
        if not self.timeout_s > 0:
            raise ConfigError(f"--timeout must be > 0 s, got {self.timeout_s}")
        if bool(self.slam) == bool(self.command):
            raise ConfigError("name the SLAM under test either as SLAM (a built-in name or package.module:factory) "
                              "or with --command, not both or neither")
        if self.repetitions < 2:
            raise ConfigError(f"--repetitions must be >= 2 (two seeds tell a deterministic SLAM), got {self.repetitions}")
        if not 0 < self.alpha < 1:
            raise ConfigError(f"--alpha must lie in (0, 1), got {self.alpha}")
        if self.n_steps < 1:
            raise ConfigError(f"--steps must be >= 1, got {self.n_steps}")
        for name in self.oracles:
            get_oracle(name)
        unknown = set(self.options) - set(DEFAULT_OPTIONS)
        if unknown:
            raise ConfigError(f"unknown oracle option(s) {sorted(unknown)}; known: {sorted(DEFAULT_OPTIONS)}")
        self._check_budgets()
        with use_paths(self.paths):
            slam_factory(self)  # imports the factory: a wrong path is a usage error before any run
            if self.reference:
                normalise_options(self.reference, {}, where="--reference")
        return self

    def _check_budgets(self) -> None:
        """Each per-class budget names a class of the check's space and is a positive number of mm."""
        per_class = dict(self.options.get("budget_classes") or {})
        if not per_class:
            return
        space = self.parameter_space()
        for key, mm in per_class.items():
            name, _, cls = str(key).partition(".")
            try:
                known = space[name].class_names
            except (KeyError, ConfigError):
                known = None
            if known is None or cls not in known:
                raise ConfigError(f"--budget {key}: not PARAMETER.CLASS of the space (e.g. map_size.large"
                                  + (f"; {name}'s classes: {', '.join(known)}" if known else "") + ")")
            if not (isinstance(mm, (int, float)) and mm > 0):
                raise ConfigError(f"--budget {key}={mm!r}: the bound must be a positive number of mm")

    def parameter_space(self):
        """The check's parameter space: Table I with the spec's overrides."""
        from faultlab.space import table1_space
        from faultlab.space.parameters import space_from_mapping

        return space_from_mapping(self.space, source="check space") if self.space else table1_space()

    @property
    def label(self) -> str:
        return shlex.join(self.command) if self.command else self.slam

    def to_dict(self) -> dict:
        d = asdict(self)
        d["command"] = list(self.command)
        d["oracles"] = list(self.oracles)
        d["paths"] = list(self.paths)
        d["options"] = {**DEFAULT_OPTIONS, **dict(self.options)}
        d["options"]["relations"] = list(d["options"]["relations"])
        d["options"]["budget_classes"] = dict(d["options"]["budget_classes"])
        return d

    def digest(self) -> str:
        return hashlib.sha256(json.dumps(self.to_dict(), sort_keys=True).encode()).hexdigest()[:16]


class use_paths:
    """Context manager: ``paths`` (and the working directory) at the front of ``sys.path``."""

    def __init__(self, paths: Sequence[str]):
        self.paths = [str(Path(p).resolve()) for p in (*paths, os.getcwd())]

    def __enter__(self):
        self.added = [p for p in self.paths if p not in sys.path]
        sys.path[:0] = self.added
        return self

    def __exit__(self, *exc):
        for p in self.added:
            if p in sys.path:
                sys.path.remove(p)
        return False


def slam_factory(spec: CheckSpec):
    """``() -> SlamAdapter`` of the SLAM under test (picklable: the workers rebuild it)."""
    if spec.command:
        return functools.partial(build_slam, "process", normalise_options(
            "process", {"command": list(spec.command)}, where="--command"))
    get_slam_kind(spec.slam, where="SLAM")
    # validates a built-in's options; imports an import path's factory (a wrong path is a usage error)
    options = normalise_options(spec.slam, dict(spec.slam_options), where="SLAM")
    return functools.partial(build_slam, spec.slam, options)


def reference_factory(spec: CheckSpec):
    if not spec.reference:
        return None
    return functools.partial(build_slam, spec.reference, normalise_options(spec.reference, {}, where="--reference"))


def execute_limited(factory, scenario: Scenario, seed: int, *, timeout_s: float) -> Outcome:
    """:func:`faultlab.oracles.execute` within the runner's wall-clock limit: a SLAM stuck past
    ``timeout_s`` (a Python loop, a sleep) is stopped and its outcome is a ``timeout`` error."""
    import time

    start = time.perf_counter()
    try:
        with time_limit(timeout_s):
            return execute(factory, scenario, seed)
    except TimeLimitExceeded:
        return Outcome(None, f"timeout: wall-clock limit of {timeout_s:g} s exceeded", time.perf_counter() - start)


def executor(spec) -> functools.partial:
    """The executor of ``spec``'s runs (picklable): :func:`execute_limited` at its ``timeout_s``."""
    return functools.partial(execute_limited, timeout_s=float(spec.timeout_s))


def judge_scenario(spec: CheckSpec, case_id: str, scenario: Scenario,
                   classes: Mapping[str, str] | None = None) -> CaseJudgement:
    """Judge one scenario (in Table I's ``classes``, parameter -> class name; default: those a reduced
    case keeps in ``meta["check_classes"]``) by the spec's oracles, in this process."""
    with use_paths(spec.paths):
        return judge_case(case_id, scenario, slam_factory(spec), oracles=[get_oracle(o) for o in spec.oracles],
                          seeds=repetition_seeds(spec.seed, case_id, spec.repetitions), alpha=spec.alpha,
                          reference=reference_factory(spec), options={**DEFAULT_OPTIONS, **dict(spec.options)},
                          classes=scenario.meta.get("check_classes", {}) if classes is None else classes,
                          executor=executor(spec))
