"""Study files: the shipped study at both scales, the quick overrides, and refusals before anything runs."""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest

from faultlab.campaigns.mutation import load_mutation_experiment
from faultlab.campaigns.study import load_study_experiment, sampled_load
from faultlab.errors import ConfigError
from faultlab.space import read_class_weights
from faultlab.mutation.variants import is_mutant_variant
from faultlab.inference.exact import min_pairs
from faultlab.vocabulary import PAPER_FAULTS

BASE = """
seed = 5
runs = 2
n_steps = 10
repetitions = 8
variants = ["baseline", "motion_sign_error"]
[suites]
systematic = 5
random = 4
[slam]
name = "fastslam"
particles = 30
std_v = 0.2
[mutation]
ids = ["motion_model:arithmetic:1"]
[study]
sizes = [1, 2, 6]
draws = 10
[study.quick]
runs = 1
repetitions = 7
slam = { particles = 3 }
study = { sizes = [1, 2] }
"""


def _file(tmp_path, text):
    path = tmp_path / "s.toml"
    path.write_text(text)
    return path


def test_the_shipped_study_runs_the_paper_faults_and_sampled_mutants_at_both_scales():
    full = load_study_experiment("study")
    quick = load_study_experiment("study", quick=True)
    for s in (full, quick):
        faults = [v for v in s.experiment.variants if not is_mutant_variant(v)]
        mutants = [v for v in s.experiment.variants if is_mutant_variant(v)]
        assert faults[0] == "baseline" and set(PAPER_FAULTS) <= set(faults)
        assert mutants == [f"mutant:{m}" for m in s.selection.run]                 # mutants after the faults
        assert s.experiment.variants.index(mutants[0]) == len(faults)
        assert {x.kind for x in s.experiment.suites} == {"systematic", "random", "pairwise", "base-choice",
                                                         "effect-guided"}
        assert s.study.whole == ("pairwise", "base-choice")                       # whole suites at both scales
        # the effect-guided suites draw by the committed effects study's weights, recorded in the experiment
        assert s.weights_file == "../weights/jacobian_sign_error.csv"              # beside the study file
        assert s.experiment.space["weights"] == read_class_weights(SHIPPED_WEIGHTS)
    assert len(full.selection.run) == 150 and len(quick.selection.run) == 10
    assert full.study.sizes == (1, 2, 5, 10, 20) and quick.study.sizes == (1, 2, 5, 10)
    assert quick.experiment.runs == 1
    for s in (quick, full):  # K: the fewest with which a case of the largest family (a whole base-choice
        largest = max(x.n_cases for x in s.experiment.suites)  # suite of 22) can reject two-sided
        assert largest == 22 and s.experiment.repetitions == min_pairs(s.study.alpha / largest,
                                                                       alternative="two-sided")
    assert quick.experiment.variants[:18] == full.experiment.variants[:18]          # the 17 faults at both scales
    assert quick.experiment.space["inactivity"]["classes"]["inactive"] == [120]
    assert dict(quick.experiment.slam.options)["particles"] == 20 and full.experiment.slam.config.particles == 200
    assert quick.study.multiplicity == "holm" and not quick.study.timeouts_detect


def test_the_large_study_is_the_medium_protocol_at_the_planned_pools_and_mutants():
    large = load_study_experiment("study-large")
    medium = load_study_experiment("study-medium")
    pools = {s.kind: large.experiment.runs * s.n_cases for s in large.experiment.suites}
    assert pools == {"systematic": 165, "random": 165, "pairwise": 220, "base-choice": 242, "effect-guided": 165}
    assert len(large.selection.run) == 270
    assert large.experiment.variants[:18] == medium.experiment.variants[:18]    # the baseline and 17 faults
    for key in ("n_steps", "repetitions", "timeout_s", "space", "seed"):
        assert getattr(large.experiment, key) == getattr(medium.experiment, key), key
    assert dict(large.experiment.slam.options) == dict(medium.experiment.slam.options)
    assert large.study == medium.study


def test_the_large_studys_halves_split_its_variants_over_the_same_protocol():
    large = load_study_experiment("study-large")
    faults = load_study_experiment("study-large-faults")
    mutants = load_study_experiment("study-large-mutants")
    assert faults.selection is None and faults.experiment.runs == large.experiment.runs
    assert list(faults.experiment.variants) == list(large.experiment.variants[:18])  # the baseline and 17 faults
    assert mutants.experiment.runs == 2 and list(mutants.selection.run) == list(large.selection.run)
    assert list(mutants.experiment.variants) == [large.experiment.variants[0], *large.experiment.variants[18:]]
    for half in (faults, mutants):
        for key in ("n_steps", "repetitions", "timeout_s", "space", "seed", "suites", "detection", "metric"):
            assert getattr(half.experiment, key) == getattr(large.experiment, key), key
        assert dict(half.experiment.slam.options) == dict(large.experiment.slam.options)
        assert half.study == large.study


