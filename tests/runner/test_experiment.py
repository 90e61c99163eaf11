import math
import json
import pickle
from pathlib import Path

import pytest

from faultlab.errors import ConfigError
from faultlab.runner.experiment import (
    Experiment,
    SlamSpec,
    SuiteSpec,
    load_experiment,
    parse_experiment,
)
from faultlab.metrics import DetectionRule
from faultlab.slam.fastslam import FastSlamConfig
from tests.runner.suts import TinySlam, to_toml, write_experiment

ROOT = Path(__file__).resolve().parents[2]


def test_paper_experiment_is_the_papers_protocol():
    exp = load_experiment(ROOT / "experiments" / "paper.toml")
    assert exp.runs == 3
    assert exp.suites == (SuiteSpec("systematic", 5), SuiteSpec("random", 5), SuiteSpec("fixed", 5))
    assert exp.variants == ("baseline", "naive_resampling", "missing_angle_wrap", "motion_sign_error")
    assert exp.repetitions == 1 and exp.n_steps == 1000 and exp.metric == "rms"
    assert exp.slam.name == "fastslam" and exp.slam.config.particles == 200
    # 3 runs x 3 suites x 5 cases x 4 variants = the paper's 180 SLAM executions
    n_cases = sum(s.n_cases for s in exp.suites) * exp.runs
    assert n_cases * len(exp.variants) * exp.repetitions == 180
    cfg = exp.slam.config
    assert cfg.particles == 200
    assert cfg.std_omega == pytest.approx(math.radians(20.0)) and cfg.std_bearing == pytest.approx(math.radians(10.0))
    assert exp.detection == DetectionRule(abs_mm=250.0, rel=0.25)


def test_smoke_experiment_loads():
    exp = load_experiment(ROOT / "experiments" / "smoke.toml")
    assert exp.runs >= 1 and exp.n_steps <= 200 and exp.slam.config.particles <= 50


def test_defaults_and_roundtrip(tmp_path):
    exp = parse_experiment({"seed": 5})
    assert exp.runs == 1 and exp.repetitions == 1 and exp.variants == ("baseline",)
    assert exp.slam == SlamSpec() and exp.timeout_s > 0
    # to_dict is a complete, valid experiment mapping: parsing it gives the same experiment
    again = parse_experiment(exp.to_dict())
    assert again.hash == exp.hash and again.canonical_json() == exp.canonical_json()
    # the TOML text of the mapping loads to the same experiment
    p = tmp_path / "e.toml"
    p.write_text(to_toml(exp.to_dict()))
    assert load_experiment(p).hash == exp.hash


def test_experiment_is_picklable_and_builds_custom_slam(tmp_path):
    exp = load_experiment(write_experiment(tmp_path / "e.toml"))
    clone = pickle.loads(pickle.dumps(exp))
    assert clone == exp and clone.hash == exp.hash
    slam = exp.slam.build()
    assert isinstance(slam, TinySlam) and slam.noise == 0.02


def test_hash_ignores_comments_and_formatting_but_not_values(tmp_path):
    a = write_experiment(tmp_path / "a.toml")
    b = tmp_path / "b.toml"
    b.write_text("# a comment\n\n" + a.read_text().replace(" = ", "   =   "))
    assert load_experiment(a).hash == load_experiment(b).hash
    c = write_experiment(tmp_path / "c.toml", repetitions=3)
    assert load_experiment(c).hash != load_experiment(a).hash
    # the suites' order is part of the experiment
    d = write_experiment(tmp_path / "d.toml", suites={"fixed": 1, "random": 2})
    assert load_experiment(d).hash != load_experiment(a).hash


def test_merge_changes_tables_key_by_key(tmp_path):
    exp = load_experiment(ROOT / "experiments" / "paper.toml")
    quick = exp.merge(runs=1, n_steps=100, slam={"particles": 10}, suites={"random": 2})
    assert quick.runs == 1 and quick.n_steps == 100
    assert quick.slam.config.particles == 10 and quick.slam.config.std_v == exp.slam.config.std_v  # merged
    assert dict((s.kind, s.n_cases) for s in quick.suites) == {"systematic": 5, "random": 2, "fixed": 5}
    assert quick.hash != exp.hash
    assert exp.runs == 3  # frozen original unchanged
    with pytest.raises(ConfigError, match="runs"):
        exp.merge(runs=0)
    with pytest.raises(ConfigError, match="bogus"):
        exp.merge(bogus=1)


