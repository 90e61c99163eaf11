"""The SLAMs faultlab ships, by the name an experiment file uses, and how each is configured.

An experiment's ``[slam]`` table names a SLAM: a built-in name from :data:`BUILTIN_SLAMS`, the name of
a SLAM a third-party distribution declares in the ``faultlab.slams`` entry-point group (a
:class:`SlamKind`, or an iterable of them; :func:`all_slams`), or an import path ``"package.module:factory"`` whose factory is called with the table's ``options`` as
keyword arguments.  A built-in SLAM with settings has a config class with
``from_options(mapping, *, where)`` and ``to_options()`` (the file's keys and units), which is
the one place its keys, defaults and bounds are defined.  A built-in SLAM written as replaceable
units names its steps table (:attr:`SlamKind.steps`), whose fields are the units a fault can
replace (:func:`faultlab.faults.applicability.applicable_faults`).

``fastslam`` and ``fastslam2`` take ``association = "unknown"``: the ids are hidden and the filter
associates observations itself (:mod:`faultlab.slam.association`; :attr:`SlamKind.unknown` is the
adapter of that mode, whose units differ: :func:`SlamKind.steps_for`).

``fastslam`` also takes ``profile`` (:mod:`faultlab.slam.profiles`: ``"reference"``, the default,
``"paper"``, ``"paper_no_aliasing"``): the profile gives the units and the default settings, and the
table's other keys override the profile's settings.  A non-default profile is kept in the options
(and so in the experiment's hash); ``"reference"`` is dropped, so naming it changes nothing.
"""

from __future__ import annotations

import importlib.util
from collections.abc import Callable, Mapping
from types import MappingProxyType
from dataclasses import dataclass, fields
from typing import Any

from faultlab.config import import_object
from faultlab.errors import ConfigError, UnknownPluginError
from faultlab.plugins import PluginCatalogue
from faultlab.slam.association import FastSlam2Unknown, FastSlamUnknown
from faultlab.slam.deadreckoning import DeadReckoning
from faultlab.slam.ekf import EkfSlam, EkfSlamConfig, EkfSlamSteps
from faultlab.slam.fastslam import FastSlam, FastSlamConfig, FastSlamSteps
from faultlab.slam.fastslam2 import FastSlam2, FastSlam2Steps
from faultlab.slam.gtsam import GtsamSlam, GtsamSlamConfig
from faultlab.slam.process import ProcessSlam, ProcessSlamConfig
from faultlab.slam.profiles import DEFAULT_PROFILE, get_profile
from faultlab.slam.protocol import SlamAdapter
from faultlab.vocabulary import KNOWN_ASSOCIATION, UNKNOWN_ASSOCIATION

__all__ = ["SlamKind", "BUILTIN_SLAMS", "SLAM_ENTRY_POINT_GROUP", "SlamPluginWarning", "load_slam_plugins", "all_slams",
           "get_slam_kind", "build_slam", "normalise_options"]