def test_the_medium_study_is_the_quick_protocol_with_five_runs_and_fifty_of_the_mutation_studys_mutants():
    medium = load_study_experiment("study-medium")
    quick = load_study_experiment("study", quick=True)
    paper = load_mutation_experiment("mutation-paper", mutants="sample=150").selection.run
    # the drawn subset the file's comment states: positions default_rng(1).choice(150, 50), sorted
    positions = sorted(np.random.default_rng(1).choice(len(paper), size=50, replace=False).tolist())
    assert list(medium.selection.run) == [paper[i] for i in positions]
    assert medium.experiment.runs == 5 and quick.experiment.runs == 1
    assert medium.experiment.variants[:18] == quick.experiment.variants[:18]    # the same 17 faults
    for key in ("n_steps", "repetitions", "timeout_s", "space"):                  # the quick scale's SLAM and space
        assert getattr(medium.experiment, key) == getattr(quick.experiment, key), key
    assert [(s.kind, s.n_cases) for s in medium.experiment.suites] == [(s.kind, s.n_cases)
                                                                        for s in quick.experiment.suites]
    assert dict(medium.experiment.slam.options) == dict(quick.experiment.slam.options)
    assert medium.study.whole == quick.study.whole and medium.study.sizes == quick.study.sizes


def test_quick_replaces_keys_and_merges_tables_key_by_key(tmp_path):
    path = _file(tmp_path, BASE)
    full, quick = load_study_experiment(path), load_study_experiment(path, quick=True)
    assert (full.experiment.runs, full.experiment.repetitions, full.study.sizes) == (2, 8, (1, 2, 6))
    assert (quick.experiment.runs, quick.experiment.repetitions, quick.study.sizes) == (1, 7, (1, 2))
    q = dict(quick.experiment.slam.options)
    assert q["particles"] == 3 and q["std_v"] == 0.2           # the rest of [slam] is kept
    assert quick.study.draws == 10                               # the rest of [study] is kept
    assert full.experiment.hash != quick.experiment.hash


@pytest.mark.parametrize("change,match", [
    (("sizes = [1, 2, 6]", "sizes = [1, 2, 5, 9]"), r"9 cases cannot be drawn from the 8 cases of the random pool"),
    (("repetitions = 8", "repetitions = 7"), r"repetitions = 7 is too few.*0.05/6.*two-sided.*K = 8"),
    (("sizes = [1, 2, 6]", "sizes = [1, 1]"), r"study.sizes lists a size twice"),
    (("draws = 10", "draws = 10\nbins = 3"), r"study.bins is not a known key"),
    (("draws = 10", 'multiplicity = "hochberg"'), r"study.multiplicity must be one of 'holm', 'bonferroni'"),
    (('"motion_sign_error"]', '"motion_sign_error", "mutant:motion_model:arithmetic:1"]'),
     r"mutants come from \[mutation\]"),
    (('ids = ["motion_model:arithmetic:1"]', 'idz = ["x"]'), r"\[mutation\]: unknown key"),
])
def test_malformed_study_files_are_refused_naming_the_key(tmp_path, change, match):
    with pytest.raises(ConfigError, match=match):
        load_study_experiment(_file(tmp_path, BASE.replace(*change)))


SHIPPED_WEIGHTS = Path(__file__).resolve().parents[2] / "faultlab" / "data" / "weights" / "jacobian_sign_error.csv"


def test_the_shipped_weights_are_the_committed_effects_studys_and_load_from_any_directory(tmp_path, monkeypatch):
    repo = SHIPPED_WEIGHTS.parents[3]
    assert SHIPPED_WEIGHTS.read_bytes() == (repo / "reports/effects/weights_jacobian_sign_error.csv").read_bytes()
    monkeypatch.chdir(tmp_path)                      # a relative weights path is read beside the study file
    assert load_study_experiment("study").experiment.space["weights"] == read_class_weights(SHIPPED_WEIGHTS)
    (tmp_path / "a").mkdir()
    _weights_file(tmp_path / "a")
    (tmp_path / "a" / "s.toml").write_text(WEIGHTED)
    assert load_study_experiment(tmp_path / "a" / "s.toml").experiment.space["weights"] == PLANTED
    assert not (tmp_path / "w.csv").exists()


def test_sampled_load_samples_at_start_interval_and_end():
    with sampled_load(interval_s=0.05) as samples:
        time.sleep(0.18)
    assert len(samples) >= 4 and all(len(s) == 4 for s in samples)
    assert samples[0][0] <= samples[-1][0]


# ---------------------------------------------------------------------------- effect-guided suites

WEIGHTED = BASE.replace("random = 4", "random = 4\neffect-guided = 4").replace("draws = 10", "draws = 10\nweights = 'w.csv'")
PLANTED = {"map_size": {"small": 0.7, "medium": 0.2, "large": 0.1}, "step_size": {"small": 0.1, "medium": 0.1,
                                                                                  "large": 0.8}}


def _weights_file(tmp_path, text: str | None = None) -> None:
    rows = [f"{p},{c},{w}" for p, ws in PLANTED.items() for c, w in ws.items()]
    (tmp_path / "w.csv").write_text(text if text is not None else "parameter,class,weight\n" + "\n".join(rows) + "\n")


