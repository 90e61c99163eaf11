"""Study files: the shipped study at both scales, the quick overrides, and refusals before anything runs."""

from __future__ import annotations

import time

import pytest

from faultlab.campaigns.study import load_study_experiment, sampled_load
from faultlab.errors import ConfigError
from faultlab.mutation.variants import is_mutant_variant
from faultlab.stats.verdict import min_pairs
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
        assert {x.kind for x in s.experiment.suites} == {"systematic", "random", "pairwise", "base-choice"}
    assert len(full.selection.run) == 150 and len(quick.selection.run) == 10
    assert full.study.sizes == (1, 2, 5, 10, 20) and quick.study.sizes == (1, 2, 5, 10)
    assert quick.experiment.runs == 1
    for s in (quick, full):  # K: the fewest with which a case of the largest suite can reject two-sided
        assert s.experiment.repetitions == min_pairs(s.study.alpha / max(s.study.sizes), alternative="two-sided")
    assert quick.experiment.variants[:18] == full.experiment.variants[:18]          # the 17 faults at both scales
    assert quick.experiment.space["inactivity"]["classes"]["inactive"] == [120]
    assert dict(quick.experiment.slam.options)["particles"] == 20 and full.experiment.slam.config.particles == 200
    assert quick.study.multiplicity == "holm" and not quick.study.timeouts_detect


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


def test_sampled_load_samples_at_start_interval_and_end():
    with sampled_load(interval_s=0.05) as samples:
        time.sleep(0.18)
    assert len(samples) >= 4 and all(len(s) == 4 for s in samples)
    assert samples[0][0] <= samples[-1][0]
