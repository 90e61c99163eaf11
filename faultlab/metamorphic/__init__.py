"""faultlab.metamorphic: metamorphic relations, a second oracle that needs no ground truth.

A relation transforms a source test case into a follow-up case whose correct estimate is known
relative to the source run's estimate (rotate the world: the map rotates; relabel the landmarks:
the map is relabelled; add 2 pi to every bearing: nothing changes).  :func:`check_relation` runs a
SLAM (optionally with a fault) on both and judges the discrepancy against the unmodified SLAM's
seed-to-seed spread; :func:`relation_matrix` does so for many faults.  Built-in relations live in
:mod:`faultlab.metamorphic.builtin`, third-party ones are discovered through the entry-point group
``faultlab.metamorphic`` (:mod:`faultlab.metamorphic.registry`).
"""

from faultlab.metamorphic.builtin import BUILTIN_RELATIONS, BearingTurn, HalvedNoise, IdPermutation, IdRelabel, RigidMotion
from faultlab.metamorphic.check import (
    DEFAULT_ATOL,
    DEFAULT_FACTOR,
    RelationMatrix,
    RelationResult,
    Verdict,
    check_relation,
    metamorphic_scenario,
    relation_matrix,
)
from faultlab.metamorphic.registry import (
    RELATION_ENTRY_POINT_GROUP,
    RelationPluginWarning,
    all_relations,
    get_relation,
    load_relation_plugins,
)
from faultlab.metamorphic.relation import MetamorphicRelation, RelationExample, estimate_distance

__all__ = [
    "MetamorphicRelation",
    "RelationExample",
    "estimate_distance",
    "RigidMotion",
    "IdPermutation",
    "IdRelabel",
    "BearingTurn",
    "HalvedNoise",
    "BUILTIN_RELATIONS",
    "DEFAULT_ATOL",
    "DEFAULT_FACTOR",
    "Verdict",
    "RelationResult",
    "RelationMatrix",
    "check_relation",
    "relation_matrix",
    "metamorphic_scenario",
    "RELATION_ENTRY_POINT_GROUP",
    "RelationPluginWarning",
    "load_relation_plugins",
    "all_relations",
    "get_relation",
]
