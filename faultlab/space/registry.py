"""The suite strategies faultlab ships, by the name an experiment's ``[suites]`` table uses.

A strategy is a :class:`SuiteStrategy`: its builder (``build(space, *, rng, n_cases)`` returning
:class:`~faultlab.space.case.CaseSpec` s), the smallest size it accepts, and the coverage measures
worth printing beside the class coverage of its suites.  :data:`STRATEGIES` holds the built-in ones;
a third-party distribution declares its own in the ``faultlab.suite_strategies`` entry-point group (an
entry point loads to a :class:`SuiteStrategy` or an iterable of them), which every process reads, the
worker processes of a parallel campaign included.  :func:`build_suite`, :func:`min_suite_size` and
:func:`suite_criteria` dispatch by name, and every check of a suite name (experiment files,
``faultlab generate --suite``) reads both.  A new built-in strategy is one module with its builder plus
one entry in :data:`STRATEGIES`.

The builders live in :mod:`faultlab.space.suites` (the paper's three, Sec. VI-VII) and
:mod:`faultlab.space.strategies` (base choice, t-wise, effect-guided); the coverage measures in
:mod:`faultlab.space.coverage`.  The order in which reports list suites is
:data:`faultlab.vocabulary.SUITE_ORDER` (a strategy not named there comes last).
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable, Mapping
from dataclasses import dataclass
from functools import partial
from types import MappingProxyType

import numpy as np

from faultlab.errors import UnknownPluginError
from faultlab.plugins import PluginCatalogue
from faultlab.space.case import CaseSpec
from faultlab.space.choice import check_rng
from faultlab.space.coverage import base_choice_coverage, t_wise_coverage
from faultlab.space.covering import covering_array
from faultlab.space.parameters import ParameterSpace, table1_space
from faultlab.space.strategies import (base_choice_rows, base_choice_suite, effect_guided_suite, t_wise_kind,
                                       t_wise_suite)
from faultlab.space.suites import fixed_suite, random_suite, systematic_suite

__all__ = ["SuiteStrategy", "STRATEGIES", "SUITE_KINDS", "STRATEGY_ENTRY_POINT_GROUP", "StrategyPluginWarning",
           "load_strategy_plugins", "suite_kinds", "get_strategy", "build_suite", "min_suite_size", "suite_criteria"]


def _pairwise(cases: list[CaseSpec], space: ParameterSpace) -> tuple:
    return (t_wise_coverage(cases, space, 2),)


@dataclass(frozen=True)
class SuiteStrategy:
    """A suite strategy.

    Attributes
    ----------
    name : str
        The name an experiment's ``[suites]`` table and ``--suite`` use.
    description : str
        One line.
    build : callable
        ``build(space, *, rng, n_cases)`` -> list of CaseSpec; ``n_cases`` None means the
        strategy's own default size.  ``rng`` is the only source of randomness.
    min_size : callable, optional
        ``min_size(space)``: the smallest ``n_cases`` the builder accepts (None: any size >= 1).
    criteria : callable
        ``criteria(cases, space)``: the coverage measures (:class:`~faultlab.space.TupleCoverage`,
        :class:`~faultlab.space.BaseChoiceCoverage`) printed beside the class coverage; default:
        pairwise coverage, the common yardstick of the combinatorial strategies.
    strength : int, optional
        t of a t-wise strategy (None otherwise).
    """

    name: str
    description: str
    build: Callable[..., list[CaseSpec]]
    min_size: Callable[[ParameterSpace], int] | None = None
    criteria: Callable[[list[CaseSpec], ParameterSpace], tuple] = _pairwise
    strength: int | None = None


def _fixed(space: ParameterSpace, *, rng: np.random.Generator, n_cases: int | None = None) -> list[CaseSpec]:
    return fixed_suite(space, n_cases=n_cases)


def _t_wise(strength: int) -> SuiteStrategy:
    def criteria(cases, space):
        pairwise = () if strength == 2 else _pairwise(cases, space)
        return pairwise + (t_wise_coverage(cases, space, strength),)

    return SuiteStrategy(t_wise_kind(strength),
                         f"every feasible combination of classes of any {strength} parameters (covering array)",
                         partial(t_wise_suite, strength=strength),
                         min_size=lambda space: len(covering_array(space.structure, strength)),
                         criteria=criteria, strength=strength)


#: Built-in strategies by name (read-only; a third party declares its own in the entry-point group): the paper's three in the order it introduces them (Sec. VI), then
#: the combinatorial strategies (base choice, t-wise with the strength in the name, effect-guided).
STRATEGIES: Mapping[str, SuiteStrategy] = MappingProxyType({
    s.name: s for s in (
        SuiteStrategy("systematic", "coverage-driven: every class of every parameter covered (Sec. VI)",
                      systematic_suite, min_size=lambda space: space.min_cases),
        SuiteStrategy("random", "every value drawn over its parameter's whole domain (Sec. VII-C)", random_suite),
        SuiteStrategy("fixed", "every case the paper's fixed values (Sec. VII-C)", _fixed),
        SuiteStrategy("base-choice", "a base case, then one parameter varied at a time", base_choice_suite,
                      min_size=lambda space: len(base_choice_rows(space)[0]),
                      criteria=lambda cases, space: (base_choice_coverage(cases, space),) + _pairwise(cases, space)),
        _t_wise(2),
        _t_wise(3),
        _t_wise(4),
        SuiteStrategy("effect-guided", "each class once, then classes by weights from an earlier campaign",
                      effect_guided_suite),
    )
})

#: The names of the strategies faultlab ships (:func:`suite_kinds` also lists the plugin ones).
SUITE_KINDS: tuple[str, ...] = tuple(STRATEGIES)

#: Entry-point group of third-party suite strategies.
STRATEGY_ENTRY_POINT_GROUP = "faultlab.suite_strategies"

_STRATEGY_NAME = re.compile(r"[a-z0-9][a-z0-9-]*")


class StrategyPluginWarning(UserWarning):
    """Issued when a suite-strategy plugin fails to load."""


class _StrategyCatalogue(PluginCatalogue):
    """Strategies are records named like ``[suites]`` keys (lower case, digits and hyphens: ``3-wise``)."""

    def is_builtin(self, item) -> bool:
        return any(item is b for b in self.builtins)

    def problem(self, item, taken: dict[str, str], source: str) -> str | None:
        if not isinstance(item, SuiteStrategy):
            return f"yielded {type(item).__name__} {item!r}, not a SuiteStrategy"
        if not isinstance(item.name, str) or not _STRATEGY_NAME.fullmatch(item.name):
            return f"strategy name {item.name!r} is not lower case with digits and hyphens"
        if not isinstance(item.description, str) or not item.description.strip() or "\n" in item.description.strip():
            return f"strategy {item.name!r} needs a one-line description"
        if item.name in taken:
            return f"duplicate strategy name {item.name!r} (already defined by {taken[item.name]})"
        return None


_CATALOGUE = _StrategyCatalogue(kind="suite strategy", group=STRATEGY_ENTRY_POINT_GROUP, base=SuiteStrategy,
                                builtins=tuple(STRATEGIES.values()),
                                warning=StrategyPluginWarning)

#: ``load_strategy_plugins(*, group=None, warn=True)``: discover the third-party suite strategies (in
#: entry-point name order); a :class:`~faultlab.plugins.PluginLoad`.
load_strategy_plugins = _CATALOGUE.load


def _plugin_strategies() -> dict[str, SuiteStrategy]:
    return {s.name: s for s in load_strategy_plugins(warn=False).items}


def suite_kinds() -> tuple[str, ...]:
    """The names of every strategy: the built-in ones, then the plugin ones."""
    return tuple(STRATEGIES) + tuple(n for n in _plugin_strategies() if n not in STRATEGIES)


def get_strategy(kind: str) -> SuiteStrategy:
    """The strategy called ``kind`` (built-in or plugin); :class:`~faultlab.errors.UnknownPluginError` naming the
    known ones otherwise."""
    if isinstance(kind, str) and kind in STRATEGIES:
        return STRATEGIES[kind]
    plugins = _plugin_strategies()
    if isinstance(kind, str) and kind in plugins:
        return plugins[kind]
    raise UnknownPluginError("suite strategy", kind, [*STRATEGIES, *plugins])


def build_suite(kind: str, space: ParameterSpace | None = None, *, rng: np.random.Generator,
                n_cases: int | None = None) -> list[CaseSpec]:
    """Build a suite of :class:`CaseSpec` s.

    Parameters
    ----------
    kind : str
        A registered strategy (:func:`suite_kinds`): ``systematic``, ``random``, ``fixed``,
        ``base-choice``, ``pairwise``, ``3-wise``, ``4-wise``, ``effect-guided``.
        Base classes and class weights come from the space (``[base]``, ``[weights]``).
    space : ParameterSpace, optional
        Table I when None.
    rng : numpy.random.Generator
        The only source of randomness (unused by ``fixed``).
    n_cases : int, optional
        Number of cases; default: the builder's choice (``space.min_cases``, 5 with Table I,
        for systematic, random, fixed and effect-guided; the covering rows for base-choice and
        t-wise).

    Raises
    ------
    ConfigError
        Unknown kind, or too few cases.
    """
    space = space or table1_space()
    strategy = get_strategy(kind)
    check_rng(rng)
    return strategy.build(space, rng=rng, n_cases=n_cases)


def min_suite_size(kind: str, space: ParameterSpace) -> int | None:
    """The smallest size a builder accepts for ``kind`` (None where any size >= 1 goes)."""
    strategy = get_strategy(kind)
    return None if strategy.min_size is None else strategy.min_size(space)


def suite_criteria(kind: str, cases: Iterable[CaseSpec], space: ParameterSpace) -> tuple:
    """The coverage measures worth printing beside the class coverage of a suite of ``kind``.

    Base choice: its base-choice coverage; t-wise: its t-wise coverage; every kind: pairwise
    coverage (once), the common yardstick of the combinatorial strategies.

    Returns
    -------
    tuple of TupleCoverage / BaseChoiceCoverage
    """
    return tuple(get_strategy(kind).criteria(list(cases), space))
