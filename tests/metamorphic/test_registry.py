"""Relation plugins are discovered through real entry-point metadata; bad ones are reported, not fatal."""


import pytest

from faultlab.errors import ConfigError
from faultlab.metamorphic import (
    BUILTIN_RELATIONS,
    RELATION_ENTRY_POINT_GROUP,
    RelationPluginWarning,
    all_relations,
    get_relation,
    load_relation_plugins,
)
from tests.distributions import make_distribution


def _make_distribution(site, dist, entry_points, modules):
    make_distribution(site, dist, RELATION_ENTRY_POINT_GROUP, entry_points, modules)


PLUGIN = """
    import numpy as np
    from faultlab.metamorphic import MetamorphicRelation, RelationExample
    from faultlab.metamorphic.builtin import BUILTIN_RELATIONS, example_scenario
    from faultlab.metamorphic.relation import with_record

    class ReversedSteps(MetamorphicRelation):
        name = "acme_range_offset"
        description = "one millimetre more on every range moves the map by at most a few millimetres"
        exact = False

        def transform(self, scenario, rng):
            return with_record(scenario, self.name, obs_range=scenario.obs_range + 0.001)

        examples = (RelationExample(source=example_scenario,
                                    followup={"obs_range": example_scenario().obs_range + 0.001}),)

    class Unnamed(MetamorphicRelation):
        name = "Bad Name"
        description = "x"

        def transform(self, scenario, rng):
            return scenario

    RELATIONS = [ReversedSteps, *BUILTIN_RELATIONS]   # re-declaring the built-ins is harmless
    BAD = [Unnamed(), 42]
"""


def test_plugin_relations_load_and_bad_ones_are_reported(site):
    _make_distribution(site, "acme-relations", {"acme": "acme_rel:RELATIONS", "bad": "acme_rel:BAD",
                                                "broken": "no_such_module_xyz:R"}, {"acme_rel": PLUGIN})
    with pytest.warns(RelationPluginWarning) as caught:
        report = load_relation_plugins()
    assert [r.name for r in report.items] == ["acme_range_offset"]
    messages = [str(w.message) for w in caught]
    assert any("'Bad Name' is not lower-case snake_case" in m for m in messages)
    assert any("yielded int 42, not a MetamorphicRelation" in m for m in messages)
    assert any("plugin 'broken'" in m and "ModuleNotFoundError" in m for m in messages)
    assert len(report.errors) == 3
    with pytest.warns(RelationPluginWarning):
        names = [r.name for r in all_relations()]
    assert names[:len(BUILTIN_RELATIONS)] == [r.name for r in BUILTIN_RELATIONS]
    assert names[-1] == "acme_range_offset"
    with pytest.warns(RelationPluginWarning):
        assert get_relation("acme_range_offset").name == "acme_range_offset"


def test_get_relation_knows_the_builtins_and_suggests_close_names():
    assert get_relation("rigid_motion") is BUILTIN_RELATIONS[0]
    with pytest.raises(ConfigError, match=r"unknown metamorphic relation 'rigid_motoin'.*did you mean 'rigid_motion'"):
        get_relation("rigid_motoin")
    assert [r.name for r in all_relations(plugins=False)] == [r.name for r in BUILTIN_RELATIONS]
