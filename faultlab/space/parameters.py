"""The parameter space of Table I as data: parameters, equivalence classes, classification.

Each of the 11 parameters (Sec. V) has a *kind*:

- ``categorical`` (directionality): every class is one label (``random``, ``loop``);
- ``discrete`` (rotation error, inactivity): every class is a finite set of values
  (``{0}``, ``{2 pi}``, ``{-2 pi}``; ``{0}``, ``{2000}``);
- ``continuous``: every class is an interval per component; one component for map
  size, landmark density, step size, symmetry, outlier probability and field of
  view, two (distance, angle) for variance and bias.  An interval with
  ``lo == hi`` in every component is a *point class* (the ``{0}`` classes).

Classification of a value (``classify``): point classes take precedence;
intervals are half-open ``[lo, hi)`` except the topmost (largest ``hi`` of the
component), which is closed; a zero-width component ``[lo, lo]`` contains
``lo``.  A two-component value belongs to a class only if both components lie
in that class.  Values in no class get ``-1``.

Boundaries and classes can be overridden from a TOML file (:func:`load_space`,
format documented in ``experiments/space_table1.toml``) or a mapping
(:func:`space_from_mapping`).  Besides the parameters, a space file may hold
``[constraints]`` (forbidden class combinations, :mod:`faultlab.space.constraints`),
``[base]`` and ``[weights]`` (settings of the base-choice and effect-guided suites,
:mod:`faultlab.space.settings`).  Malformed input raises one
:class:`~faultlab.errors.ConfigError` naming the file and the key.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, replace
from enum import StrEnum
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from faultlab.config import read_toml
from faultlab.data import resolve_experiment
from faultlab.errors import ConfigError
from faultlab.space.case import FIXED_VALUES, PARAMETER_NAMES, VALUE_KEYS
from faultlab.space.constraints import ClassStructure, Constraint, check_constraints, parse_constraints, structure_of
from faultlab.space.settings import parse_base, parse_weights

__all__ = [
    "Kind",
    "EquivalenceClass",
    "Parameter",
    "ParameterSpace",
    "table1_space",
    "load_space",
    "space_from_mapping",
    "DIRECTIONALITY_LABELS",
]

#: Labels the scenario generator understands (Sec. VI-B).
DIRECTIONALITY_LABELS: tuple[str, ...] = ("random", "loop")

_TWO_PI = 2.0 * math.pi


class Kind(StrEnum):
    """How a parameter's classes are described and drawn."""

    CATEGORICAL = "categorical"
    DISCRETE = "discrete"
    CONTINUOUS = "continuous"


@dataclass(frozen=True)
class EquivalenceClass:
    """One equivalence class of a parameter.

    Attributes
    ----------
    name : str
        Class name (e.g. ``"small"``), unique within the parameter.
    values : tuple
        Categorical: ``(label,)``.  Discrete: the value set (at least one value).
        Continuous: empty.
    bounds : tuple of (float, float)
        Continuous: ``(lo, hi)`` per component (``lo <= hi``).  Otherwise empty.
    """

    name: str
    values: tuple = ()
    bounds: tuple[tuple[float, float], ...] = ()

    @property
    def is_point(self) -> bool:
        """True for a continuous class with ``lo == hi`` in every component."""
        return bool(self.bounds) and all(lo == hi for lo, hi in self.bounds)

    @property
    def is_atom(self) -> bool:
        """True if the class carries no length (categorical, discrete or point class)."""
        return not self.bounds or self.is_point

    @property
    def length(self) -> float:
        """Length of the primary (first) component's interval; 0 for atoms."""
        if not self.bounds:
            return 0.0
        lo, hi = self.bounds[0]
        return float(hi - lo)


