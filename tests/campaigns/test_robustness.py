"""The robustness campaign at tiny scale: one store per SLAM, hardware limits skipped where they do not apply."""

import pytest

from faultlab.analysis.robustness import robustness
from faultlab.campaigns.robustness import LABELS, robustness_stores, run_robustness, scale_overrides
from faultlab.config import ExperimentOverrides
from faultlab.errors import ConfigError


def test_scale_overrides():
    assert scale_overrides() == ExperimentOverrides()
    assert scale_overrides(cases=3, steps=20, repetitions=5) == ExperimentOverrides(
        suites=(("random", 3),), n_steps=20, repetitions=5)
    with pytest.raises(ConfigError, match="repetitions"):
        scale_overrides(repetitions=0)


def test_unknown_label_is_refused_before_anything_runs(tmp_path):
    with pytest.raises(ConfigError, match="unknown SLAM label"):
        run_robustness(tmp_path, only=["nope"])
    assert not any(tmp_path.iterdir())


@pytest.mark.slow
def test_tiny_campaign_on_fastslam_and_ekf(tmp_path):
    overrides = scale_overrides(cases=3, steps=15, repetitions=5).then(
        ExperimentOverrides(variants=("baseline", "obs_delay", "particle_budget")))
    with pytest.warns(UserWarning, match="particle_budget"):
        ran = run_robustness(tmp_path, overrides=overrides, particles=5, only=["fastslam1", "ekf"], jobs=1,
                             progress=False)
    assert set(ran.summaries) == {"fastslam1", "ekf"}
    stores = robustness_stores(tmp_path)
    assert list(stores) == [label for label in LABELS if label in ("fastslam1", "ekf")]
    r = robustness(stores)
    got = set(zip(r.degradation["slam"], r.degradation["fault"]))
    assert got == {("fastslam1", "obs_delay"), ("fastslam1", "particle_budget"), ("ekf", "obs_delay")}
    assert list(r.not_applicable[["slam", "fault"]].itertuples(index=False, name=None)) == [("ekf", "particle_budget")]
    assert r.protocol["fastslam1"]["particles"] == 5 and r.protocol["ekf"]["particles"] is None
    assert (r.degradation["n_jobs"] == 15).all()
