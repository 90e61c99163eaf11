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
from faultlab.oracles import DEFAULT_OPTIONS, CaseJudgement, get_oracle, judge_case, repetition_seeds
from faultlab.scenario.model import Scenario
from faultlab.slam.registry import build_slam, get_slam_kind, normalise_options
from faultlab.vocabulary import DEFAULT_ALPHA

__all__ = ["DEFAULT_SUITE", "DEFAULT_ORACLES", "CheckSpec", "use_paths", "slam_factory", "reference_factory",
           "judge_scenario"]

#: The default suite kind (:mod:`faultlab.campaigns.check`: why pairwise).
DEFAULT_SUITE = "pairwise"
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

    def validate(self) -> "CheckSpec":
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
        with use_paths(self.paths):
            slam_factory(self)  # imports the factory: a wrong path is a usage error before any run
            if self.reference:
                normalise_options(self.reference, {}, where="--reference")
        return self

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


def judge_scenario(spec: CheckSpec, case_id: str, scenario: Scenario) -> CaseJudgement:
    """Judge one scenario by the spec's oracles (in this process)."""
    with use_paths(spec.paths):
        return judge_case(case_id, scenario, slam_factory(spec), oracles=[get_oracle(o) for o in spec.oracles],
                          seeds=repetition_seeds(spec.seed, case_id, spec.repetitions), alpha=spec.alpha,
                          reference=reference_factory(spec), options={**DEFAULT_OPTIONS, **dict(spec.options)})