@dataclass(frozen=True)
class Parameter:
    """One row of Table I.

    Attributes
    ----------
    name : str
        One of :data:`~faultlab.space.case.PARAMETER_NAMES`.
    kind : Kind
    keys : tuple of str
        The :class:`~faultlab.space.case.CaseSpec` value keys this parameter sets
        (two for variance and bias: distance and angle component).
    classes : tuple of EquivalenceClass
        In Table I order; the class index is the position in this tuple.
    integer : bool
        Values are integers (inactivity steps).
    """

    name: str
    kind: Kind
    keys: tuple[str, ...]
    classes: tuple[EquivalenceClass, ...]
    integer: bool = False

    @property
    def n_classes(self) -> int:
        return len(self.classes)

    @property
    def class_names(self) -> tuple[str, ...]:
        return tuple(c.name for c in self.classes)

    @property
    def units(self) -> tuple[str, ...]:
        return tuple(VALUE_KEYS[k] for k in self.keys)

    @property
    def components(self) -> tuple[str, ...]:
        """Component names used in TOML: ``("distance", "angle")`` or ``()`` for one value."""
        if len(self.keys) == 1:
            return ()
        return tuple(k[len(self.name) + 1:] for k in self.keys)

    def index(self, class_name: str) -> int:
        """Index of the class called ``class_name``."""
        try:
            return self.class_names.index(class_name)
        except ValueError:
            raise ConfigError(f"parameter {self.name} has no class {class_name!r} "
                              f"(classes: {', '.join(self.class_names)})") from None

    # -- classification -------------------------------------------------
    def _tops(self) -> list[float]:
        """Largest upper bound per component over the non-point classes."""
        his = [c.bounds for c in self.classes if not c.is_point]
        if not his:
            return [math.inf] * len(self.keys)
        return [max(b[j][1] for b in his) for j in range(len(self.keys))]

    def classify(self, values: Mapping[str, Any]) -> int:
        """Index of the class containing this parameter's value(s) in ``values``, or -1.

        Parameters
        ----------
        values : mapping
            Case values keyed by :attr:`keys` (extra keys are ignored).
        """
        if self.kind is Kind.CATEGORICAL:
            v = str(values[self.keys[0]])
            for i, c in enumerate(self.classes):
                if v in c.values:
                    return i
            return -1
        try:
            x = [float(values[k]) for k in self.keys]
        except (TypeError, ValueError):
            return -1
        if self.kind is Kind.DISCRETE:
            for i, c in enumerate(self.classes):
                if any(math.isclose(x[0], s, rel_tol=1e-12, abs_tol=1e-12) for s in c.values):
                    return i
            return -1
        for i, c in enumerate(self.classes):  # point classes take precedence
            if c.is_point and all(xj == lo for xj, (lo, _) in zip(x, c.bounds)):
                return i
        tops = self._tops()
        for i, c in enumerate(self.classes):
            if c.is_point:
                continue
            if all(_contains(xj, lo, hi, top) for xj, (lo, hi), top in zip(x, c.bounds, tops)):
                return i
        return -1

    # -- drawing ----------------------------------------------------------
    def draw(self, index: int, rng: np.random.Generator) -> dict[str, float | int | str]:
        """Draw a value uniformly inside class ``index`` (Sec. VI).

        Continuous classes: every component uniform in its interval (all
        components from the same class); draws that would classify into another
        class (a value exactly on a shared, excluded boundary) are repeated.
        Discrete classes: uniform over the value set.

        Returns
        -------
        dict
            Value key -> value, in Table I units.
        """
        c = self.classes[index]
        if self.kind is Kind.CATEGORICAL:
            return {self.keys[0]: c.values[int(rng.integers(len(c.values)))] if len(c.values) > 1
                    else c.values[0]}
        if self.kind is Kind.DISCRETE:
            v = c.values[int(rng.integers(len(c.values)))] if len(c.values) > 1 else c.values[0]
            return {self.keys[0]: int(v) if self.integer else float(v)}
        for _ in range(100):
            out = {k: float(lo if lo == hi else rng.uniform(lo, hi)) for k, (lo, hi) in zip(self.keys, c.bounds)}
            if self.classify(out) == index:
                return out
        raise ConfigError(f"parameter {self.name}: cannot draw a value inside class {c.name!r} "
                          f"(its interval is covered by other classes)")

    def random_weights(self) -> np.ndarray:
        """Class probabilities of the *random* suite, shape (n_classes,).

        Atoms (categorical/discrete/point classes) get ``1 / n_classes`` each;
        the remaining mass is spread over the interval classes proportionally
        to the length of their primary component, so that class choice plus a
        uniform draw inside the class is a uniform draw over the union of the
        intervals.
        """
        n = self.n_classes
        atoms = np.array([c.is_atom for c in self.classes])
        w = np.where(atoms, 1.0 / n, 0.0)
        if atoms.all():
            return np.full(n, 1.0 / n)
        lengths = np.array([0.0 if a else c.length for a, c in zip(atoms, self.classes)])
        rest = 1.0 - atoms.sum() / n
        if lengths.sum() > 0:
            w = w + rest * lengths / lengths.sum()
        else:
            w = w + np.where(atoms, 0.0, rest / (~atoms).sum())
        return w / w.sum()

    # -- serialisation -----------------------------------------------------
    def to_dict(self) -> dict:
        """The parameter's table in the TOML override format (JSON-serialisable)."""
        if self.kind is Kind.CATEGORICAL:
            return {"classes": [c.values[0] for c in self.classes]}
        if self.kind is Kind.DISCRETE:
            conv = int if self.integer else float
            return {"classes": {c.name: [conv(v) for v in c.values] for c in self.classes}}
        if not self.components:
            return {"classes": {c.name: [lo, hi] for c in self.classes for (lo, hi) in c.bounds}}
        return {"classes": {c.name: {comp: [lo, hi] for comp, (lo, hi) in zip(self.components, c.bounds)}
                            for c in self.classes}}


