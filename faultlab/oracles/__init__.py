"""faultlab.oracles: judging a SLAM under test without an injected fault (``faultlab check``).

An oracle (:class:`Oracle`) judges one test case from the SLAM's repeated runs on it: it crashed
(``execution``), broke an exact metamorphic relation (``metamorphic``), mapped worse than dead
reckoning (``floor``) or than a reference SLAM (``differential``), reported a covariance smaller than
its error (``consistency``, :mod:`faultlab.oracles.consistency`), or exceeded a declared accuracy or
time budget (``budget``, :mod:`faultlab.oracles.budget`).  Built-ins in
:mod:`faultlab.oracles.builtin`; plugins through the entry-point group ``faultlab.oracles``;
:func:`judge_case` applies several to a case with the level shared among their tests;
:mod:`faultlab.oracles.shrink` reduces a failing case to a minimal one.
"""

from faultlab.oracles.builtin import (
    BUILTIN_ORACLES,
    DEFAULT_OPTIONS,
    BudgetOracle,
    ConsistencyOracle,
    DifferentialOracle,
    ExecutionOracle,
    FloorOracle,
    MetamorphicOracle,
)
from faultlab.oracles.judge import CaseJudgement, judge_case, repetition_seeds
from faultlab.oracles.oracle import FAIL, PASS, SKIP, CaseRuns, Oracle, OracleResult, Outcome, execute, sign_test
from faultlab.oracles.registry import (
    ORACLE_ENTRY_POINT_GROUP,
    OraclePluginWarning,
    all_oracles,
    get_oracle,
    load_oracle_plugins,
)

__all__ = [
    "Oracle", "OracleResult", "Outcome", "CaseRuns", "PASS", "FAIL", "SKIP", "execute", "sign_test",
    "ExecutionOracle", "MetamorphicOracle", "FloorOracle", "DifferentialOracle", "ConsistencyOracle",
    "BudgetOracle", "BUILTIN_ORACLES", "DEFAULT_OPTIONS",
    "CaseJudgement", "judge_case", "repetition_seeds",
    "ORACLE_ENTRY_POINT_GROUP", "OraclePluginWarning", "all_oracles", "get_oracle",
    "load_oracle_plugins",
]
