"""A sample budget drawn before screening: a seeded uniform order, screened only as far as the budget needs."""

import pytest
from scipy.stats import chisquare

import faultlab.mutation.sourceselect as sourceselect
from faultlab.errors import ConfigError
from faultlab.mutation.outcome import MutantOutcome
from faultlab.mutation.probes import classify_probes, probe_coverage, probe_fingerprints, probe_runs
from faultlab.mutation.sourceselect import (UNSAMPLED, mutant_records, sample_order, screen_target,
                                            select_source_mutants)
from faultlab.mutation.target import generate_source_mutants, parse_target
from faultlab.runner.experiment import SlamSpec
from faultlab.seeds import mutant_draw
from tests.mutation.test_probes import _probes
from tests.mutation.usercode import FACTORY, MODULE, SOURCE, forget_package, user_package  # noqa: F401  (fixture)

SPEC = SlamSpec(name=FACTORY, options=())


class _Mutants:
    """Stand-in for a target's mutants: only their ids matter to the order."""

    def __init__(self, ids):
        self.mutants = [type("M", (), {"id": i})() for i in ids]

    def __iter__(self):
        return iter(self.mutants)


def test_the_order_is_a_uniform_permutation():
    ids = [f"m:f:arithmetic:{i}:k" for i in range(6)]
    firsts = [sample_order(_Mutants(ids), sample=1, seed=s)[0] for s in range(1200)]
    counts = [firsts.count(i) for i in ids]
    assert sorted(sample_order(_Mutants(ids), sample=1, seed=0)) == sorted(ids)
    assert chisquare(counts).pvalue > 1e-3, counts  # each id first with probability 1/6


def test_the_order_keeps_every_unchanged_mutant_in_place_when_others_change():
    ids = [f"m:f:op:{i}:k{i}" for i in range(40)]
    before = sample_order(_Mutants(ids), sample=5, seed=3)
    changed = [i for i in ids if not i.endswith(("k3", "k17"))] + ["m:f:op:3:new", "m:f:op:17:new"]
    after = sample_order(_Mutants(changed), sample=5, seed=3)
    assert [i for i in after if i in before] == [i for i in before if i in after]
    # the order is that of each mutant's own draw, brute force
    assert after == sorted(changed, key=lambda i: mutant_draw(3, i))
    assert sample_order(_Mutants(ids), sample=None, seed=3) == ids  # no budget: generation order
    with pytest.raises(ConfigError, match="sample"):
        sample_order(_Mutants(ids), sample=0, seed=3)


def test_a_budget_screens_a_prefix_of_the_order_and_samples_the_first_live_mutants(user_package, tmp_path,
                                                                                   monkeypatch):  # noqa: F811
    monkeypatch.setenv("FAULTLAB_CACHE_DIR", str(tmp_path / "cache"))
    found = generate_source_mutants(parse_target(MODULE))
    probes, seeds = _probes()
    order = sample_order(found, sample=4, seed=7)
    # the oracle: every mutant screened, then the first 4 live ones of the order
    every = probe_runs(order, SPEC, probes, seeds)
    original = probe_fingerprints(None, SPEC, probes, seeds)
    full = classify_probes(order, every, original)
    want = [i for i in order if full[i].outcome is None][:4]
    ran = []
    real = sourceselect.probe_runs
    monkeypatch.setattr(sourceselect, "probe_runs", lambda ids, *a, **k: ran.extend(ids) or real(ids, *a, **k))
    got = screen_target(found, SPEC, probes, seeds, probe_key="p", order=order, budget=4)
    assert list(got) == order[:len(got)] and len(got) < len(order)   # a prefix, not the whole target
    assert [i for i, s in got.items() if s.outcome is None] == want
    assert {i: (s.outcome, s.duplicate_of) for i, s in got.items()} == \
        {i: (full[i].outcome, full[i].duplicate_of) for i in got}
    assert len(ran) < len(order) and set(got) <= set(ran)
    # a rerun reads the cached fingerprints: nothing runs, the same classes
    ran.clear()
    again = screen_target(found, SPEC, probes, seeds, probe_key="p", order=order, budget=4)
    assert ran == [] and {i: s.outcome for i, s in again.items()} == {i: s.outcome for i, s in got.items()}
    sel = select_source_mutants(found, got, sample=4)
    assert sorted(sel.run) == sorted(want) and sel.info["n_screened"] == len(got)
    assert sel.info["n_mutants"] == len(found) and sel.info["n_sampled"] == 4
    records = mutant_records(found, got)["mutants"]
    assert {i for i, r in records.items() if r["screening"] == UNSAMPLED} == set(order) - set(got)


def test_a_budget_larger_than_the_live_mutants_screens_everything(user_package, tmp_path, monkeypatch):  # noqa: F811
    monkeypatch.setenv("FAULTLAB_CACHE_DIR", str(tmp_path / "cache"))
    found = generate_source_mutants(parse_target(MODULE), operators=["off_by_one"])
    probes, seeds = _probes()
    order = sample_order(found, sample=10_000, seed=1)
    got = screen_target(found, SPEC, probes, seeds, probe_key="p", order=order, budget=10_000, jobs=1)
    assert list(got) == order  # every mutant, classified in the order (a duplicate stands for the earliest)
    oracle = classify_probes(order, probe_runs(order, SPEC, probes, seeds), probe_fingerprints(None, SPEC, probes,
                                                                                                seeds))
    assert {i: (s.outcome, s.duplicate_of) for i, s in got.items()} == \
        {i: (s.outcome, s.duplicate_of) for i, s in oracle.items()}


UNUSED = '''
    def plot(self, scale=2.0):
        return [scale * p + 1.0 for p in self.pose]
'''


def test_mutants_of_code_the_original_never_calls_are_equivalent_without_running(user_package, tmp_path,
                                                                                   monkeypatch):  # noqa: F811
    monkeypatch.setenv("FAULTLAB_CACHE_DIR", str(tmp_path / "cache"))
    source = SOURCE.replace("\n    def estimate(self):", UNUSED + "\n    def estimate(self):")
    user_package.write_text(source)
    forget_package()
    found = generate_source_mutants(parse_target(MODULE))
    probes, seeds = _probes()
    plot = {m.id for m in found if m.function == "Mapper.plot"}
    covered = probe_coverage(MODULE, SPEC, probes, seeds)
    lines = source.splitlines()
    first = {name: next(n for n, line in enumerate(lines, 1) if line.lstrip().startswith(f"def {name}("))
             for name in ("plot", "update", "_gain")}
    assert first["plot"] not in covered and first["update"] in covered
    assert first["_gain"] in covered  # called at import, not by the SLAM
    ran = []
    real = sourceselect.probe_runs
    monkeypatch.setattr(sourceselect, "probe_runs", lambda ids, *a, **k: ran.extend(ids) or real(ids, *a, **k))
    got = screen_target(found, SPEC, probes, seeds, probe_key="p")
    assert plot and not plot & set(ran)
    assert all(got[i].outcome == MutantOutcome.EQUIVALENT and "never calls" in got[i].reason for i in plot)
    # the oracle: run them anyway, each gives the original's estimates on every probe
    original = probe_fingerprints(None, SPEC, probes, seeds)
    assert all(f == original for f in real(sorted(plot), SPEC, probes, seeds).values())
    gain = next(m for m in found if m.function == "_gain" and m.change.endswith("return 0.0"))
    assert got[gain.id].outcome == MutantOutcome.INVALID  # import-time code counts as run