def _contains(x: float, lo: float, hi: float, top: float) -> bool:
    """Half-open [lo, hi); closed if ``hi`` is the topmost bound or the interval has zero width."""
    if lo <= x < hi:
        return True
    return x == hi and (hi == top or lo == hi)


@dataclass(frozen=True)
class ParameterSpace:
    """The 11 parameters with their classes (Table I, possibly overridden).

    Attributes
    ----------
    parameters : tuple of Parameter
        In :data:`~faultlab.space.case.PARAMETER_NAMES` order.
    source : str
        Where the space came from ("Table I" or the override file), for messages.
    constraints : tuple of Constraint
        Forbidden class combinations (:mod:`faultlab.space.constraints`); none in Table I.
    base : tuple of (str, str)
        Base classes that replace the default ones (:meth:`base_classes`), by parameter.
    weights : tuple of (str, tuple of float)
        Class weights of the effect-guided suite, by parameter, in class order
        (:mod:`faultlab.space.settings`); unlisted parameters have equal weights.
    """

    parameters: tuple[Parameter, ...]
    source: str = "Table I"
    constraints: tuple[Constraint, ...] = ()
    base: tuple[tuple[str, str], ...] = ()
    weights: tuple[tuple[str, tuple[float, ...]], ...] = ()

    def __post_init__(self) -> None:
        names = tuple(p.name for p in self.parameters)
        if names != PARAMETER_NAMES:
            raise ConfigError(f"{self.source}: a parameter space needs the parameters "
                              f"{', '.join(PARAMETER_NAMES)} in this order, got {', '.join(names)}")
        if self.constraints:
            check_constraints(self.parameters, self.constraints, source=self.source)
        for name, cls in self.base:
            if cls not in self[name].class_names:
                raise ConfigError(f"{self.source}: [base].{name}: the space has no class {cls!r} "
                                  f"(classes: {', '.join(self[name].class_names)})")
        for name, ws in self.weights:
            if len(ws) != self[name].n_classes:
                raise ConfigError(f"{self.source}: [weights].{name}: {len(ws)} weights for "
                                  f"{self[name].n_classes} classes")

    def __getitem__(self, name: str) -> Parameter:
        for p in self.parameters:
            if p.name == name:
                return p
        raise KeyError(name)

    def __iter__(self):
        return iter(self.parameters)

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def n_classes(self) -> int:
        """Total number of classes over all parameters (the coverage denominator)."""
        return sum(p.n_classes for p in self.parameters)

    @property
    def min_cases(self) -> int:
        """Smallest suite that can cover every class: the largest class count."""
        return max(p.n_classes for p in self.parameters)

    @property
    def structure(self) -> ClassStructure:
        """Class counts and constraints as indices (what combinatorial builders work on)."""
        return structure_of(self.parameters, self.constraints)

    def classify(self, values: Mapping[str, Any]) -> dict[str, int]:
        """Class index (or -1) of every parameter for a full set of case values."""
        return {p.name: p.classify(values) for p in self.parameters}

    def base_classes(self) -> dict[str, int]:
        """Class index of every parameter in the base case of the base-choice suite.

        A parameter named in :attr:`base` takes that class; every other one the class of its
        :data:`~faultlab.space.case.FIXED_VALUES` value (the *fixed* suite's).

        Raises
        ------
        ConfigError
            If a fixed value lies in no class of the space and no base class is given for it.
        """
        given = dict(self.base)
        fixed = self.classify(FIXED_VALUES)
        out = {}
        for p in self.parameters:
            if p.name in given:
                out[p.name] = p.index(given[p.name])
            elif fixed[p.name] < 0:
                value = ", ".join(f"{FIXED_VALUES[k]!r} {VALUE_KEYS[k]}" for k in p.keys)
                raise ConfigError(f"{self.source}: no base class for {p.name}: the fixed value {value} lies "
                                  f"in no class; name one in [base] (e.g. {p.name} = "
                                  f"\"{p.class_names[0]}\")")
            else:
                out[p.name] = fixed[p.name]
        return out

    def class_weights(self) -> dict[str, np.ndarray] | None:
        """Class weights of every parameter (equal where not given), or None if none are given."""
        if not self.weights:
            return None
        given = dict(self.weights)
        return {p.name: np.array(given.get(p.name, (1.0,) * p.n_classes), dtype=float)
                for p in self.parameters}

    def with_parameter(self, parameter: Parameter) -> "ParameterSpace":
        """A copy with one parameter replaced."""
        return replace(self, parameters=tuple(parameter if p.name == parameter.name else p
                                              for p in self.parameters))

    def with_base(self, base: Mapping[str, str], *, source: str | None = None) -> "ParameterSpace":
        """A copy whose base classes are ``base`` (parameter -> class name) on top of :attr:`base`."""
        merged = {**dict(self.base), **dict(base)}
        return replace(self, base=parse_base(merged, self.parameters, source=source or self.source))

    def with_weights(self, weights: Mapping[str, Mapping[str, float]], *,
                     source: str | None = None) -> "ParameterSpace":
        """A copy with the class weights ``{parameter: {class: weight}}`` (replacing :attr:`weights`)."""
        return replace(self, weights=parse_weights(weights, self.parameters, source=source or self.source,
                                                   table="" if source else "[weights]"))

    def to_dict(self) -> dict:
        """Every parameter in the override format (and any constraints, base classes, weights);
        ``space_from_mapping`` reads it back."""
        out: dict = {p.name: p.to_dict() for p in self.parameters}
        if self.constraints:
            out["constraints"] = {"forbid": [c.to_dict() for c in self.constraints]}
        if self.base:
            out["base"] = dict(self.base)
        if self.weights:
            out["weights"] = {name: dict(zip(self[name].class_names, ws)) for name, ws in self.weights}
        return out