def test_effect_guided_cases_follow_the_weights_of_the_study_file(tmp_path, monkeypatch):
    from scipy.stats import chisquare

    from faultlab.scenario import draw_suite

    monkeypatch.chdir(tmp_path)
    _weights_file(tmp_path)
    sexp = load_study_experiment(_file(tmp_path, WEIGHTED.replace("effect-guided = 4", "effect-guided = 400")
                                       .replace("sizes = [1, 2, 6]", "sizes = [1, 2]")))
    exp = sexp.experiment
    assert sexp.weights_file == "w.csv" and exp.space["weights"] == PLANTED
    space = exp.parameter_space()
    cases = draw_suite("effect-guided", space, root_seed=exp.seed, run=1, n_cases=400)
    for name, planted in PLANTED.items():
        classes = space[name].class_names
        # each class once first, then every further case draws by the weights: the later cases' class
        # counts fit the planted weights and not equal weights (chi-square goodness of fit)
        later = [space[name].class_names[c.spec.classes[name]] for c in cases[len(classes):]]
        counts = [later.count(k) for k in classes]
        expected = [len(later) * planted[k] / sum(planted.values()) for k in classes]
        assert chisquare(counts, expected).pvalue > 1e-3, (name, counts)
        assert chisquare(counts).pvalue < 1e-6, (name, counts)
        first = {space[name].class_names[c.spec.classes[name]] for c in cases[:len(classes)]}
        assert first == set(classes)


@pytest.mark.parametrize("text,match", [
    (None, r"study\.weights: w\.csv: no such file"),
    ("parameter,class,weight\n", r"study\.weights: w\.csv: holds no class weights"),
    ("parameter,class,wait\nmap_size,small,1\n", r"study\.weights: .*lacks the column 'weight'"),
    ("parameter,class,weight\nmap_size,tiny,1\n", r"study\.weights: w\.csv: map_size\.tiny: unknown class"),
    ("parameter,class,weight\nmap_size,small,1\n", r"study\.weights: w\.csv: map_size: no weight for class 'medium'"),
    ("parameter,class,weight\nmap_size,small,-1\nmap_size,medium,1\nmap_size,large,1\n",
     r"study\.weights: w\.csv: map_size\.small: a weight must be a finite number >= 0"),
])
def test_a_bad_weights_file_is_one_error_naming_the_study_key_and_the_file(tmp_path, monkeypatch, text, match):
    monkeypatch.chdir(tmp_path)
    if text is not None:
        _weights_file(tmp_path, text)
    with pytest.raises(ConfigError, match=match) as info:
        load_study_experiment(_file(tmp_path, WEIGHTED))
    assert str(info.value).startswith(str(tmp_path / "s.toml")) and "\n" not in str(info.value)


def test_weights_and_effect_guided_suites_come_together(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    _weights_file(tmp_path)
    with pytest.raises(ConfigError, match=r"suites\.effect-guided: needs class weights: give study\.weights"):
        load_study_experiment(_file(tmp_path, WEIGHTED.replace("weights = 'w.csv'", "")))
    with pytest.raises(ConfigError, match=r"study\.weights: no effect-guided suite"):
        load_study_experiment(_file(tmp_path, WEIGHTED.replace("effect-guided = 4", "")))
    with pytest.raises(ConfigError, match=r"study\.weights: \[space\.weights\] gives class weights as well"):
        load_study_experiment(_file(tmp_path, WEIGHTED + "[space.weights]\nmap_size = { small = 1, medium = 1, "
                                                         "large = 1 }\n"))


def test_the_confirmatory_study_declares_its_analyses_before_it_runs():
    sexp = load_study_experiment("study-confirm")
    d = sexp.declaration
    assert d.confirmatory and d.unit == "run" and d.family == "holm"
    assert [(a.table, a.strategy_a, a.strategy_b, a.test, a.margin) for a in d.analyses] == [
        ("detection_means", "systematic", "random", "difference", None),
        ("detection_means", "systematic", "random", "equivalence", 0.05)]
    assert sexp.to_json()["declaration"] == d.to_dict()
    assert [s.kind for s in sexp.experiment.suites] == ["systematic", "random"]
    pilot = load_study_experiment("study-large-faults").experiment
    assert sexp.experiment.seed != pilot.seed  # new evaluation runs; the protocol is the pilot's
    assert (sexp.experiment.variants, sexp.experiment.repetitions, sexp.experiment.n_steps) == (
        pilot.variants, pilot.repetitions, pilot.n_steps)


@pytest.mark.parametrize("extra, match", [
    ('[declaration]\n[[declaration.analyses]]\ntable = "detection_means"\nstrategy_a = "systematic"\n'
     'strategy_b = "pairwise"\n', "'pairwise' is not one of the study's suites"),
    ('[declaration]\n[[declaration.analyses]]\ntable = "detection_comparisons"\nvariant = "no_such_fault"\n',
     "'no_such_fault' is not one of the study's variants"),
])
def test_a_declaration_naming_what_the_study_does_not_run_is_refused(tmp_path, extra, match):
    with pytest.raises(ConfigError, match=match):
        load_study_experiment(_file(tmp_path, BASE + extra))
