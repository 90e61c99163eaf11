"""Screening: known stillborn, equivalent and duplicate mutants; fingerprints; the reference's mutants."""

import time

import libcst as cst
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from faultlab.faults import UnitExample
from faultlab.faults.check import CheckStatus, check_faults
from faultlab.mutation.examples import unit_examples
from faultlab.mutation.mutant import generate_mutants, mutant_fault
from faultlab.mutation.operatorbase import NodeOperator
from faultlab.mutation.operators import BUILTIN_OPERATORS
from faultlab.mutation.outcome import MutantOutcome
from faultlab.mutation.screening import _alarm_handler, _call, screen_mutants, unit_fingerprint
from faultlab.slam import REFERENCE_STEPS, FastSlamSteps
from tests.mutation import toy

EQUIVALENT, STILLBORN, DUPLICATE = MutantOutcome.EQUIVALENT, MutantOutcome.STILLBORN, MutantOutcome.DUPLICATE


class _Nonlocal(NodeOperator):
    """Test operator whose mutants never compile: ``t = ...`` -> ``nonlocal zz``."""

    name = "nonlocal_zz"
    description = "replace an assignment by a nonlocal statement (never compiles)"

    def mutations(self, node, parent):
        if isinstance(node, cst.Assign):
            yield cst.Nonlocal(names=[cst.NameItem(cst.Name("zz"))]), "`nonlocal zz`"


@pytest.fixture(scope="module")
def toy_report():
    mutants = generate_mutants(toy.ToySteps, operators=list(BUILTIN_OPERATORS) + [_Nonlocal()])
    return screen_mutants(mutants, toy.EXAMPLES)


def _find(report, unit, change):
    return [m for m in report.mutants if m.unit == unit and m.change == change]


def test_identical_bytecode_is_equivalent(toy_report):
    (m,) = _find(toy_report, "fold", "return a * (2 + 2)  ->  return a * (2 * 2)")
    assert toy_report[m.id].outcome is EQUIVALENT and toy_report[m.id].reason == "identical bytecode"
    (m,) = _find(toy_report, "fold", "return a * (2 + 2)  ->  return a * (2 - 2)")
    assert toy_report[m.id].live


def test_adding_a_zero_constant_is_equivalent(toy_report):
    """``a + 0.0 * c`` adds zero whatever ``c`` becomes; constant folding even gives the same bytecode."""
    reasons = {m.change.split("  ->  ")[1]: toy_report[m.id] for m in toy_report.mutants if m.unit == "pad"}
    for new in ("return a + 0.0 * 10.0", "return a + 0.0 * 2.5", "return a + 0.0 * 0.0", "return a + 0.0 / 5.0"):
        assert reasons[new].outcome is EQUIVALENT and reasons[new].reason == "identical bytecode", new
    for new in ("return a + 0.0 * -5.0", "return a - 0.0 * 5.0"):  # -0.0 and a - 0.0: other code, same values
        assert reasons[new].outcome is EQUIVALENT and reasons[new].reason.startswith("bit-identical"), new
    assert reasons["return a * (0.0 * 5.0)"].live and reasons["return a + (0.0 + 5.0)"].live


def test_mutants_of_a_dead_store_are_equivalent_by_their_outputs(toy_report):
    dead = [m for m in toy_report.mutants if m.unit == "scale" and m.line == m.first_line + 1]
    assert {m.operator for m in dead} >= {"arithmetic", "constant", "unary_minus", "statement_deletion"}
    for m in dead:
        s = toy_report[m.id]
        if m.operator == "nonlocal_zz":
            assert s.outcome is STILLBORN and "does not compile" in s.reason
        else:
            assert s.outcome is EQUIVALENT and s.reason.startswith("bit-identical outputs"), (m.id, s)
    live = [m for m in toy_report.mutants if m.unit == "scale" and toy_report[m.id].live]
    assert live and all(m.line > m.first_line + 1 for m in live)  # t = a + _OFFSET; return t


def test_the_same_outputs_as_an_earlier_mutant_is_a_duplicate(toy_report):
    (flip,) = _find(toy_report, "lin", "return 2.0 * a  ->  return -2.0 * a")
    (negated,) = _find(toy_report, "lin", "return 2.0 * a  ->  return -(2.0 * a)")
    assert toy_report[flip.id].live and flip.operator == "constant"
    assert toy_report[negated.id].outcome is DUPLICATE and toy_report[negated.id].duplicate_of == flip.id
    assert toy_report.members(flip.id) == (negated.id,)


