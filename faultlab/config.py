"""Validation of configuration, in one place: TOML files, typed tables, numbers and import paths.

Every configuration value faultlab accepts -- an experiment file, a parameter-space file, the
settings of a SLAM or of the detection rule, an import path ``package.module:attr`` -- is checked
by the functions here, so that a malformed value always gives one :class:`~faultlab.errors.ConfigError`
(or the error class a caller names) saying *what* is wrong and *where* (file and key).
"""

from __future__ import annotations

import copy
import importlib
import math
import numbers
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from pathlib import Path
from typing import Any, ClassVar

from faultlab.errors import ConfigError

__all__ = ["read_toml", "merge_tables", "Table", "check_number", "check_int", "check_choice", "import_object", "Option",
           "Settings", "ExperimentOverrides"]


def read_toml(path: str | Path, *, what: str) -> tuple[dict, str]:
    """Read and parse a TOML file.

    Parameters
    ----------
    path : str or Path
    what : str
        What the file is, for messages (e.g. ``"experiment file"``).

    Returns
    -------
    (dict, str)
        The parsed table and the file's text.

    Raises
    ------
    ConfigError
        ``"<path>: <what> cannot be read (...)"`` or ``"<path>: <what> is not valid TOML (...)"`` (which
        includes a file that is not UTF-8).
    """
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except OSError as exc:
        raise ConfigError(f"{p}: {what} cannot be read ({exc.strerror or exc})") from exc
    except UnicodeDecodeError as exc:  # TOML is UTF-8 by definition
        line = exc.object[:exc.start].count(b"\n") + 1
        raise ConfigError(f"{p}: {what} is not valid TOML (not UTF-8 text: byte 0x{exc.object[exc.start]:02x} "
                          f"at line {line})") from None
    try:
        return tomllib.loads(text), text
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{p}: {what} is not valid TOML ({exc})") from exc


def merge_tables(data: Mapping, overrides: Mapping) -> dict:
    """A deep copy of ``data`` with ``overrides`` replacing its keys; a table replaces key by key.

    How an experiment's ``quick`` table is laid over the file's own values.
    """
    out = copy.deepcopy(dict(data))
    for key, value in overrides.items():
        if isinstance(value, Mapping) and isinstance(out.get(key), Mapping):
            out[key] = {**out[key], **copy.deepcopy(dict(value))}
        else:
            out[key] = copy.deepcopy(value)
    return out