# ---------------------------------------------------------------------------
# Table I
# ---------------------------------------------------------------------------

def _cont(name: str, keys: tuple[str, ...], classes: list[tuple[str, list[tuple[float, float]]]]) -> Parameter:
    return Parameter(name, Kind.CONTINUOUS, keys,
                     tuple(EquivalenceClass(n, bounds=tuple((float(a), float(b)) for a, b in bs))
                           for n, bs in classes))


def table1_space() -> ParameterSpace:
    """The default parameter space: Table I of the paper, in its units."""
    pi = math.pi
    params = (
        Parameter("directionality", Kind.CATEGORICAL, ("directionality",),
                  (EquivalenceClass("random", values=("random",)), EquivalenceClass("loop", values=("loop",)))),
        Parameter("rotation_error", Kind.DISCRETE, ("rotation_error",),
                  (EquivalenceClass("none", values=(0.0,)), EquivalenceClass("positive", values=(2 * pi,)),
                   EquivalenceClass("negative", values=(-2 * pi,)))),
        Parameter("inactivity", Kind.DISCRETE, ("inactivity",),
                  (EquivalenceClass("none", values=(0,)), EquivalenceClass("inactive", values=(2000,))),
                  integer=True),
        _cont("map_size", ("map_size",),
              [("small", [(4, 16)]), ("medium", [(16, 100)]), ("large", [(100, 400)])]),
        _cont("landmark_density", ("landmark_density",),
              [("low", [(1, 3)]), ("medium", [(3, 9)]), ("high", [(9, 15)])]),
        _cont("step_size", ("step_size",),
              [("small", [(25, 50)]), ("medium", [(50, 100)]), ("large", [(100, 200)])]),
        _cont("symmetry", ("symmetry",),
              [("low", [(0, 10)]), ("medium", [(10, 60)]), ("high", [(60, 90)])]),
        _cont("outlier_probability", ("outlier_probability",),
              [("none", [(0, 0)]), ("low", [(0, 5)]), ("high", [(5, 15)])]),
        _cont("field_of_view", ("field_of_view",),
              [("small", [(pi / 2, pi)]), ("large", [(pi, 2 * pi)])]),
        _cont("variance", ("variance_distance", "variance_angle"),
              [("none", [(0, 0), (0, 0)]), ("low", [(0, 20), (0, 0.04)]), ("high", [(20, 100), (0.04, 0.2)])]),
        _cont("bias", ("bias_distance", "bias_angle"),
              [("high_neg", [(-25, -10), (-0.05, -0.02)]), ("low_neg", [(-10, 0), (-0.02, 0)]),
               ("none", [(0, 0), (0, 0)]), ("low_pos", [(0, 10), (0, 0.02)]),
               ("high_pos", [(10, 25), (0.02, 0.05)])]),
    )
    return ParameterSpace(params, source="Table I")