def test_raising_on_every_example_is_stillborn(toy_report):
    (m,) = _find(toy_report, "take", "return a[:, 0]  ->  return a[:, 1]")
    s = toy_report[m.id]
    assert s.outcome is STILLBORN and "raises on every unit example (2): IndexError" in s.reason
    (m,) = _find(toy_report, "take", "return a[:, 0]  ->  return a[:, -1]")
    assert toy_report[m.id].outcome is EQUIVALENT  # one column: -1 is 0


def test_helper_mutants_are_screened_as_their_unit(toy_report):
    helper = [m for m in toy_report.mutants if m.id.startswith("twice._double:")]
    assert helper and all(m.unit == "twice" and m.function == "_double" for m in helper)
    (m,) = _find(toy_report, "twice", "return 2.0 * x  ->  return 4.0 * x")
    assert toy_report[m.id].live


def test_counts_add_up(toy_report):
    counts = toy_report.counts()
    assert sum(counts.values()) == len(toy_report.mutants)
    assert counts["live"] == len(toy_report.live())
    assert all(n for label, n in counts.items() if label != "nondeterministic")  # the toy writes what it reads


def _depends_on_memory(unit_source, m, examples, fills=(-3.0, 11.0)) -> bool:
    """Brute force: the mutant's outputs with ``numpy.empty`` itself returning arrays full of each of ``fills``."""
    unit = unit_source.build({m.function: m.mutated_source})
    runs = []
    for fill in fills:
        with pytest.MonkeyPatch.context() as mp, np.errstate(all="ignore"):
            mp.setattr(np, "empty", lambda shape, dtype=float, **k: np.full(shape, fill, dtype=dtype))
            mp.setattr(np, "empty_like", lambda a, dtype=None, **k: np.full_like(a, fill, dtype=dtype))
            seen = []
            for ex in examples:
                args, kwargs = ex.make_args()
                try:
                    seen.append(unit_fingerprint(unit(*args, **kwargs), args, kwargs))
                except Exception as exc:
                    seen.append(type(exc).__name__)
            runs.append(seen)
    return runs[0] != runs[1]


def test_a_mutant_that_leaves_scratch_memory_unwritten_is_nondeterministic_and_never_runs():
    from tests.mutation import leaky

    mutants = generate_mutants(leaky.LeakySteps)
    report = screen_mutants(mutants, leaky.EXAMPLES)
    source = mutants.sources["rotation"]
    leaking = {m.id for m in mutants if _depends_on_memory(source, m, leaky.EXAMPLES["rotation"])}
    assert leaking  # e.g. out[:, 1, 0] -> out[:, 0, 0]: entry (1, 0) keeps whatever the memory held
    nondeterministic = {m.id for m in mutants if report[m.id].outcome is MutantOutcome.NONDETERMINISTIC}
    assert nondeterministic == leaking
    assert not nondeterministic & {m.id for m in report.live()}
    assert all("np.empty" in report[i].reason for i in nondeterministic)
    assert report.counts()["nondeterministic"] == len(leaking)


def test_no_live_mutant_of_the_reference_units_reads_memory_it_never_wrote():
    """The units' outputs are zero-filled: the two mutants that leave an output entry unwritten are ordinary;
    a mutant that skips writing an intermediate (uninitialised work arrays) is nondeterministic, never live."""
    mutants = generate_mutants(REFERENCE_STEPS, units=("predict_measurement", "innovation_covariance"))
    examples = unit_examples()
    report = screen_mutants(mutants, examples)
    for mid in ("predict_measurement:index:18", "innovation_covariance._sandwich_sym:index:12"):
        m = mutants.get(mid)
        assert not _depends_on_memory(mutants.sources[m.unit], m, examples[m.unit]), mid
        assert report[mid].live
    leaking = {m.id for m in mutants if report[m.id].live or report[m.id].outcome is MutantOutcome.NONDETERMINISTIC
               if _depends_on_memory(mutants.sources[m.unit], m, examples[m.unit])}
    assert leaking == {m.id for m in mutants if report[m.id].outcome is MutantOutcome.NONDETERMINISTIC}
    assert leaking  # statement deletions in the sandwich's work arrays


def test_a_mutant_that_writes_into_its_input_is_not_equivalent(toy_report):
    (alias,) = _find(toy_report, "shift", "b = -a  ->  b = a")  # then b *= 2.0 doubles the caller's array
    assert toy_report[alias.id].live
    (m,) = _find(toy_report, "shift", "b *= 2.0  ->  b /= 2.0")  # b is a fresh array: a dead store
    assert toy_report[m.id].outcome is EQUIVALENT


