"""Mutants of user source: targets, generation with scope and pragmas, serving a mutated module at import."""

import hashlib
import importlib
import os
import stat
import sys

import numpy as np
import pytest

from faultlab.errors import ConfigError, FaultError
from faultlab.mutation.target import (SourceMutantFault, generate_source_mutants, mutated_modules, parse_target,
                                      source_mutant)
from faultlab.runner.experiment import SlamSpec
from faultlab.slam.protocol import Observations
from tests.mutation.usercode import FACTORY, MODULE, SOURCE, write_package


def _tree_digest(root) -> str:
    h = hashlib.sha256()
    for dirpath, _, files in sorted(os.walk(root)):
        for f in sorted(files):
            if f.endswith(".py"):
                h.update(f.encode() + open(os.path.join(dirpath, f), "rb").read())
    return h.hexdigest()


def test_a_target_is_a_module_a_function_or_a_file_with_line_ranges(user_package):
    assert parse_target(MODULE).module == MODULE
    t = parse_target(f"{MODULE}:Mapper.update,wrap")
    assert t.functions == ("Mapper.update", "wrap")
    f = parse_target(f"{user_package}:30-35,16")
    assert f.module == MODULE and f.lines == ((30, 35), (16, 16))
    with pytest.raises(ConfigError, match="faultlab's own code"):
        parse_target("faultlab.slam.units")
    with pytest.raises(ConfigError, match="no file"):
        parse_target(str(user_package.parent / "nothere.py"))
    with pytest.raises(ConfigError, match="not N or N-M"):
        parse_target(f"{user_package}:a-b")


def test_every_method_and_function_is_mutated_except_under_the_pragma(user_package):
    found = generate_source_mutants(parse_target(MODULE))
    functions = {m.function for m in found}
    assert functions == {"_gain", "wrap", "Mapper.reset", "Mapper.update", "Mapper.estimate"}
    assert set(found.skipped) == {"clamp", "make"}
    pragma_line = next(i for i, line in enumerate(SOURCE.splitlines(), 1) if "setdefault" in line)
    assert not [m for m in found if m.line == pragma_line]
    for m in found:  # the mutated module differs from the original only at the mutant's function
        assert m.mutated_module != m.original_module
        compile(m.mutated_module, "x", "exec")
        a, b = m.original_module.splitlines(), m.mutated_module.splitlines()
        changed = [i + 1 for i, (x, y) in enumerate(zip(a, b)) if x != y]
        assert len(a) != len(b) or changed and changed[0] == m.line
    lines = generate_source_mutants(parse_target(f"{user_package}:16-16"))
    assert {m.function for m in lines} == {"wrap"} and all(m.line == 16 for m in lines)
    only = generate_source_mutants(parse_target(f"{MODULE}:Mapper.reset"), operators=["statement_deletion"])
    assert [m.id.split(":")[1:4] for m in only] == [["Mapper.reset", "statement_deletion", str(i)] for i in (1, 2, 3)]
    with pytest.raises(ConfigError, match="did you mean 'Mapper.update'"):
        generate_source_mutants(parse_target(f"{MODULE}:Mapper.updat"))


def test_a_mutant_keeps_its_id_until_its_own_function_changes(user_package, tmp_path):
    before = {m.id for m in generate_source_mutants(parse_target(MODULE))}
    user_package.write_text(SOURCE.replace("return (a + np.pi) % (2 * np.pi) - np.pi",
                                           "return (a + np.pi) % (2.0 * np.pi) - np.pi"))
    importlib.invalidate_caches()
    after = {m.id for m in generate_source_mutants(parse_target(MODULE))}
    unchanged = {i for i in before if ":wrap:" not in i}
    assert unchanged <= after
    assert not {i for i in before if ":wrap:" in i} & after  # wrap changed: all its mutants are new
    stale = next(i for i in before if ":wrap:" in i)
    with pytest.raises(FaultError, match="changed since"):
        source_mutant(stale)


def test_the_mutated_module_is_served_at_import_and_the_original_comes_back(user_package):
    mutant = next(m for m in generate_source_mutants(parse_target(f"{MODULE}:wrap"), operators=["off_by_one"])
                  if m.change.endswith("return (a + np.pi) % (3 * np.pi) - np.pi"))
    original = importlib.import_module(MODULE)
    digest = _tree_digest(user_package.parent.parent)
    os.chmod(user_package, stat.S_IRUSR)  # read-only, like another user's site-packages
    try:
        with mutated_modules(mutant.id, MODULE):
            served = importlib.import_module(MODULE)
            assert served is not original and served.wrap.__code__.co_filename.startswith("<mutant ")
            # (4 + pi) mod 3 pi - pi = 4 (no wrap), where the original wraps to 4 - 2 pi
            assert served.wrap(4.0) == pytest.approx(4.0)
        assert sys.modules[MODULE] is original
        assert original.wrap(4.0) == pytest.approx(4.0 - 2 * np.pi)
        assert original.wrap.__code__.co_filename == str(user_package)
    finally:
        os.chmod(user_package, stat.S_IRUSR | stat.S_IWUSR)
    assert _tree_digest(user_package.parent.parent) == digest  # nothing written to the user's files


def test_a_variant_builds_the_whole_slam_from_the_mutated_module(user_package):
    mutant = next(m for m in generate_source_mutants(parse_target(f"{MODULE}:Mapper.update"), operators=["arithmetic"])
                  if "th = wrap(th - omega)" in m.change)
    fault = SourceMutantFault(name=f"mutant:{mutant.id}", mutant_id=mutant.id)
    slam = fault.build_slam(SlamSpec(name=FACTORY, options=()))
    base = SlamSpec(name=FACTORY, options=()).build()
    for s in (slam, base):
        s.reset((0.0, 0.0, 0.0), rng=np.random.default_rng(0))
        s.update((1.0, 0.3), _no_observations())
    assert base.pose[2] == pytest.approx(0.3) and slam.pose[2] == pytest.approx(-0.3)
    assert type(slam).__module__ == MODULE and type(slam) is not type(base)


def test_an_import_time_failure_of_a_mutant_propagates_from_the_hook(user_package):
    mutant = next(m for m in generate_source_mutants(parse_target(f"{MODULE}:_gain"), operators=["constant"])
                  if m.change.endswith("return 0.0"))
    with pytest.raises(ZeroDivisionError):
        with mutated_modules(mutant.id, MODULE):
            pass
    assert importlib.import_module(MODULE).GAIN == 1.0


def test_an_installed_copy_elsewhere_is_mutated_from_its_own_source(tmp_path, monkeypatch):
    site = tmp_path / "site-packages"
    path = write_package(site)
    monkeypatch.syspath_prepend(str(site))
    from tests.mutation.usercode import forget_package

    forget_package()
    importlib.invalidate_caches()
    try:
        found = generate_source_mutants(parse_target(MODULE))
        assert found.module.path == str(path) and found.module.display_path == "usermap/slam.py"
    finally:
        forget_package()


def _no_observations():
    return Observations.empty()