#: Admissible values per value key (closed intervals), checked for overrides.
_DOMAINS: dict[str, tuple[float, float]] = {
    "map_size": (0.0, math.inf),
    "landmark_density": (0.0, math.inf),
    "step_size": (0.0, math.inf),
    "symmetry": (0.0, 100.0),
    "outlier_probability": (0.0, 100.0),
    "field_of_view": (0.0, _TWO_PI),
    "variance_distance": (0.0, math.inf),
    "variance_angle": (0.0, math.inf),
    "bias_distance": (-math.inf, math.inf),
    "bias_angle": (-math.inf, math.inf),
    "inactivity": (0.0, math.inf),
    "rotation_error": (-math.inf, math.inf),
}

# ---------------------------------------------------------------------------
# Overrides (TOML)
# ---------------------------------------------------------------------------

_PI_EXPR = re.compile(r"^\s*([+-]?)\s*(\d+(?:\.\d*)?|\.\d+)?\s*\*?\s*pi\s*(?:/\s*(\d+(?:\.\d*)?|\.\d+))?\s*$")


def _number(raw: Any, where: str) -> float:
    """A finite number from TOML: int, float, or a multiple of pi written as a string ("pi/2", "-2pi")."""
    if isinstance(raw, bool):
        raise ConfigError(f"{where}: expected a number, got the boolean {str(raw).lower()}")
    if isinstance(raw, (int, float)):
        x = float(raw)
    elif isinstance(raw, str):
        m = _PI_EXPR.match(raw)
        if not m:
            raise ConfigError(f"{where}: expected a number or a multiple of pi such as \"pi/2\" or "
                              f"\"-2pi\", got the string {raw!r}")
        sign, factor, divisor = m.groups()
        x = (float(factor) if factor else 1.0) * math.pi
        if divisor:
            if float(divisor) == 0:
                raise ConfigError(f"{where}: division by zero in {raw!r}")
            x = x / float(divisor)
        x = -x if sign == "-" else x
    else:
        raise ConfigError(f"{where}: expected a number, got {type(raw).__name__} {raw!r}")
    if not math.isfinite(x):
        raise ConfigError(f"{where}: expected a finite number, got {raw!r}")
    return x


def _interval(raw: Any, where: str) -> tuple[float, float]:
    """A class interval: a number (point class) or a list [lower, upper]."""
    if isinstance(raw, list):
        if len(raw) != 2:
            raise ConfigError(f"{where}: expected [lower, upper] or a single number, got a list of "
                              f"{len(raw)} values")
        lo, hi = _number(raw[0], where), _number(raw[1], where)
        if lo > hi:
            raise ConfigError(f"{where}: lower bound {raw[0]} > upper bound {raw[1]}")
        return lo, hi
    x = _number(raw, where)
    return x, x


def _check_domain(key: str, x: float, where: str, unit: str) -> None:
    lo, hi = _DOMAINS[key]
    if not lo <= x <= hi:
        raise ConfigError(f"{where}: value {x:g} {unit} is outside the admissible range "
                          f"[{lo:g}, {hi:g}] of {key}")


