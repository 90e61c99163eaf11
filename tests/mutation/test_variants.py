"""Mutants as variants: ``mutant:<id>`` resolves to the catalogue's fault, pickles, and selection classes."""

import pickle

import numpy as np
import pytest

from faultlab.errors import FaultError
from faultlab.mutation.variants import (is_mutant_variant, mutant_id_of, mutant_variant, resolve_mutant_variant,
                                        select_mutants, _catalogue)
from faultlab.runner.variants import resolve_variant
from faultlab.slam import FastSlam

SIGN_FLIP = "motion_model:arithmetic:9"  # wrap(th + u[:, 1]) -> wrap(th - u[:, 1])


@pytest.fixture(scope="module")
def catalogue():
    return _catalogue()


def test_a_mutant_variant_resolves_to_the_catalogues_fault(catalogue):
    fault = resolve_variant(mutant_variant(SIGN_FLIP))
    expected = catalogue.mutants.fault(SIGN_FLIP)
    assert fault.name == expected.name and fault.step == "motion_model"
    assert is_mutant_variant("mutant:x") and not is_mutant_variant("baseline")
    assert mutant_id_of(mutant_variant(SIGN_FLIP)) == SIGN_FLIP


def test_every_live_mutant_resolves_by_its_variant_name(catalogue):
    for m in catalogue.report.live()[::25]:
        assert resolve_mutant_variant(mutant_variant(m.id)).name == m.fault_name


def test_a_resolved_mutant_pickles_and_turns_the_wrong_way_after_unpickling():
    fault = pickle.loads(pickle.dumps(resolve_variant(mutant_variant(SIGN_FLIP))))
    slam = fault.apply(FastSlam())
    poses = np.zeros((3, 3))
    u = np.array([[0.0, 0.3]] * 3)
    original = FastSlam().steps.motion_model
    assert np.allclose(original(poses, u, wrap=lambda a: a)[:, 2], 0.3)
    assert np.allclose(slam.steps.motion_model(poses, u, wrap=lambda a: a)[:, 2], -0.3)


def test_an_unknown_mutant_is_one_clear_error_naming_close_ids():
    with pytest.raises(FaultError, match="motion_model:arithmetic:9"):
        resolve_variant("mutant:motion_model:arithmetic:99")


def test_selection_runs_live_mutants_and_records_screened_ones_with_their_class(catalogue):
    report = catalogue.report
    eq = next(m.id for m in catalogue.mutants if str(report[m.id].outcome) == "equivalent")
    dup = next(m.id for m in catalogue.mutants if str(report[m.id].outcome) == "duplicate")
    sel = select_mutants(ids=[SIGN_FLIP, eq, dup])
    rep = report[dup].duplicate_of
    assert set(sel.run) == {SIGN_FLIP, rep}
    assert sel.screened == {eq: "equivalent", dup: "duplicate"}
    assert sel.represented_by == {dup: rep}
    assert sel.unit[rep] == catalogue.mutants.get(rep).unit


def test_a_sample_is_reproducible_and_of_live_mutants(catalogue):
    a = select_mutants(sample=20, seed=3)
    assert a == select_mutants(sample=20, seed=3) and len(a.run) == 20
    assert all(catalogue.report[m].live for m in a.run)
    assert select_mutants(sample=20, seed=4).run != a.run