def check_number(value: Any, *, name: str, minimum: float | None = None, positive: bool = False,
                 maximum: float | None = None, error: type[Exception] = ConfigError) -> float:
    """``value`` as a finite float, or ``error`` naming ``name``.

    Parameters
    ----------
    value : any
        Booleans are rejected (TOML and Python both let ``true`` pass as a number).
    name : str
        Where the value comes from, e.g. ``"exp.toml: slam.std_v"`` or ``"FastSlamConfig.std_v"``.
    minimum, maximum : float, optional
        Inclusive bounds.
    positive : bool
        Require ``value > 0``.
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise error(f"{name} must be a number, got {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise error(f"{name} must be finite, got {value!r}")
    if positive and x <= 0:
        raise error(f"{name} must be > 0, got {value!r}")
    if minimum is not None and x < minimum:
        raise error(f"{name} must be >= {minimum:g}, got {value!r}")
    if maximum is not None and x > maximum:
        raise error(f"{name} must be <= {maximum:g}, got {value!r}")
    return x


def check_int(value: Any, *, name: str, minimum: int | None = None,
              error: type[Exception] = ConfigError) -> int:
    """``value`` as an int (numpy integers accepted, booleans and floats rejected), or ``error``."""
    if isinstance(value, bool) or not isinstance(value, numbers.Integral):
        raise error(f"{name} must be an integer, got {value!r}")
    if minimum is not None and value < minimum:
        raise error(f"{name} must be >= {minimum}, got {value!r}")
    return int(value)


def check_choice(value: Any, *, name: str, choices: tuple[str, ...],
                 error: type[Exception] = ConfigError) -> str:
    """``value`` as one of the strings ``choices``, or ``error`` naming ``name`` and the choices."""
    if not isinstance(value, str) or value not in choices:
        raise error(f"{name} must be one of {', '.join(map(repr, choices))}, got {value!r}")
    return value


def import_object(spec: str, *, what: str = "import path", error: type[Exception] = ConfigError) -> Any:
    """Import ``"package.module:attr"`` (``attr`` may be dotted).

    Parameters
    ----------
    spec : str
    what : str
        Names the setting in messages, e.g. ``"exp.toml: slam.name"``.
    error : exception class
        Raised, with ``what`` and ``spec`` in the message, for a malformed path, a module that
        fails to import (any exception, with its type and message) or a missing attribute.
    """
    module_name, sep, attr = spec.partition(":") if isinstance(spec, str) else ("", "", "")
    if not sep or not module_name or not attr:
        raise error(f"{what} = {spec!r}: expected 'package.module:attr'")
    try:
        obj = importlib.import_module(module_name)
    except Exception as exc:
        raise error(f"{what} = {spec!r}: cannot import module {module_name!r} "
                    f"({type(exc).__name__}: {exc})") from exc
    for part in attr.split("."):
        try:
            obj = getattr(obj, part)
        except AttributeError:
            raise error(f"{what} = {spec!r}: module {module_name!r} has no attribute {attr!r}") from None
    return obj


class Table:
    """Typed, validated access to one TOML table; messages name the file and the key.

    Parameters
    ----------
    data : mapping
        The table (anything else raises ConfigError).
    where : str
        The table's dotted name in the file (``""`` for the top level, ``"slam"``, ...).
    source : str
        The file (or other source) for messages.
    """

    def __init__(self, data: Any, where: str, source: str):
        if not isinstance(data, Mapping):
            raise ConfigError(f"{source}: {where or 'the file'} must be a table, got {type(data).__name__}")
        self.data, self.where, self.source = data, where, source

    def name(self, key: str) -> str:
        """The dotted name of ``key`` (``slam.particles``)."""
        return f"{self.where}.{key}" if self.where else key

    def error(self, key: str, reason: str) -> ConfigError:
        return ConfigError(f"{self.source}: {self.name(key)} {reason}")

    def has(self, key: str) -> bool:
        return key in self.data

    def get(self, key: str, default: Any = None) -> Any:
        return self.data.get(key, default)

    def int(self, key: str, default: int | None = None, *, minimum: int | None = None) -> int:
        """An integer; required when ``default`` is None."""
        if key not in self.data:
            if default is None:
                raise self.error(key, "is required")
            return default
        return check_int(self.data[key], name=f"{self.source}: {self.name(key)}", minimum=minimum)

    def float(self, key: str, default: float, *, positive: bool = False, minimum: float | None = None,
              maximum: float | None = None) -> float:
        """A finite number (an integer is accepted)."""
        if key not in self.data:
            return default
        return check_number(self.data[key], name=f"{self.source}: {self.name(key)}", positive=positive,
                            minimum=minimum, maximum=maximum)

    def bool(self, key: str, default: bool) -> bool:
        if key not in self.data:
            return default
        v = self.data[key]
        if not isinstance(v, bool):
            raise self.error(key, f"must be true or false, got {v!r}")
        return v

    def str(self, key: str, default: str, *, choices: tuple[str, ...] | None = None) -> str:
        if key not in self.data:
            return default
        v = self.data[key]
        if not isinstance(v, str):
            raise self.error(key, f"must be a string, got {v!r}")
        if choices is not None and v not in choices:
            raise self.error(key, f"must be one of {', '.join(map(repr, choices))}, got {v!r}")
        return v

    def table(self, key: str) -> "Table":
        """The sub-table ``key`` (an empty one when absent)."""
        return Table(self.data.get(key, {}), self.name(key), self.source)

    def check_unknown(self, allowed: tuple[str, ...] | Mapping) -> None:
        """Raise for the first key not in ``allowed``."""
        for key in self.data:
            if key not in allowed:
                raise self.error(key, f"is not a known key (known: {', '.join(allowed)})")


@dataclass(frozen=True)
class Option:
    """One setting of a configuration dataclass as it appears in an experiment file.

    Attributes
    ----------
    key : str
        The key in the file (e.g. ``"std_omega_deg"``).
    degrees : bool
        The file gives degrees; the field holds radians.
    integer : bool
        An integer setting.
    bounds : dict
        Keyword bounds for :func:`check_number` / :func:`check_int` (``minimum``, ``positive``, ...).
    choices : tuple of str, optional
        A string setting with these values (:func:`check_choice`).
    omit_default : bool
        :meth:`Settings.to_options` leaves the setting out while it has its default value, so that
        a setting added later does not change the options (and the hash) of existing experiments.
    """

    key: str
    degrees: bool = False
    integer: bool = False
    bounds: Mapping[str, Any] = field(default_factory=dict)
    choices: tuple[str, ...] | None = None
    omit_default: bool = False

    def check(self, value: Any, *, name: str) -> float | int | str:
        if self.choices is not None:
            return check_choice(value, name=name, choices=self.choices)
        if self.integer:
            return check_int(value, name=name, **self.bounds)
        return check_number(value, name=name, **self.bounds)


class Settings:
    """Mixin of frozen configuration dataclasses whose fields are experiment-file settings.

    A subclass declares ``OPTIONS: ClassVar[dict[str, Option]]`` (field name -> :class:`Option`),
    the one place where each setting's file key, unit and bounds are defined; fields hold SI values.
    The mixin validates every field on construction and converts from and to the file's keys and units.
    """

    OPTIONS: ClassVar[dict[str, Option]] = {}

    def __post_init__(self) -> None:
        for name, option in self.OPTIONS.items():
            value = option.check(getattr(self, name), name=f"{type(self).__name__}.{name}")
            object.__setattr__(self, name, value)

    @classmethod
    def from_options(cls, options: Mapping[str, Any], *, where: str | None = None):
        """An instance from file-shaped ``options`` (missing keys take the defaults).

        ``where`` prefixes every message (e.g. ``"exp.toml: slam"``); default: the class name.
        """
        where = where or cls.__name__
        by_key = {option.key: (name, option) for name, option in cls.OPTIONS.items()}
        kwargs = {}
        for key, value in options.items():
            if key not in by_key:
                raise ConfigError(f"{where}.{key} is not a known key (known: {', '.join(by_key)})")
            name, option = by_key[key]
            x = option.check(value, name=f"{where}.{key}")
            kwargs[name] = math.radians(x) if option.degrees else x
        return cls(**kwargs)

    def to_options(self) -> dict[str, Any]:
        """The file-shaped options of this instance (inverse of :meth:`from_options`).

        Settings declared with ``omit_default`` are left out while they hold their default.
        """
        defaults = {f.name: f.default for f in fields(self)}
        return {option.key: (math.degrees(getattr(self, name)) if option.degrees else getattr(self, name))
                for name, option in self.OPTIONS.items()
                if not (option.omit_default and getattr(self, name) == defaults[name])}


@dataclass(frozen=True)
class ExperimentOverrides:
    """Typed changes a campaign makes to an experiment's settings (``--quick``, a profile, a scale).

    Every field is an experiment file's key with its meaning; ``None`` keeps the experiment's value.
    Each value is checked here on construction (type and range, naming the field); the experiment
    checks the changed whole again (:meth:`faultlab.runner.Experiment.apply`: suite kinds, variant
    names, the SLAM's options).  Combine two with :meth:`then`, change one with
    :func:`dataclasses.replace`.

    Attributes
    ----------
    runs, repetitions, n_steps : int, optional
        Evaluation runs, SLAM repetitions per case (K), active steps per case.
    particles : int, optional
        ``slam.particles``: set in the ``[slam]`` table, whose other settings are kept (a SLAM
        without particles refuses it).
    suites : tuple of (str, int or None), optional
        Replaces ``[suites]``: (kind, cases) in order, ``None`` cases = ``"auto"``.  A mapping is
        accepted.
    variants : tuple of str, optional
        Replaces ``variants``.
    fov_bug : bool, optional
    slam : tuple of (str, value), optional
        Replaces the whole ``[slam]`` table (a mapping is accepted); ``particles`` then applies to it.
    rule : str, optional
        ``detection.rule``, the detection rule's other settings (alpha, family, ...) kept.
    """

    runs: int | None = None
    repetitions: int | None = None
    n_steps: int | None = None
    particles: int | None = None
    suites: tuple[tuple[str, int | None], ...] | None = None
    variants: tuple[str, ...] | None = None
    fov_bug: bool | None = None
    slam: tuple[tuple[str, Any], ...] | None = None
    rule: str | None = None

    def __post_init__(self) -> None:
        def name(key: str) -> str:
            return f"{type(self).__name__}.{key}"

        for key in ("runs", "repetitions", "n_steps", "particles"):
            if getattr(self, key) is not None:
                object.__setattr__(self, key, check_int(getattr(self, key), name=name(key), minimum=1))
        if self.suites is not None:
            items = self.suites.items() if isinstance(self.suites, Mapping) else self.suites
            suites = []
            for item in items:
                if not (isinstance(item, tuple) and len(item) == 2 and isinstance(item[0], str)):
                    raise ConfigError(f"{name('suites')} must map suite kinds to cases, got {self.suites!r}")
                kind, n = item
                suites.append((kind, None if n in (None, "auto")
                               else check_int(n, name=f"{name('suites')}[{kind!r}]", minimum=1)))
            if not suites:
                raise ConfigError(f"{name('suites')} must name at least one suite")
            object.__setattr__(self, "suites", tuple(suites))
        if self.variants is not None:
            if isinstance(self.variants, str) or not all(isinstance(v, str) for v in self.variants) \
                    or not self.variants:
                raise ConfigError(f"{name('variants')} must be a non-empty sequence of names, got {self.variants!r}")
            object.__setattr__(self, "variants", tuple(self.variants))
        if self.fov_bug is not None and not isinstance(self.fov_bug, bool):
            raise ConfigError(f"{name('fov_bug')} must be True or False, got {self.fov_bug!r}")
        if self.slam is not None:
            items = tuple(self.slam.items()) if isinstance(self.slam, Mapping) else tuple(self.slam)
            if not all(isinstance(i, tuple) and len(i) == 2 and isinstance(i[0], str) for i in items):
                raise ConfigError(f"{name('slam')} must be a table of settings, got {self.slam!r}")
            object.__setattr__(self, "slam", items)
        if self.rule is not None and not isinstance(self.rule, str):
            raise ConfigError(f"{name('rule')} must be a rule's name, got {self.rule!r}")

    def then(self, later: "ExperimentOverrides") -> "ExperimentOverrides":
        """These overrides followed by ``later``: a field ``later`` sets wins."""
        return ExperimentOverrides(**{f.name: getattr(self, f.name) if getattr(later, f.name) is None
                                      else getattr(later, f.name) for f in fields(self)})

    def tables(self) -> tuple[dict[str, Any], dict[str, dict[str, Any]]]:
        """The changes as file-shaped keys: (keys that replace the experiment's, tables merged key by key)."""
        replaced: dict[str, Any] = {key: getattr(self, key) for key in ("runs", "repetitions", "n_steps", "fov_bug")
                                    if getattr(self, key) is not None}
        if self.suites is not None:
            replaced["suites"] = {kind: "auto" if n is None else n for kind, n in self.suites}
        if self.variants is not None:
            replaced["variants"] = list(self.variants)
        if self.slam is not None:
            replaced["slam"] = copy.deepcopy(dict(self.slam))
        merged: dict[str, dict[str, Any]] = {}
        if self.particles is not None:
            merged["slam"] = {"particles": self.particles}
        if self.rule is not None:
            merged["detection"] = {"rule": self.rule}
        return replaced, merged
