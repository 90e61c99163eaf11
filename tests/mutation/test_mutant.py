"""Mutant generation from the reference units, diffs, and mutants as picklable faults."""

import collections
import pickle
import re
import subprocess
import sys
import traceback
from pathlib import Path

import libcst as cst
import numpy as np
import pytest

from faultlab.errors import FaultError
from faultlab.mutation.mutant import build_mutant_unit, generate_mutants, mutant_fault
from faultlab.mutation.registry import get_operator
from faultlab.slam import REFERENCE_STEPS, FastSlamSteps
from faultlab.slam import units as U

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def mutants():
    return generate_mutants(REFERENCE_STEPS, plugins=False)


def test_ids_are_unique_and_number_each_operator_in_each_function(mutants):
    assert len(mutants) > 600
    ids = [m.id for m in mutants]
    assert len(ids) == len(set(ids))
    counts = collections.defaultdict(list)
    for m in mutants:
        prefix = m.unit if m.function == m.unit else f"{m.unit}.{m.function}"
        assert m.id == f"{prefix}:{m.operator}:{m.index}"
        counts[(m.unit, m.function, m.operator)].append(m.index)
    assert all(v == list(range(1, len(v) + 1)) for v in counts.values())
    assert {m.unit for m in mutants} == set(FastSlamSteps.unit_names())


def test_each_mutant_changes_its_function_at_its_line(mutants):
    file_lines = (ROOT / "faultlab/slam/units.py").read_text().splitlines()
    for m in mutants:
        assert m.mutated_source != m.original_source
        compile(m.mutated_source, m.id, "exec")
        original = m.original_source.splitlines()
        assert file_lines[m.first_line - 1:m.first_line - 1 + len(original)] == original
        offset = m.line - m.first_line
        mutated = m.mutated_source.splitlines()
        assert original[offset] != mutated[offset] or len(original) != len(mutated), m.id
        assert original[:offset] == mutated[:offset], m.id  # nothing changes before the reported line


def _apply_diff(text: str, diff: str) -> str:
    """A minimal unified-diff applier (independent of faultlab): checks context and removed lines."""
    lines = text.splitlines(keepends=True)
    out, pos = [], 0
    hunks = re.split(r"(?m)^(@@ .* @@\n)", diff)
    for header, body in zip(hunks[1::2], hunks[2::2]):
        start = int(re.match(r"@@ -(\d+)", header).group(1)) - 1
        out += lines[pos:start]
        pos = start
        for line in body.splitlines(keepends=True):
            tag, content = line[0], line[1:]
            if tag in " -":
                assert lines[pos] == content, f"context mismatch at line {pos + 1}"
                pos += 1
            if tag in " +":
                out.append(content)
    return "".join(out + lines[pos:])


def test_diffs_apply_to_the_file_and_give_the_mutated_function(mutants):
    path = ROOT / "faultlab/slam/units.py"
    text = path.read_text()
    for m in list(mutants)[::17]:
        assert m.diff.startswith("--- a/faultlab/slam/units.py\n+++ b/faultlab/slam/units.py\n@@ -")
        patched = _apply_diff(text, m.diff)
        first = m.first_line - 1
        n_new = len(m.mutated_source.splitlines())
        assert "".join(patched.splitlines(keepends=True)[first:first + n_new]) == m.mutated_source
        assert m.change.count("  ->  ") == 1


def _check_parse_back(mutant_list):
    """The spliced text parses to exactly the tree the operator builds (spaces and parentheses included)."""
    for m in mutant_list:
        op = get_operator(m.operator)
        tree = cst.parse_module(m.original_source)
        point = list(op.points(tree))[m.index - 1]
        assert cst.parse_module(m.mutated_source).deep_equals(op.apply(tree, point)), m.id


def test_spliced_sources_equal_the_operators_trees_on_some_units(mutants):
    _check_parse_back([m for m in mutants if m.function in ("log_likelihood", "resample")])


@pytest.mark.slow
def test_spliced_sources_equal_the_operators_trees_on_a_fifth_of_all_mutants(mutants):
    _check_parse_back(list(mutants)[1::5])