@dataclass(frozen=True)
class SlamKind:
    """A SLAM by name: built-in, or declared by a third-party distribution (``faultlab.slams``).

    Attributes
    ----------
    name : str
        The name an experiment's ``[slam] name`` uses.
    description : str
        One line.
    adapter : callable
        ``adapter(config)`` (or ``adapter()`` when ``config`` is None) returns a fresh :class:`SlamAdapter`.
    config : type or None
        Its settings: a class with ``from_options(mapping, *, where)`` and ``to_options()``.
    steps : type or None
        Its steps table (a frozen dataclass whose fields are the replaceable units, e.g.
        :class:`~faultlab.slam.FastSlamSteps`); None for a SLAM without replaceable units, to
        which no fault applies.
    requires : str or None
        An optional dependency the SLAM needs, named as both its module and faultlab's extra
        (``"gtsam"``: ``pip install "faultlab[gtsam]"``); building the SLAM without it raises
        :class:`~faultlab.errors.ConfigError`.
    profiles : bool
        Whether it takes a ``profile`` option (:mod:`faultlab.slam.profiles`; FastSLAM 1.0 only).
    unknown : callable or None
        ``unknown(config)``: the adapter of the unknown-data-association mode (``association =
        "unknown"`` in the options); None if the SLAM has no such mode.
    """

    name: str
    description: str
    adapter: Callable[..., SlamAdapter]
    config: type | None = None
    steps: type | None = None
    requires: str | None = None
    profiles: bool = False
    unknown: Callable[..., SlamAdapter] | None = None

    @property
    def available(self) -> bool:
        """True unless the optional dependency in :attr:`requires` is missing (checked without importing it)."""
        return self.requires is None or importlib.util.find_spec(self.requires) is not None

    @property
    def units(self) -> tuple[str, ...]:
        """Names of the replaceable units (the fields of :attr:`steps`), in algorithm order; () if none."""
        return () if self.steps is None else tuple(f.name for f in fields(self.steps))

    def _split(self, options: Mapping[str, Any], *, where: str = "slam"):
        """(profile or None, the other options); the profile name is checked here."""
        options = dict(options)
        if not self.profiles or "profile" not in options:
            return None, options
        name = options.pop("profile")
        try:
            return get_profile(name), options
        except ConfigError as exc:
            raise ConfigError(f"{where}.profile: {exc}") from exc

    def options(self, options: Mapping[str, Any], *, where: str) -> dict[str, Any]:
        """``options`` validated, with every default filled in (file keys and units)."""
        if self.config is None:
            if options:
                raise ConfigError(f"{where}.{next(iter(options))} is not accepted by {self.name!r} "
                                  f"(it has no settings)")
            return {}
        profile, rest = self._split(options, where=where)
        settings = self.config.from_options(rest, where=where)  # validates
        if getattr(settings, "association", KNOWN_ASSOCIATION) == UNKNOWN_ASSOCIATION:
            if self.unknown is None:
                raise ConfigError(f"{where}.association: {self.name!r} has no unknown-association mode")
            if profile is not None and profile.name != DEFAULT_PROFILE:
                raise ConfigError(f"{where}.association: 'unknown' cannot be combined with profile "
                                  f"{profile.name!r} (the profiles are known-association filters)")
        defaults = (self.config() if profile is None else profile.config).to_options()
        named = {} if profile is None or profile.name == DEFAULT_PROFILE else {"profile": profile.name}
        return {**named, **defaults, **rest}

    def settings(self, options: Mapping[str, Any]):
        """The settings object of validated ``options`` (None for a SLAM without settings)."""
        if self.config is None:
            return None
        return self.config.from_options(self._split(options)[1])

    def association(self, options: Mapping[str, Any]) -> str:
        """The data association of validated ``options``: ``"known"`` or ``"unknown"``."""
        settings = self.settings(options)
        return getattr(settings, "association", KNOWN_ASSOCIATION)

    def steps_for(self, options: Mapping[str, Any]) -> type | None:
        """The steps table of the SLAM ``options`` build (the unknown-association mode has its own)."""
        if self.association(options) == UNKNOWN_ASSOCIATION:
            return self.unknown.steps_type
        return self.steps

    def build(self, options: Mapping[str, Any]) -> SlamAdapter:
        if self.config is None:
            return self.adapter()
        profile, rest = self._split(options)
        settings = self.config.from_options(rest)
        if getattr(settings, "association", KNOWN_ASSOCIATION) == UNKNOWN_ASSOCIATION:
            return self.unknown(settings)
        if profile is None:
            return self.adapter(self.config.from_options(rest))
        return self.adapter(self.config.from_options(rest), steps=profile.steps)