def test_replace_replaces_a_whole_table(tmp_path):
    exp = load_experiment(ROOT / "experiments" / "paper.toml").merge(slam={"particles": 20})
    assert exp.slam.config.particles == 20
    # the example plugin's SLAM has no particles: a merge would keep particles = 20 and be refused
    other = exp.replace(slam={"name": "first_sighting"})
    assert other.slam.name == "first_sighting" and dict(other.slam.options) == {}
    with pytest.raises(ConfigError, match="particles"):
        exp.merge(slam={"name": "first_sighting"})
    # the keys a replaced table does not give take their defaults, not the experiment's
    fresh = exp.replace(slam={"name": "fastslam"}, suites={"random": 2})
    assert fresh.slam.config == FastSlamConfig() and [(s.kind, s.n_cases) for s in fresh.suites] == [("random", 2)]
    assert exp.replace(runs=1).runs == 1 and exp.runs == 3
    with pytest.raises(ConfigError, match="bogus"):
        exp.replace(bogus=1)


def test_apply_typed_overrides_replaces_keys_and_merges_particles_and_rule():
    from faultlab.config import ExperimentOverrides

    exp = load_experiment(ROOT / "experiments" / "paper.toml")
    changed = exp.apply(ExperimentOverrides(runs=2, repetitions=6, particles=9, rule="statistical",
                                            suites={"random": 3}, variants=("baseline", "naive_resampling")))
    assert (changed.runs, changed.repetitions, changed.slam.config.particles) == (2, 6, 9)
    assert changed.slam.config.std_v == exp.slam.config.std_v  # particles merged into [slam]
    assert changed.detection.rule == "statistical" and changed.detection.alpha == exp.detection.alpha
    assert [(s.kind, s.n_cases) for s in changed.suites] == [("random", 3)]
    assert changed.variants == ("baseline", "naive_resampling")
    assert exp.apply(ExperimentOverrides()) == exp
    # a whole [slam] table, then particles into it
    ekf = exp.apply(ExperimentOverrides(slam={"name": "ekf"}))
    assert ekf.slam.name == "ekf"
    with pytest.raises(ConfigError, match="particles"):  # EKF-SLAM has no particles
        exp.apply(ExperimentOverrides(slam={"name": "ekf"}, particles=5))
    with pytest.raises(ConfigError, match="suites.nope"):  # the kinds are the experiment's to check
        exp.apply(ExperimentOverrides(suites={"nope": 1}))


@pytest.mark.parametrize(
    "change, message",
    [
        ({"seed": None}, r"seed is required"),
        ({"seed": -1}, r"seed must be >= 0"),
        ({"seed": 1.5}, r"seed must be an integer"),
        ({"runs": 0}, r"runs must be >= 1"),
        ({"runs": "3"}, r"runs must be an integer"),
        ({"runs": True}, r"runs must be an integer"),
        ({"repetitions": 0}, r"repetitions must be >= 1"),
        ({"n_steps": 0}, r"n_steps must be >= 1"),
        ({"timeout_s": 0}, r"timeout_s must be > 0"),
        ({"sensor_range": -2.0}, r"sensor_range must be > 0"),
        ({"metric": "mae"}, r"metric must be one of 'rms', 'emd'"),
        ({"bogus": 1}, r"bogus is not a known key"),
        ({"suites": {"random": 2, "exhaustive": 3}}, r"suites.exhaustive is not a known key"),
        ({"suites": {"random": 0}}, r"suites.random must be >= 1"),
        ({"suites": {"random": "many"}}, r"suites.random must be an integer"),
        ({"suites": {}}, r"suites must name at least one suite"),
        ({"suites": {"systematic": 2}}, r"suites.systematic = 2: .*systematic"),
        ({"suites": 5}, r"suites must be a table"),
        ({"variants": []}, r"variants must be a non-empty list"),
        ({"variants": "baseline"}, r"variants must be a non-empty list"),
        ({"variants": ["baseline", "baseline"]}, r"variants\[1\] = 'baseline' appears twice"),
        ({"variants": ["baseline", "no_such_fault"]}, r"variants\[1\] = 'no_such_fault'.*unknown fault"),
        ({"variants": ["baseline", "tests.runner.suts:nothing"]}, r"variants\[1\].*no attribute"),
        ({"variants": ["baseline", 3]}, r"variants\[1\] must be a variant name"),
        ({"slam": {"name": "orbslam"}}, r"slam.name: unknown SLAM 'orbslam'. Known SLAMs: fastslam, "),
        ({"slam": {"name": "no_such_module_xyz:Slam"}}, r"slam.name = .*cannot import module"),
        ({"slam": {"name": "fastslam", "particles": 0}}, r"slam.particles must be >= 1"),
        ({"slam": {"name": "fastslam", "particles": 10.5}}, r"slam.particles must be an integer"),
        ({"slam": {"name": "fastslam", "std_range": 0.0}}, r"slam.std_range must be > 0"),
        ({"slam": {"name": "fastslam", "resample_ratio": 0.5}}, r"slam.resample_ratio must be >= 1"),
        ({"slam": {"name": "fastslam", "colour": "red"}}, r"slam.colour is not a known key"),
        ({"slam": {"name": "tests.runner.suts:make_tiny", "particles": 3}}, r"slam.particles is not a known key"),
        ({"detection": {"abs_mm": -1.0}}, r"detection.abs_mm must be >= 0"),
        ({"detection": {"rel": 0.2, "alpha": 1}}, r"detection.alpha must lie in \(0, 1\)"),
            ({"detection": {"rule": "bayes"}}, r"detection.rule must be one of 'paper', 'statistical'"),
            ({"detection": {"family": "all"}}, r"detection.family must be one of 'fault', 'suite_fault', 'case'"),
            ({"detection": {"beta": 1}}, r"detection.beta is not a known key"),
        ({"space": 3}, r"space must be a table"),
        ({"space": {"no_such_parameter": {}}}, r"\[space\]"),
    ],
)
def test_malformed_experiment_is_refused_naming_key(tmp_path, change, message):
    path = write_experiment(tmp_path / "bad.toml", **change)
    with pytest.raises(ConfigError, match=message) as info:
        load_experiment(path)
    assert str(path) in str(info.value)  # names the file