def test_selection_of_units_operators_and_helpers():
    only = generate_mutants(REFERENCE_STEPS, units=["resample"], operators=["comparison"], plugins=False)
    assert [m.id for m in only] == ["resample:comparison:1", "resample:comparison:2"]
    no_helpers = generate_mutants(REFERENCE_STEPS, units=["resample"], helpers=False, plugins=False)
    assert {m.function for m in no_helpers} == {"resample"}
    with pytest.raises(FaultError, match="unknown unit.*'resampel'"):
        generate_mutants(REFERENCE_STEPS, units=["resampel"])
    with pytest.raises(FaultError, match="unknown mutant 'resample:comparison:9'"):
        only.get("resample:comparison:9")


def test_a_mutant_fault_replaces_one_unit_with_the_mutated_code(mutants):
    m = mutants.get("effective_sample_size:arithmetic:1")
    assert m.change == "return float(1.0 / np.dot(w, w))  ->  return float(1.0 * np.dot(w, w))"
    fault = mutant_fault(m, FastSlamSteps)
    assert fault.name == "mutant/effective_sample_size.arithmetic.1" and fault.step == "effective_sample_size"
    steps = fault.patch(REFERENCE_STEPS)
    assert steps.replaced() == ("effective_sample_size",)
    w = np.array([0.5, 0.3, 0.2])
    assert steps.effective_sample_size(w) == pytest.approx(0.25 + 0.09 + 0.04)  # sum(w^2), not its inverse
    assert REFERENCE_STEPS.effective_sample_size(w) == pytest.approx(1 / 0.38)
    assert mutants.fault(m.fault_name).name == fault.name  # found by fault name too


def test_a_helper_mutant_is_confined_to_its_unit(mutants):
    m = next(x for x in mutants if x.id.startswith("wrap_bearing._wrap:") and "np.floor(t, out=t)" in x.change
             and x.operator == "statement_deletion")
    steps = mutant_fault(m, FastSlamSteps).patch(REFERENCE_STEPS)
    a = np.array([4.0, -4.0, 0.5])
    np.testing.assert_allclose(steps.wrap_bearing(a), a - 2 * np.pi * (a + np.pi) / (2 * np.pi))  # no floor
    assert steps.wrap_heading is U.wrap_heading and U._wrap(a) == pytest.approx(U.wrap_heading(a))


def test_mutant_faults_pickle_and_rebuild_in_a_fresh_interpreter(mutants, tmp_path):
    m = mutants.get("effective_sample_size:arithmetic:1")
    fault = mutant_fault(m, FastSlamSteps)
    (tmp_path / "fault.pkl").write_bytes(pickle.dumps(fault))
    code = ("import pickle, sys, numpy as np\n"
            "from faultlab.slam import REFERENCE_STEPS\n"
            f"fault = pickle.loads(open({str(tmp_path / 'fault.pkl')!r}, 'rb').read())\n"
            "print(repr(fault.patch(REFERENCE_STEPS).effective_sample_size(np.array([0.5, 0.3, 0.2]))))\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert done.returncode == 0, done.stderr
    assert float(done.stdout) == fault.patch(REFERENCE_STEPS).effective_sample_size(np.array([0.5, 0.3, 0.2]))


def test_a_mutant_whose_source_changed_is_refused(mutants):
    m = mutants.get("resample:comparison:1")
    with pytest.raises(FaultError, match="changed since"):
        build_mutant_unit(FastSlamSteps, m.id, "0" * 16, U.resample)
    with pytest.raises(FaultError, match="does not exist"):
        build_mutant_unit(FastSlamSteps, "resample:comparison:7", m.digest, U.resample)
    with pytest.raises(FaultError, match="malformed mutant id"):
        build_mutant_unit(FastSlamSteps, "resample", m.digest, U.resample)


def test_a_crashing_mutant_reports_the_mutated_line_of_the_file(mutants):
    m = mutants.get("resample:statement_deletion:1")  # n = w.shape[0] deleted
    unit = mutant_fault(m, FastSlamSteps).patch(REFERENCE_STEPS).resample
    with pytest.raises(NameError) as info:  # n is now an unbound global
        unit(np.full(4, 0.25), 4.0, False, np.random.default_rng(0), None)
    frame = traceback.extract_tb(info.value.__traceback__)[-1]
    assert frame.filename.startswith("<mutant resample:statement_deletion:1")
    assert frame.lineno == m.line + 1 and frame.line.startswith("if empty or n_eff >= n")
