"""Unit sources, helpers, rebuilding a unit from changed source, bytecode comparison, poisoned numpy."""

import __future__
import inspect
import traceback
from dataclasses import dataclass, field

import numpy as np
import pytest

from faultlab.errors import FaultError
from faultlab.mutation.source import ALTERNATE_POISON, POISONED_NUMPY, code_identical, unit_source, unit_sources
from faultlab.slam import REFERENCE_STEPS, FastSlamSteps
from faultlab.slam import units as U
from tests.mutation import toy


def test_every_reference_unit_has_source_and_its_helpers():
    sources, skipped = unit_sources(REFERENCE_STEPS)
    assert skipped == {} and list(sources) == list(FastSlamSteps.unit_names())
    helpers = {u: [f.name for f in s.functions[1:]] for u, s in sources.items()}
    assert helpers["wrap_heading"] == helpers["wrap_bearing"] == ["_wrap"]
    assert helpers["init_landmarks"] == ["_vec2", "_sandwich_sym", "_common_shape", "_scratch", "_mat22"]
    assert helpers["resample"] == ["low_variance_indices"]
    assert helpers["motion_model"] == [] and helpers["extract_map"] == []
    unit_names = set(FastSlamSteps.unit_names())
    for u, s in sources.items():
        assert s.functions[0].name == getattr(REFERENCE_STEPS, u).__name__
        assert not unit_names & set(helpers[u])
        for f in s.functions:
            func = getattr(U, f.name)
            lines, first = inspect.getsourcelines(func)
            assert f.source == "".join(lines) and f.first_line == first
            assert f.display_path == "faultlab/slam/units.py"


def test_units_without_python_source_are_skipped_with_a_reason():
    def closure_maker():
        k = 2.0

        def unit(a):
            return k * a

        return unit

    @dataclass(frozen=True)
    class Odd:
        ufunc: object = np.add
        lam: object = field(default=lambda a: a)
        closure: object = field(default_factory=closure_maker)
        good: object = toy.lin

    sources, skipped = unit_sources(Odd())
    assert list(sources) == ["good"]
    assert "not a Python function" in skipped["ufunc"]
    assert "not a module-level function" in skipped["lam"]
    assert "not a module-level function" in skipped["closure"]


def test_build_without_changes_computes_what_the_unit_computes():
    sources, _ = unit_sources(REFERENCE_STEPS)
    rng = np.random.default_rng(5)
    poses = rng.normal(size=(6, 3))
    mu = rng.normal(size=(6, 4, 2)) * 3
    built = sources["predict_measurement"].build()
    assert built is not U.predict_measurement and built.__globals__ is not U.__dict__
    for a, b in zip(built(poses, mu), U.predict_measurement(poses, mu)):
        np.testing.assert_array_equal(a, b)


def test_a_changed_helper_changes_only_the_unit_it_is_built_into():
    sources, _ = unit_sources(REFERENCE_STEPS)
    src = sources["wrap_bearing"].function("_wrap").source
    identity = src.replace("    t = np.add(a, math.pi)\n", "    return a\n    t = np.add(a, math.pi)\n")
    assert identity != src
    wrap_bearing = sources["wrap_bearing"].build({"_wrap": identity})
    a = np.array([4.0, -4.0, 0.5])
    np.testing.assert_array_equal(wrap_bearing(a), a)  # no longer wraps
    expected = a - 2 * np.pi * np.floor((a + np.pi) / (2 * np.pi))
    np.testing.assert_allclose(U.wrap_bearing(a), expected, atol=1e-15)  # the module is untouched
    np.testing.assert_allclose(U.wrap_heading(a), expected, atol=1e-15)
    np.testing.assert_allclose(sources["wrap_heading"].build()(a), expected, atol=1e-15)


def test_changed_code_keeps_file_line_numbers_and_shows_the_changed_line_in_tracebacks():
    sources, _ = unit_sources(REFERENCE_STEPS)
    s = sources["effective_sample_size"]
    f = s.function("effective_sample_size")
    changed = f.source.replace("return float(1.0 / np.dot(w, w))", "return float(1.0 / undefined_name)")
    unit = s.build({"effective_sample_size": changed}, filename="<test mutant>")
    with pytest.raises(NameError) as info:
        unit(np.ones(3) / 3)
    frame = traceback.extract_tb(info.value.__traceback__)[-1]
    assert frame.filename == "<test mutant>"
    assert frame.lineno == f.first_line + f.source.splitlines().index(
        "    return float(1.0 / np.dot(w, w))")
    assert frame.line == "return float(1.0 / undefined_name)"


def test_unknown_function_cannot_be_changed():
    sources, _ = unit_sources(REFERENCE_STEPS)
    with pytest.raises(FaultError, match="not the unit or its helpers"):
        sources["resample"].build({"_wrap": "def _wrap(a):\n    return a\n"})


def test_future_flags_follow_the_module():
    sources, _ = unit_sources(REFERENCE_STEPS)
    assert sources["resample"].future_flags & __future__.annotations.compiler_flag


def test_bytecode_comparison():
    s = unit_source("fold", toy.fold, toy.ToySteps)
    original = s.function_code("fold")

    def code(body):
        return s.function_code("fold", f"def fold(a):\n    return {body}\n")

    assert code_identical(code("a * (2 * 2)"), original)  # constant folding: 2 * 2 == 2 + 2 == 4
    assert not code_identical(code("a * (2 - 2)"), original)
    assert not code_identical(code("a * 4.0"), original)  # 4.0 is not 4
    assert not code_identical(s.function_code("fold", "def fold(a):\n    return a * 0.0\n"),
                              s.function_code("fold", "def fold(a):\n    return a * -0.0\n"))


def test_poisoned_numpy_fills_empty_arrays_and_is_numpy_otherwise():
    assert np.isnan(POISONED_NUMPY.empty((2, 3))).all()
    assert (POISONED_NUMPY.empty_like(np.zeros(4, dtype=np.int64)) == np.iinfo(np.int64).min).all()
    assert POISONED_NUMPY.empty(3, dtype=bool).all()
    assert POISONED_NUMPY.ndarray is np.ndarray and POISONED_NUMPY.pi == np.pi
    sources, _ = unit_sources(REFERENCE_STEPS)
    s = sources["motion_model"]
    lazy = s.function("motion_model").source.replace("    out[:, 2] = wrap(th + u[:, 1])\n", "")
    poses, u = np.zeros((3, 3)), np.ones((3, 2))
    out = s.build({"motion_model": lazy}, poison=True)(poses, u, wrap=U.wrap_heading)
    assert (out[:, 2] == 0.0).all() and np.isfinite(out[:, :2]).all()  # the units' buffers are zero-filled
    from tests.mutation import leaky

    sources, _ = unit_sources(leaky.LeakySteps)
    s = sources["rotation"]
    lazy = s.function("rotation").source.replace("    out[:, 1, 0] = s\n", "")
    theta = np.array([0.5, 1.0])
    assert np.isnan(s.build({"rotation": lazy}, poison=True)(theta)[:, 1, 0]).all()
    assert (s.build({"rotation": lazy}, poison="alternate")(theta)[:, 1, 0] == ALTERNATE_POISON).all()
    assert np.array_equal(s.build({"rotation": lazy}, poison="alternate")(theta)[:, 0], leaky.rotation(theta)[:, 0])
