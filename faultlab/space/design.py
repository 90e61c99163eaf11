"""Designed experiments over the parameter space: Morris and Sobol/Saltelli designs from SALib.

A global sensitivity design lives in SALib's *unit problem*: ``d`` factors, each a coordinate
``u`` in ``[0, 1]``.  This module maps a unit point to the values of one test case of a
:class:`~faultlab.space.parameters.ParameterSpace` (Table I or a space file), so SALib's samplers
(:func:`SALib.sample.morris.sample`, :func:`SALib.sample.sobol.sample`) and estimators work on
faultlab's parameters unchanged.

The mapping (one factor per Table I parameter)
-----------------------------------------------
* **Categorical** (directionality) and **discrete** (rotation error, inactivity) parameters: the
  unit interval is cut into ``n`` equal bins, one per value (discrete values sorted by value, so
  rotation error runs ``-2 pi, 0, 2 pi``; a boolean-like parameter such as inactivity has two
  bins, ``none`` below ``u = 1/2``, ``inactive`` above).  ``u`` selects the value of its bin.  On
  Morris' 4-level grid (0, 1/3, 2/3, 1) every jump of ``2/3`` changes the value of a two-valued
  factor, and of a three-valued one by at least one value.
* **Continuous** parameters: every interval class (a class that is not a single point) gets an
  equal share of the unit interval, in the order of its primary component's lower bound, and
  ``u`` maps linearly inside its share.  Equal shares follow Table I's view that every class
  matters equally (the coverage-driven suite), rather than the raw length of the intervals
  (``map_size`` spans 4-400 m^2, its ``small`` class only 12 of them).
* **Variance and bias** (two components, distance and angle, per class): one factor moves both
  components together through the class intervals -- the same relative position ``t`` inside the
  class's distance interval and inside its angle interval -- so every design point lies inside a
  class of the parameter, as every case of a suite does, and the indices are those of Table I's
  parameter (not of a component alone).
* **Point classes** (``{0}`` of variance, bias and outlier probability) are the common end of their
  neighbouring intervals: ``u = 0`` of variance is ``(0 mm, 0 rad)``, the ``none`` class; the
  middle of bias is ``(0, 0)``.  They carry no share of their own (a continuous factor at a point
  class would be a discrete jump), so a Sobol design reaches them only at grid points and a Morris
  design at its levels 0 or 1.
* A parameter that the design does not vary keeps the *fixed* suite's value
  (:data:`~faultlab.space.case.FIXED_VALUES`).
* **Constraints** of a space file: a point whose classes are forbidden is *repaired* before it
  becomes a case: the varied parameters of each violated constraint, last in parameter order
  first, move to the allowed class nearest in ``u`` (ties: the lower class), ``u`` clamped into
  that class's share.  The indices then describe the response over the allowed space, with the
  repaired points counted where the repair puts them; :attr:`Design.repaired` says how many.

Sizes
-----
A Morris design of ``r`` trajectories over ``d`` factors has ``r (d + 1)`` points; a Sobol design
(Saltelli's scheme, first and total order) with base sample ``N`` (a power of two) has
``N (d + 2)`` points.  Impossible sizes raise one :class:`~faultlab.errors.ConfigError`.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from faultlab.errors import ConfigError
from faultlab.seeds import design_seed_sequence
from faultlab.space.case import FIXED_VALUES, PARAMETER_NAMES, CaseSpec
from faultlab.space.parameters import Kind, Parameter, ParameterSpace

__all__ = ["DESIGN_METHODS", "Design", "unit_problem", "unit_to_values", "morris_design", "sobol_design",
           "study_design",
           "design_size", "check_factors", "factor_levels"]

#: Design methods: elementary effects (screening) and Saltelli's scheme for Sobol indices.
DESIGN_METHODS: tuple[str, ...] = ("morris", "sobol")


@dataclass(frozen=True)
class Design:
    """A design: its unit points and the test cases they become.

    Attributes
    ----------
    method : {"morris", "sobol"}
    factors : tuple of str
        The varied parameters (SALib's ``names``), in parameter order.
    unit : ndarray, shape (n_points, n_factors)
        SALib's points in the unit hypercube (before any constraint repair).
    cases : tuple of CaseSpec
        One case per point, in point order.
    levels : int
        Morris grid levels (0 for Sobol).
    base : int
        Morris trajectories, or Sobol's base sample size N.
    repaired : int
        Points moved by a constraint repair.
    """

    method: str
    factors: tuple[str, ...]
    unit: np.ndarray
    cases: tuple[CaseSpec, ...]
    levels: int = 0
    base: int = 0
    repaired: int = 0

    @property
    def n_points(self) -> int:
        return int(self.unit.shape[0])

    @property
    def problem(self) -> dict:
        """SALib's problem dictionary of the design."""
        return unit_problem(self.factors)


def check_factors(factors: Sequence[str] | None, *, where: str = "factors") -> tuple[str, ...]:
    """The factor names in parameter order (None: all 11 parameters).

    Raises
    ------
    ConfigError
        An unknown parameter, a repeated one, or fewer than two.
    """
    if factors is None:
        return PARAMETER_NAMES
    factors = list(factors)
    for f in factors:
        if f not in PARAMETER_NAMES:
            raise ConfigError(f"{where}: unknown parameter {f!r} (parameters: {', '.join(PARAMETER_NAMES)})")
    if len(set(factors)) != len(factors):
        raise ConfigError(f"{where}: a parameter is named twice: {factors!r}")
    if len(factors) < 2:
        raise ConfigError(f"{where}: a sensitivity design needs at least two parameters, got {factors!r}")
    return tuple(p for p in PARAMETER_NAMES if p in factors)


def unit_problem(factors: Sequence[str]) -> dict:
    """SALib's problem: every factor a coordinate in [0, 1]."""
    return {"num_vars": len(factors), "names": list(factors), "bounds": [[0.0, 1.0]] * len(factors)}


def factor_levels(parameter: Parameter) -> int:
    """Number of distinct values of a categorical/discrete parameter (0 for continuous ones)."""
    if parameter.kind is Kind.CONTINUOUS:
        return 0
    return len(_discrete_values(parameter))


def _discrete_values(parameter: Parameter) -> list:
    values = [v for c in parameter.classes for v in c.values]
    if parameter.kind is Kind.DISCRETE:
        values = sorted(values)
    return values


def _intervals(parameter: Parameter) -> list[int]:
    """Indices of the interval (non-point) classes, by their primary lower bound."""
    idx = [i for i, c in enumerate(parameter.classes) if not c.is_point]
    return sorted(idx, key=lambda i: (parameter.classes[i].bounds[0][0], parameter.classes[i].bounds[0][1]))


def _parameter_value(parameter: Parameter, u: float) -> dict:
    """The value(s) of ``parameter`` at unit coordinate ``u`` (module docstring)."""
    u = min(max(float(u), 0.0), 1.0)
    if parameter.kind is not Kind.CONTINUOUS:
        values = _discrete_values(parameter)
        v = values[min(int(u * len(values)), len(values) - 1)]
        if parameter.kind is Kind.CATEGORICAL:
            return {parameter.keys[0]: v}
        return {parameter.keys[0]: int(v) if parameter.integer else float(v)}
    order = _intervals(parameter)
    if not order:  # only point classes: a discrete choice among them
        points = [c.bounds for c in parameter.classes]
        b = points[min(int(u * len(points)), len(points) - 1)]
        return {k: float(lo) for k, (lo, _) in zip(parameter.keys, b)}
    n = len(order)
    j = min(int(u * n), n - 1)
    t = u * n - j
    c = parameter.classes[order[j]]
    return {k: float(lo + t * (hi - lo)) for k, (lo, hi) in zip(parameter.keys, c.bounds)}


def _class_shares(parameter: Parameter) -> list[tuple[int, float, float]]:
    """(class index, u low, u high) of every class: interval classes their share, point classes a point."""
    out = []
    if parameter.kind is not Kind.CONTINUOUS:
        values = _discrete_values(parameter)
        n = len(values)
        for k, v in enumerate(values):
            ci = next(i for i, c in enumerate(parameter.classes) if v in c.values)
            out.append((ci, k / n, (k + 1) / n))
        return out
    order = _intervals(parameter)
    n = len(order)
    for j, ci in enumerate(order):
        out.append((ci, j / n, (j + 1) / n))
    for ci, c in enumerate(parameter.classes):
        if c.is_point:
            for u in np.linspace(0.0, 1.0, 2 * n + 1) if n else [0.0]:
                if parameter.classify(_parameter_value(parameter, u)) == ci:
                    out.append((ci, float(u), float(u)))
                    break
    return out


def unit_to_values(space: ParameterSpace, factors: Sequence[str], u: np.ndarray) -> tuple[CaseSpec, bool]:
    """The case at unit point ``u`` (shape ``(len(factors),)``), and whether a constraint repaired it."""
    u = np.asarray(u, dtype=float).copy()
    values: dict = dict(FIXED_VALUES)
    pos = {f: i for i, f in enumerate(factors)}
    for f, i in pos.items():
        values.update(_parameter_value(space[f], u[i]))
    classes = space.classify(values)
    repaired = False
    structure = space.structure
    if structure.forbidden:
        names = space.names
        row = [classes[p] for p in names]
        for _ in range(len(structure.forbidden) * len(names) + 1):
            if structure.allows(row):
                break
            violated = next(c for c in structure.forbidden
                            if all(row[p] >= 0 and row[p] in cs for p, cs in c))
            movable = [p for p, _ in violated if names[p] in pos]
            if not movable:
                raise ConfigError(f"{space.source}: [constraints] forbid the fixed values of "
                                  f"{', '.join(names[p] for p, _ in violated)}; vary one of them in the design")
            p = movable[-1]
            name = names[p]
            ui = u[pos[name]]
            best = None
            for ci, lo, hi in _class_shares(space[name]):
                trial = list(row)
                trial[p] = ci
                if ci == row[p] or not structure.allows(trial):
                    continue
                top = hi - 1e-9 if lo < hi < 1.0 else hi  # a share is half-open except the last
                target = min(max(ui, lo), top)
                dist = abs(target - ui)
                if best is None or dist < best[0] - 1e-15:
                    best = (dist, target)
            if best is None:
                raise ConfigError(f"{space.source}: [constraints]: no allowed class of {name} for a design point")
            u[pos[name]] = best[1]
            values.update(_parameter_value(space[name], best[1]))
            classes = space.classify(values)
            row = [classes[q] for q in names]
            repaired = True
        else:  # pragma: no cover - every step removes one violation of a feasible space
            raise ConfigError(f"{space.source}: [constraints]: a design point cannot be repaired")
    return CaseSpec(values, classes), repaired


def _cases(space: ParameterSpace, factors: tuple[str, ...], unit: np.ndarray) -> tuple[tuple[CaseSpec, ...], int]:
    out, n_rep = [], 0
    for row in unit:
        case, rep = unit_to_values(space, factors, row)
        out.append(case)
        n_rep += int(rep)
    return tuple(out), n_rep


def design_size(method: str, *, n_factors: int, base: int) -> int:
    """Number of points: ``r (d + 1)`` (Morris, r trajectories) or ``N (d + 2)`` (Sobol, base N)."""
    if method not in DESIGN_METHODS:
        raise ConfigError(f"unknown design method {method!r} (methods: {', '.join(DESIGN_METHODS)})")
    return base * (n_factors + 1) if method == "morris" else base * (n_factors + 2)


def morris_design(space: ParameterSpace, *, rng: np.random.Generator, trajectories: int, levels: int = 4,
                  factors: Sequence[str] | None = None) -> Design:
    """Morris' elementary-effects design (:func:`SALib.sample.morris.sample`) as test cases.

    Parameters
    ----------
    space : ParameterSpace
    rng : numpy.random.Generator
        Passed to SALib as its seed.
    trajectories : int
        Number of trajectories ``r >= 2`` (the bootstrap of mu* resamples them).
    levels : int
        Even number of grid levels ``p >= 2`` (SALib's ``num_levels``; jump ``p / (2 (p - 1))``).
    factors : sequence of str, optional
        Varied parameters (default all 11).

    Raises
    ------
    ConfigError
        Unknown parameters, ``trajectories < 2``, odd or too few levels.
    """
    from SALib.sample import morris

    factors = check_factors(factors)
    if isinstance(trajectories, bool) or not isinstance(trajectories, int) or trajectories < 2:
        raise ConfigError(f"a Morris design needs at least 2 trajectories (mu* and its bootstrap interval "
                          f"come from their spread), got {trajectories!r}")
    if isinstance(levels, bool) or not isinstance(levels, int) or levels < 2 or levels % 2:
        raise ConfigError(f"Morris levels must be an even integer >= 2, got {levels!r}")
    unit = morris.sample(unit_problem(factors), trajectories, num_levels=levels, seed=rng)
    cases, n_rep = _cases(space, factors, unit)
    return Design("morris", factors, unit, cases, levels=levels, base=trajectories, repaired=n_rep)


def sobol_design(space: ParameterSpace, *, rng: np.random.Generator, base: int,
                 factors: Sequence[str] | None = None) -> Design:
    """Saltelli's design for first- and total-order Sobol indices (:func:`SALib.sample.sobol.sample`).

    Parameters
    ----------
    space : ParameterSpace
    rng : numpy.random.Generator
        Scrambles SALib's Sobol' sequence.
    base : int
        Base sample size ``N``, a power of two >= 4 (Sobol' sequences balance only then).
    factors : sequence of str, optional
        Varied parameters (default all 11); typically those Morris screening keeps.

    Raises
    ------
    ConfigError
        Unknown parameters, ``base`` not a power of two >= 4.
    """
    from SALib.sample import sobol

    factors = check_factors(factors)
    if isinstance(base, bool) or not isinstance(base, int) or base < 4 or base & (base - 1):
        raise ConfigError(f"a Sobol design needs a base sample size N that is a power of two >= 4 "
                          f"(its {len(factors) + 2} N points are then balanced), got {base!r}")
    unit = sobol.sample(unit_problem(factors), base, calc_second_order=False, scramble=True, seed=rng)
    cases, n_rep = _cases(space, factors, unit)
    return Design("sobol", factors, unit, cases, base=base, repaired=n_rep)



def study_design(space: ParameterSpace, method: str, *, seed: int, trajectories: int = 0, levels: int = 4,
                 base: int = 0, factors: Sequence[str] | None = None) -> Design:
    """The design of an effects study's stage, drawn from :func:`faultlab.seeds.design_seed_sequence`.

    ``method`` ``"morris"`` uses ``trajectories`` and ``levels``, ``"sobol"`` uses ``base``; the same
    arguments always give the same design (the campaign that runs it and the analysis that reads it
    rebuild it from the study's settings).
    """
    rng = np.random.default_rng(design_seed_sequence(seed, method))
    if method == "morris":
        return morris_design(space, rng=rng, trajectories=trajectories, levels=levels, factors=factors)
    if method == "sobol":
        return sobol_design(space, rng=rng, base=base, factors=factors)
    raise ConfigError(f"unknown design method {method!r} (methods: {', '.join(DESIGN_METHODS)})")