def test_fingerprints_ignore_layout_negative_zero_and_nan_payload_but_not_dtype_or_rng_state():
    a = np.arange(6.0).reshape(2, 3)
    assert unit_fingerprint(a, (), {}) == unit_fingerprint(np.asfortranarray(a), (), {})
    assert unit_fingerprint(np.array([0.0]), (), {}) == unit_fingerprint(np.array([-0.0]), (), {})
    other_nan = np.frombuffer(np.array([0x7FF8000000000001], dtype=np.uint64).tobytes(), dtype=float)
    assert np.isnan(other_nan[0])
    assert unit_fingerprint(other_nan, (), {}) == unit_fingerprint(np.array([np.nan]), (), {})
    assert unit_fingerprint(np.arange(3), (), {}) != unit_fingerprint(np.arange(3.0), (), {})
    g1, g2 = np.random.default_rng(1), np.random.default_rng(1)
    g2.random()
    assert unit_fingerprint(None, (g1,), {}) != unit_fingerprint(None, (g2,), {})
    assert unit_fingerprint((a, None), (), {}) != unit_fingerprint((a, a), (), {})


@settings(max_examples=60, deadline=None)
@given(hnp.arrays(np.float64, hnp.array_shapes(max_dims=3, max_side=4), elements=st.floats(allow_nan=True)),
       hnp.arrays(np.float64, hnp.array_shapes(max_dims=3, max_side=4), elements=st.floats(allow_nan=True)))
def test_fingerprints_agree_with_array_equal(a, b):
    same = a.shape == b.shape and np.array_equal(a, b, equal_nan=True)
    assert (unit_fingerprint(a, (), {}) == unit_fingerprint(b, (), {})) == same


def test_a_unit_stuck_in_a_loop_is_stopped():
    def spin(a):
        while True:
            pass

    mutants = generate_mutants(toy.ToySteps, units=["lin"], operators=["constant"])
    report = screen_mutants(mutants, {"lin": (UnitExample(lambda: ((np.ones(2),), {})),)}, time_limit=0.2)
    assert report.counts()["live"] >= 1  # the mutants themselves are fine
    start = time.perf_counter()
    with _alarm_handler(0.2) as limit:
        fp, error = _call(spin, UnitExample(lambda: ((np.ones(2),), {})), limit)
    assert fp == "raises _ExampleTimeout" and time.perf_counter() - start < 5


def test_screening_a_few_reference_units():
    mutants = generate_mutants(REFERENCE_STEPS, units=["combine_weights", "innovation_covariance",
                                                       "effective_sample_size"], plugins=False)
    report = screen_mutants(mutants, unit_examples())
    s = report.results
    assert s["combine_weights:axis:2"].outcome is EQUIVALENT  # axis=1 -> axis=-1 on (N, k)
    assert s["combine_weights:axis:1"].live  # axis=1 -> axis=0
    assert s["innovation_covariance:comparison:1"].outcome is EQUIVALENT  # Q is diagonal in every call
    assert s["effective_sample_size:arithmetic:1"].live
    assert report.n_examples["effective_sample_size"] >= 3


@pytest.mark.slow
def test_the_reference_has_at_least_150_live_mutants_and_screening_is_deterministic():
    mutants = generate_mutants(REFERENCE_STEPS, plugins=False)
    first = screen_mutants(mutants, unit_examples())
    counts = first.counts()
    assert counts["live"] >= 150 and all(counts.values())
    again = screen_mutants(generate_mutants(REFERENCE_STEPS, plugins=False), unit_examples())
    assert {k: (v.outcome, v.duplicate_of) for k, v in first.results.items()} == {
        k: (v.outcome, v.duplicate_of) for k, v in again.results.items()}


def test_unit_level_classes_agree_with_whole_slam_runs():
    """Screened-equivalent mutants leave a FastSLAM run bit-identical; a live one changes it."""
    mutants = generate_mutants(REFERENCE_STEPS, units=["combine_weights", "innovation_covariance",
                                                       "effective_sample_size"], plugins=False)
    ids = ["combine_weights:axis:2", "innovation_covariance:comparison:1", "effective_sample_size:arithmetic:1"]
    report = check_faults([mutant_fault(mutants.get(i), FastSlamSteps) for i in ids], n_steps=40, particles=20,
                          n_seeds=1, plugins=False)
    assert [c.status for c in report] == [CheckStatus.EQUIVALENT, CheckStatus.EQUIVALENT, CheckStatus.DIFFERS]