def _parse_parameter(base: Parameter, table: Any, where: str) -> Parameter:
    """``base`` with the classes of one ``[parameter]`` table of a space file."""
    if not isinstance(table, Mapping):
        raise ConfigError(f"{where}: expected a table with a 'classes' entry, got {type(table).__name__}")
    unknown = [k for k in table if k != "classes"]
    if unknown:
        raise ConfigError(f"{where}.{unknown[0]}: unknown key (a parameter table has only 'classes')")
    if "classes" not in table:
        raise ConfigError(f"{where}: missing 'classes'")
    raw, where = table["classes"], f"{where}.classes"
    if base.kind is Kind.CATEGORICAL:
        return replace(base, classes=_categorical_classes(raw, where))
    if not isinstance(raw, Mapping):
        raise ConfigError(f"{where}: expected a table of named classes, got {type(raw).__name__}")
    if not raw:
        raise ConfigError(f"{where}: no classes (empty table)")
    if base.kind is Kind.DISCRETE:
        return replace(base, classes=_discrete_classes(base, raw, where))
    return replace(base, classes=_interval_classes(base, raw, where))


def _categorical_classes(raw: Any, where: str) -> tuple[EquivalenceClass, ...]:
    """One class per label: ``["random", "loop"]``."""
    if not isinstance(raw, list) or not all(isinstance(x, str) for x in raw):
        raise ConfigError(f"{where}: expected a list of labels such as [\"random\", \"loop\"]")
    if not raw:
        raise ConfigError(f"{where}: no classes (empty list)")
    for x in raw:
        if x not in DIRECTIONALITY_LABELS:
            raise ConfigError(f"{where}: unknown label {x!r} (the generator knows "
                              f"{', '.join(DIRECTIONALITY_LABELS)})")
    if len(set(raw)) != len(raw):
        raise ConfigError(f"{where}: a label appears twice (overlapping classes)")
    return tuple(EquivalenceClass(x, values=(x,)) for x in raw)


def _discrete_classes(base: Parameter, raw: Mapping, where: str) -> tuple[EquivalenceClass, ...]:
    """Value sets: ``{ none = [0], positive = ["2pi", "4pi"] }``; no value in two classes."""
    key = base.keys[0]
    classes = []
    for name, spec in raw.items():
        w = f"{where}.{name}"
        items = spec if isinstance(spec, list) else [spec]
        if not items:
            raise ConfigError(f"{w}: empty class (no values)")
        classes.append(EquivalenceClass(str(name), values=tuple(_discrete_value(base, key, x, w) for x in items)))
    for i, a in enumerate(classes):
        for b in classes[i + 1:]:
            if any(math.isclose(x, y, rel_tol=1e-12, abs_tol=1e-12) for x in a.values for y in b.values):
                raise ConfigError(f"{where}: classes {a.name!r} and {b.name!r} overlap "
                                  f"(they share a value)")
    return tuple(classes)


def _discrete_value(base: Parameter, key: str, x: Any, where: str) -> float | int:
    if base.integer and (isinstance(x, bool) or not isinstance(x, int)):
        raise ConfigError(f"{where}: expected whole numbers of steps, got {x!r}")
    v = _number(x, where)
    _check_domain(key, v, where, VALUE_KEYS[key])
    if key == "rotation_error" and not math.isclose(v / _TWO_PI, round(v / _TWO_PI), abs_tol=1e-9):
        raise ConfigError(f"{where}: a rotation error must be a multiple of 2 pi, got {x!r}")
    return int(x) if base.integer else v


def _interval_classes(base: Parameter, raw: Mapping, where: str) -> tuple[EquivalenceClass, ...]:
    """Intervals (or point classes), one per component for two-component parameters."""
    comps = base.components
    classes = []
    for name, spec in raw.items():
        w = f"{where}.{name}"
        if comps:
            bounds, ws = _component_bounds(comps, spec, w)
        else:
            bounds, ws = (_interval(spec, w),), [w]
        for key, (lo, hi), wc in zip(base.keys, bounds, ws):
            _check_domain(key, lo, wc, VALUE_KEYS[key])
            _check_domain(key, hi, wc, VALUE_KEYS[key])
        classes.append(EquivalenceClass(str(name), bounds=bounds))
    for i, a in enumerate(classes):
        for b in classes[i + 1:]:
            if a.is_point and b.is_point and a.bounds == b.bounds:
                raise ConfigError(f"{where}: classes {a.name!r} and {b.name!r} overlap (the same point)")
            if a.is_point or b.is_point:
                continue  # a point class takes precedence over an interval it touches
            if all(max(la, lb) < min(ha, hb) for (la, ha), (lb, hb) in zip(a.bounds, b.bounds)):
                raise ConfigError(f"{where}: classes {a.name!r} and {b.name!r} overlap "
                                  f"(intervals may share an endpoint only)")
    return tuple(classes)