def test_not_toml_and_missing_file(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("seed = = 3\n")
    with pytest.raises(ConfigError, match="not valid TOML"):
        load_experiment(bad)
    with pytest.raises(ConfigError, match="cannot be read"):
        load_experiment(tmp_path / "missing.toml")


def test_auto_suite_size_and_space_overrides(tmp_path):
    exp = load_experiment(write_experiment(tmp_path / "e.toml", suites={"systematic": "auto"}))
    assert exp.suites == (SuiteSpec("systematic", None),)
    assert exp.to_dict()["suites"] == {"systematic": "auto"}


def test_dataclass_is_frozen():
    exp = parse_experiment({"seed": 1})
    with pytest.raises(AttributeError):
        exp.runs = 2  # type: ignore[misc]
    assert isinstance(exp, Experiment)


def test_fov_bug_is_validated_and_hashed_only_when_on(tmp_path):
    a = load_experiment(write_experiment(tmp_path / "a.toml"))
    off = load_experiment(write_experiment(tmp_path / "off.toml", fov_bug=False))
    on = load_experiment(write_experiment(tmp_path / "on.toml", fov_bug=True))
    assert not a.fov_bug and on.fov_bug
    assert off.hash == a.hash  # the default: hashes of older campaigns stay valid
    assert on.hash != a.hash and a.replace(fov_bug=True).hash == on.hash
    assert on.to_dict()["fov_bug"] is True and pickle.loads(pickle.dumps(on)) == on
    with pytest.raises(ConfigError, match="fov_bug"):
        load_experiment(write_experiment(tmp_path / "bad.toml", fov_bug="yes"))


def test_slam_profile_is_validated_and_hashed(tmp_path):
    exp = load_experiment(ROOT / "experiments" / "paper.toml")
    paper = exp.merge(slam={"profile": "paper"})
    assert paper.slam.profile == "paper" and exp.slam.profile == "reference"
    assert paper.hash != exp.hash
    assert exp.merge(slam={"profile": "reference"}).hash == exp.hash  # naming the default changes nothing
    assert paper.merge(slam={"particles": 30}).slam.config.particles == 30  # the table overrides the profile
    assert paper.merge(slam={"particles": 30}).hash != paper.hash
    assert parse_experiment(paper.to_dict(), source="again").hash == paper.hash  # round trip keeps the profile
    assert paper.slam.build().steps.replaced()  # the paper's units, not the reference's
    with pytest.raises(ConfigError, match=r"paper.toml \(with slam=.*slam.profile: unknown FastSLAM profile"):
        exp.merge(slam={"profile": "nope"})


def test_unknown_association_selects_the_emd_and_refuses_the_rms():
    from faultlab.runner.experiment import parse_experiment

    base = {"seed": 1, "suites": {"fixed": 1}, "slam": {"name": "fastslam2", "association": "unknown"}}
    exp = parse_experiment(base, source="u.toml")
    assert exp.metric == "emd" and exp.slam.association == "unknown"
    assert parse_experiment({**base, "metric": "emd"}, source="u.toml").metric == "emd"
    with pytest.raises(ConfigError, match=r"u.toml: metric must be 'emd' with slam.association = 'unknown'"):
        parse_experiment({**base, "metric": "rms"}, source="u.toml")
    known = parse_experiment({"seed": 1, "suites": {"fixed": 1}}, source="k.toml")
    assert known.metric == "rms" and known.slam.association == "known"
    assert "association" not in dict(known.slam.options)  # existing experiments keep their hash
    with pytest.raises(ConfigError, match="slam.association must be one of 'known', 'unknown'"):
        parse_experiment({**base, "slam": {"name": "fastslam", "association": "sometimes"}}, source="u.toml")


def test_metrics_option_is_validated_and_hashed_only_when_not_all(tmp_path):
    a = load_experiment(write_experiment(tmp_path / "a.toml"))
    both = load_experiment(write_experiment(tmp_path / "both.toml", metrics=["emd", "rms"]))
    rms = load_experiment(write_experiment(tmp_path / "rms.toml", metrics=["rms"]))
    assert a.metrics == ("rms", "emd", "ate") and both.metrics == ("rms", "emd") and rms.metrics == ("rms",)
    assert both.hash == a.hash and "metrics" not in a.canonical_json()  # older campaigns keep their hash
    assert rms.hash != a.hash and a.replace(metrics=["rms"]).hash == rms.hash
    assert parse_experiment(rms.to_dict()).hash == rms.hash and pickle.loads(pickle.dumps(rms)) == rms
    for bad, message in ((["rms", "mae"], r"metrics unknown metric 'mae'"), ([], "metrics must be a non-empty"),
                         ("rms", "metrics must be a non-empty"), (["rms", "rms"], "metrics must be a non-empty"),
                         (["emd"], r"metrics must record the experiment's metric 'rms'")):
        with pytest.raises(ConfigError, match=message) as info:
            load_experiment(write_experiment(tmp_path / "bad.toml", metrics=bad))
        assert "bad.toml" in str(info.value)
    with pytest.raises(ConfigError, match="metrics must record 'rms' for a SLAM with landmark ids"):
        a.replace(metric="emd", metrics=["emd"])
    unknown = parse_experiment({"seed": 1, "slam": {"name": "fastslam", "association": "unknown"}, "metrics": ["emd"]})
    assert unknown.metric == "emd" and unknown.metrics == ("emd",)


def test_the_ate_is_recorded_by_default_can_be_the_metric_and_leaves_every_older_hash_as_it_was(tmp_path):
    a = load_experiment(write_experiment(tmp_path / "a.toml"))
    # a hash of the layout before the ATE (no metrics key when both map errors were recorded), by hand
    before = json.loads(a.canonical_json())
    assert "metrics" not in before
    for metrics in (["rms", "emd"], ["rms", "emd", "ate"], ["ate", "emd", "rms"]):
        assert a.replace(metrics=metrics).hash == a.hash, metrics
    rms = a.replace(metrics=["rms"])
    assert a.replace(metrics=["rms", "ate"]).hash == rms.hash and json.loads(rms.canonical_json())["metrics"] == ["rms"]
    by_ate = a.replace(metric="ate")
    assert by_ate.metric == "ate" and by_ate.hash != a.hash
    with pytest.raises(ConfigError, match="must record the experiment's metric 'ate'"):
        a.replace(metric="ate", metrics=["rms", "emd"])
    unknown = parse_experiment({"seed": 1, "slam": {"name": "fastslam", "association": "unknown"}, "metric": "ate"})
    assert unknown.metric == "ate" and unknown.metrics == ("rms", "emd", "ate")
    with pytest.raises(ConfigError, match="must be 'emd' with slam.association = 'unknown' \\(or 'ate'"):
        parse_experiment({"seed": 1, "slam": {"name": "fastslam", "association": "unknown"}, "metric": "rms"})