#: Built-in SLAMs by name (read-only: a new SLAM is declared in the ``faultlab.slams`` entry-point group).
BUILTIN_SLAMS: Mapping[str, SlamKind] = MappingProxyType({
    k.name: k for k in (
        SlamKind("fastslam", "the reference FastSLAM 1.0 (known correspondences)", FastSlam, FastSlamConfig,
                 FastSlamSteps, profiles=True, unknown=FastSlamUnknown),
        SlamKind("fastslam2", "FastSLAM 2.0: poses sampled from the proposal that includes the observations",
                 FastSlam2, FastSlamConfig, FastSlam2Steps, unknown=FastSlam2Unknown),
        SlamKind("ekf", "EKF-SLAM: one joint Gaussian over the pose and every landmark", EkfSlam, EkfSlamConfig,
                 EkfSlamSteps),
        SlamKind("dead_reckoning", "odometry only: the baseline any SLAM should beat", DeadReckoning),
        SlamKind("gtsam", "GTSAM iSAM2: incremental smoothing over all poses with range-bearing factors",
                 GtsamSlam, GtsamSlamConfig, requires="gtsam"),
        SlamKind("process", "a SLAM program in any language, run as a child process speaking line-delimited "
                            "JSON (faultlab.slam.process)", ProcessSlam, ProcessSlamConfig),
    )
})


#: Entry-point group of third-party SLAMs.
SLAM_ENTRY_POINT_GROUP = "faultlab.slams"


class SlamPluginWarning(UserWarning):
    """Issued when a SLAM plugin fails to load."""


class _SlamCatalogue(PluginCatalogue):
    """SLAMs are records (:class:`SlamKind`), not classes: a built-in is recognised by identity."""

    def is_builtin(self, item) -> bool:
        return any(item is b for b in self.builtins)


_CATALOGUE = _SlamCatalogue(kind="SLAM", group=SLAM_ENTRY_POINT_GROUP, base=SlamKind,
                            builtins=tuple(BUILTIN_SLAMS.values()), warning=SlamPluginWarning)

#: ``load_slam_plugins(*, group=None, warn=True)``: discover the third-party SLAMs (in entry-point name
#: order); a :class:`~faultlab.plugins.PluginLoad`.
load_slam_plugins = _CATALOGUE.load
#: ``all_slams(*, plugins=True)``: the built-in SLAMs, then the plugin ones.
all_slams = _CATALOGUE.all


def get_slam_kind(name: str, *, where: str = "slam.name") -> SlamKind | None:
    """The SLAM ``name`` (built-in or plugin); None for an import path; :class:`~faultlab.errors.UnknownPluginError`
    for anything else.

    Every process reads the plugins from the installed distributions' metadata, so a worker process
    of a parallel campaign knows the same SLAMs as the process that started it.
    """
    if name in BUILTIN_SLAMS:
        return BUILTIN_SLAMS[name]
    if isinstance(name, str) and ":" in name:
        return None
    plugins = {k.name: k for k in load_slam_plugins(warn=False).items}
    if isinstance(name, str) and name in plugins:
        return plugins[name]
    raise UnknownPluginError("SLAM", name, [*BUILTIN_SLAMS, *plugins], where=where,
                             note=" (or an import path 'package.module:factory')")


def normalise_options(name: str, options: Mapping[str, Any], *, where: str) -> dict[str, Any]:
    """Validate the options of SLAM ``name`` and fill in its defaults (file keys and units).

    For an import path the factory is imported (it must be callable) and ``options`` are kept as given.
    """
    kind = get_slam_kind(name, where=f"{where}.name")
    if kind is not None:
        return kind.options(options, where=where)
    factory = import_object(name, what=f"{where}.name")
    if not callable(factory):
        raise ConfigError(f"{where}.name = {name!r} is not callable")
    return dict(options)


def build_slam(name: str, options: Mapping[str, Any]) -> SlamAdapter:
    """A fresh SLAM adapter: built-in ``name`` with its options, or ``factory(**options)``."""
    kind = get_slam_kind(name)
    if kind is not None:
        return kind.build(options)
    return import_object(name, what="slam.name")(**dict(options))