def _component_bounds(comps: tuple[str, ...], spec: Any, where: str) -> tuple[tuple, list[str]]:
    """The intervals of a two-component class: ``{ distance = [0, 20], angle = [0, 0.04] }``."""
    if not isinstance(spec, Mapping):
        raise ConfigError(f"{where}: expected a table {{ {' = [lo, hi], '.join(comps)} = [lo, hi] }}, "
                          f"got {type(spec).__name__}")
    extra = [k for k in spec if k not in comps]
    if extra:
        raise ConfigError(f"{where}.{extra[0]}: unknown component (expected {', '.join(comps)})")
    missing = [k for k in comps if k not in spec]
    if missing:
        raise ConfigError(f"{where}: missing component {missing[0]!r}")
    return tuple(_interval(spec[c], f"{where}.{c}") for c in comps), [f"{where}.{c}" for c in comps]


#: Tables of a space file besides the parameters, in the order they are read.
SETTINGS_TABLES: tuple[str, ...] = ("constraints", "base", "weights")


def space_from_mapping(mapping: Mapping[str, Any], *, source: str,
                       base: ParameterSpace | None = None) -> ParameterSpace:
    """Table I (or ``base``) with the parameters in ``mapping`` replaced.

    Parameters
    ----------
    mapping : mapping
        Parameter name -> table ``{"classes": ...}`` in the format of
        ``experiments/space_table1.toml``.  Parameters not given keep their
        classes (partial override).  Besides the parameters: ``constraints``
        (forbidden class combinations, :mod:`faultlab.space.constraints`),
        ``base`` (base classes) and ``weights`` (class weights,
        :mod:`faultlab.space.settings`), read against the final classes.
    source : str
        Names the file (and table) in error messages, e.g. ``"experiments/x.toml [space]"``.
    base : ParameterSpace, optional
        Space to override; Table I by default.

    Raises
    ------
    ConfigError
        Unknown parameter, wrong type, lower > upper, empty or overlapping
        classes, a value outside the parameter's admissible range, a malformed
        constraint, base class or weight.
    """
    space = base or table1_space()
    if not isinstance(mapping, Mapping):
        raise ConfigError(f"{source}: expected a table of parameters, got {type(mapping).__name__}")
    for name, table in mapping.items():
        if name in SETTINGS_TABLES:
            continue
        if name not in PARAMETER_NAMES:
            raise ConfigError(f"{source}: [{name}]: unknown parameter (known: {', '.join(PARAMETER_NAMES)}; "
                              f"besides them a space file has the tables {', '.join(SETTINGS_TABLES)})")
        space = space.with_parameter(_parse_parameter(space[name], table, f"{source}: [{name}]"))
    settings = {}
    if "constraints" in mapping:
        settings["constraints"] = parse_constraints(mapping["constraints"], space.parameters, source=source)
    if "base" in mapping:
        settings["base"] = parse_base(mapping["base"], space.parameters, source=source)
    if "weights" in mapping:
        settings["weights"] = parse_weights(mapping["weights"], space.parameters, source=source)
    return replace(space, source=str(source), **settings)


def load_space(path: str | Path) -> ParameterSpace:
    """Read a TOML override file (see ``experiments/space_table1.toml``) on top of Table I.

    Parameters
    ----------
    path : str or Path
        A file, or the name of a shipped file (``"space_table1"``, Table I written out;
        see :func:`faultlab.data.resolve_experiment`).

    Raises
    ------
    ConfigError
        If the file is missing (or the name unknown), not valid TOML, or malformed (see
        :func:`space_from_mapping`).
    """
    file = resolve_experiment(path, what="parameter-space file")
    data, _ = read_toml(file, what="parameter-space file")
    return space_from_mapping(data, source=str(path))
