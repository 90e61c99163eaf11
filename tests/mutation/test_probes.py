"""Screening mutants of user source on probe scenarios: invalid, equivalent, duplicate, trivially killed."""

import numpy as np
import pytest

from faultlab.mutation.outcome import MutantOutcome
from faultlab.mutation.probes import probe_fingerprints, screen_on_probes
from faultlab.mutation.target import generate_source_mutants, parse_target
from faultlab.runner.experiment import SlamSpec
from faultlab.scenario.suite import draw_suite, generate_case
from faultlab.space import table1_space
from tests.mutation.usercode import FACTORY, MODULE

SPEC = SlamSpec(name=FACTORY, options=())


def _probes(n=2):
    cases = draw_suite("random", table1_space(), root_seed=5, run=0, n_cases=n)
    return [generate_case(c, n_steps=10) for c in cases], [11 + c.case for c in cases]


def _find(found, function, operator, change_end):
    return next(m for m in found if m.function == function and m.operator == operator and m.change.endswith(change_end))


def test_the_planted_classes_are_found(user_package):
    found = generate_source_mutants(parse_target(MODULE))
    probes, seeds = _probes()
    one = screen_on_probes(list(found), SPEC, probes, seeds, jobs=1)
    invalid = _find(found, "_gain", "constant", "return 0.0")  # 1 / 0 at import
    assert one[invalid.id].outcome == MutantOutcome.INVALID and "ZeroDivisionError" in one[invalid.id].reason
    # a counter no estimate reads: changing the number it counts, or not counting, changes no estimate
    counter = [m for m in found if m.function == "Mapper.update" and "self.steps" in m.change.split("->")[0]
               and m.operator in ("arithmetic", "off_by_one", "constant", "statement_deletion")]
    assert len(counter) >= 3 and all(one[m.id].outcome == MutantOutcome.EQUIVALENT for m in counter), \
        [(m.change, one[m.id].reason) for m in counter]
    no_map = next(m for m in found if m.function == "Mapper.reset" and m.change == "self.map = {}  ->  pass")
    runs_as = one[no_map.id].duplicate_of or no_map.id  # AttributeError on every probe, as deleting self.pose
    assert one[runs_as].outcome is None and one[runs_as].trivial and "AttributeError" in one[runs_as].reason
    turn = _find(found, "Mapper.update", "arithmetic", "th = wrap(th - omega)")
    assert one[turn.id].outcome is None and not one[turn.id].trivial
    for s in one.values():
        if s.outcome == MutantOutcome.DUPLICATE:  # it and the one it duplicates give the same fingerprints
            assert one[s.duplicate_of].outcome is None
            assert probe_fingerprints(s.mutant, SPEC, probes, seeds) == probe_fingerprints(s.duplicate_of, SPEC, probes,
                                                                                            seeds)
    assert any(s.outcome == MutantOutcome.DUPLICATE for s in one.values())
    live = [i for i, s in one.items() if s.outcome is None]
    fps = [probe_fingerprints(i, SPEC, probes, seeds) for i in live]
    assert len(set(fps)) == len(fps)  # live mutants differ from each other on some probe
    assert probe_fingerprints(None, SPEC, probes, seeds) not in fps


@pytest.mark.slow
def test_screening_in_two_processes_gives_the_same_classes(user_package):
    found = generate_source_mutants(parse_target(MODULE))
    probes, seeds = _probes()
    one = screen_on_probes(list(found), SPEC, probes, seeds, jobs=1)
    two = screen_on_probes(list(found), SPEC, probes, seeds, jobs=2)
    assert {i: (s.outcome, s.duplicate_of, s.trivial) for i, s in two.items()} == \
        {i: (s.outcome, s.duplicate_of, s.trivial) for i, s in one.items()}


def test_a_probe_fingerprint_is_that_of_the_estimate_bit_for_bit(user_package):
    probes, seeds = _probes(1)
    a = probe_fingerprints(None, SPEC, probes, seeds)
    assert a == probe_fingerprints(None, SPEC, probes, seeds)
    assert len(a) == 1 and not a[0].startswith("fails:")
    assert np.isfinite(len(a[0]))
