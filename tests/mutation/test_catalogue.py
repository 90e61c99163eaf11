"""The screened mutants of a SLAM by name, the cache of screening results, the listings."""

import json

import pytest

from faultlab.errors import FaultError
from faultlab.mutation import catalogue as C
from faultlab.mutation.catalogue import cache_dir, list_mutants, mutant_catalogue, show_mutant
from faultlab.mutation.examples import unit_examples
from faultlab.mutation.mutant import generate_mutants
from faultlab.mutation.screening import screen_mutants
from tests.mutation import toy

TOY = "tests.mutation.toy:make_toy_slam"


@pytest.fixture
def cache(tmp_path, monkeypatch):
    monkeypatch.setenv("FAULTLAB_CACHE_DIR", str(tmp_path / "cache"))
    return tmp_path / "cache"


def test_cache_dir_follows_the_environment(monkeypatch, tmp_path):
    monkeypatch.setenv("FAULTLAB_CACHE_DIR", str(tmp_path))
    assert cache_dir() == tmp_path
    monkeypatch.setenv("FAULTLAB_CACHE_DIR", "")
    assert cache_dir() is None
    monkeypatch.delenv("FAULTLAB_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_dir() == tmp_path / "xdg" / "faultlab"


def test_a_slam_given_by_import_path_is_mutated_and_screened_on_its_own_recorded_calls(cache):
    cat = mutant_catalogue(TOY)
    assert not cat.cached and {m.unit for m in cat.mutants} == set(toy.ToySteps.__dataclass_fields__)
    expected = screen_mutants(generate_mutants(toy.ToySteps), unit_examples(toy.make_toy_slam()))
    assert {k: v.label for k, v in cat.report.results.items()} == {k: v.label for k, v in expected.results.items()}
    assert cat.report.n_examples["lin"] >= 2


def test_results_are_cached_and_a_stale_or_damaged_cache_is_ignored(cache):
    first = mutant_catalogue(TOY)
    files = list((cache / "mutation").glob("toysteps-*.json"))
    assert len(files) == 1
    again = mutant_catalogue(TOY)
    assert again.cached and {k: (v.outcome, v.reason, v.duplicate_of) for k, v in again.report.results.items()} == {
        k: (v.outcome, v.reason, v.duplicate_of) for k, v in first.report.results.items()}
    data = json.loads(files[0].read_text())
    data["key"] = "something else"  # e.g. written by another version of the code
    files[0].write_text(json.dumps(data))
    assert not mutant_catalogue(TOY).cached
    files[0].write_text("{not json")
    assert not mutant_catalogue(TOY).cached
    assert mutant_catalogue(TOY).cached  # rewritten


def test_the_cache_key_changes_with_the_mutants():
    slam = toy.make_toy_slam()
    everything = generate_mutants(toy.ToySteps)
    fewer = generate_mutants(toy.ToySteps, units=["lin", "take"])
    assert C._cache_key(everything, slam) == C._cache_key(generate_mutants(toy.ToySteps), slam)
    assert C._cache_key(everything, slam) != C._cache_key(fewer, slam)


def test_no_cache_means_nothing_is_written(cache):
    assert not mutant_catalogue(TOY, cache=False).cached
    assert not cache.exists()


def test_listing_shows_live_mutants_and_counts_every_class(cache):
    cat = mutant_catalogue(TOY)
    text = list_mutants(TOY, unit="lin")
    lin = [m for m in cat.mutants if m.unit == "lin"]
    live = [m for m in lin if cat.report.results[m.id].live]
    for m in lin:
        assert (m.id in text) == (m in live)
    counts = cat.report.counts(lin)
    for label, n in counts.items():
        assert any(line.split()[:2] == [label, str(n)] for line in text.splitlines()), label
    assert f"{len(lin)} mutants of unit lin" in text
    full = list_mutants(TOY, unit="lin", all_mutants=True)
    assert all(m.id in full for m in lin) and "duplicate" in full


def test_listing_filters_by_operator_and_refuses_unknown_names(cache):
    text = list_mutants(TOY, operator="constant", all_mutants=True)
    rows = [line for line in text.splitlines() if line.startswith(("scale", "lin", "twice", "fold", "take", "shift"))]
    assert rows and all(":constant:" in r.split()[0] for r in rows)
    with pytest.raises(FaultError, match="unknown unit 'lni'"):
        list_mutants(TOY, unit="lni")
    with pytest.raises(FaultError, match="unknown mutation operator"):
        list_mutants(TOY, operator="constants")
    with pytest.raises(FaultError, match="no replaceable units"):
        list_mutants("dead_reckoning")


def test_show_prints_the_record_the_class_and_the_diff(cache):
    cat = mutant_catalogue(TOY)
    (dup,) = [m for m in cat.mutants if m.change == "return 2.0 * a  ->  return -(2.0 * a)"]
    text = show_mutant(dup.id, TOY)
    rep = cat.report.results[dup.id]
    assert f"mutant      {dup.id}" in text and f"class       duplicate: {rep.reason}" in text
    assert f"runs as     {rep.duplicate_of}" in text
    assert text.endswith(dup.diff.rstrip("\n")) and "-    return 2.0 * a\n+    return -(2.0 * a)" in text
    stand_in = show_mutant(rep.duplicate_of, TOY)
    assert f"stands for  1 duplicate(s): {dup.id}" in stand_in
    with pytest.raises(FaultError, match="unknown mutant 'lin:constant:99'"):
        show_mutant("lin:constant:99", TOY)
