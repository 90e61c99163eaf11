"""[slam] profile for the built-in FastSLAM: validated in one place, defaults from the profile."""

from __future__ import annotations

import numpy as np
import pytest

from faultlab.errors import ConfigError
from faultlab.scenario import generate_scenario
from faultlab.slam import run_slam
from faultlab.slam.fastslam import REFERENCE_STEPS, FastSlam, FastSlamConfig
from faultlab.slam.profiles import PAPER_STEPS, get_profile
from faultlab.slam.registry import BUILTIN_SLAMS, build_slam, normalise_options
from faultlab.space import FIXED_VALUES, CaseSpec


def test_profile_options_are_the_profiles_settings_overridden_by_the_table():
    opts = normalise_options("fastslam", {"profile": "paper", "particles": 30}, where="x.toml: slam")
    assert opts == {"profile": "paper", **{**get_profile("paper").config.to_options(), "particles": 30}}
    slam = build_slam("fastslam", opts)
    assert slam.steps == PAPER_STEPS
    assert slam.config == FastSlamConfig.from_options({**get_profile("paper").config.to_options(), "particles": 30})
    assert BUILTIN_SLAMS["fastslam"].settings(opts).particles == 30


def test_the_reference_profile_is_the_default_and_leaves_no_trace():
    assert normalise_options("fastslam", {"profile": "reference"}, where="s") == normalise_options("fastslam", {},
                                                                                                    where="s")
    assert build_slam("fastslam", {"profile": "reference"}).steps == REFERENCE_STEPS


def test_paper_no_aliasing_builds_its_own_units():
    slam = build_slam("fastslam", normalise_options("fastslam", {"profile": "paper_no_aliasing"}, where="s"))
    assert slam.steps == get_profile("paper_no_aliasing").steps


@pytest.mark.parametrize("name, options, match", [
    ("fastslam", {"profile": "papr"}, r"x.toml: slam.profile: unknown FastSLAM profile 'papr'.*paper"),
    ("fastslam", {"profile": 3}, r"slam.profile"),
    ("fastslam2", {"profile": "paper"}, r"profile"),
    ("ekf", {"profile": "paper"}, r"profile"),
    ("fastslam", {"profile": "paper", "particles": 0}, r"particles"),
])
def test_bad_profile_options(name, options, match):
    with pytest.raises(ConfigError, match=match):
        normalise_options(name, options, where="x.toml: slam")


def test_a_paper_profile_slam_runs_a_case_like_the_profile_itself():
    sc = generate_scenario(CaseSpec(FIXED_VALUES), rng=np.random.default_rng(1), n_steps=15)
    opts = normalise_options("fastslam", {"profile": "paper", "particles": 8}, where="s")
    a = run_slam(build_slam("fastslam", opts), sc, rng=np.random.default_rng(2))
    prof = get_profile("paper")
    b = run_slam(FastSlam(FastSlamConfig.from_options({**prof.config.to_options(), "particles": 8}),
                          steps=prof.steps), sc, rng=np.random.default_rng(2))
    np.testing.assert_array_equal(a.landmarks, b.landmarks)


def _installed_command() -> str:
    import shutil
    import sys
    from pathlib import Path

    command = Path(sys.executable).with_name("faultlab")
    return str(command) if command.exists() else shutil.which("faultlab")


@pytest.mark.slow
def test_a_slam_from_an_installed_distribution_runs_in_parallel_workers(tmp_path):
    """The example plugin's SLAM, named in an experiment, runs in every loky worker of ``--jobs 2``.

    A SLAM registered only in the parent process would crash in the workers (they re-import faultlab);
    one declared in the ``faultlab.slams`` entry-point group is found by every process."""
    import subprocess

    from faultlab.runner import load_results
    from faultlab.slam.registry import load_slam_plugins
    from tests.runner.suts import write_experiment

    assert "first_sighting" in [k.name for k in load_slam_plugins(warn=False).items], \
        "install the example distribution: pip install -e examples/faultlab-example-plugin"
    toml = write_experiment(tmp_path / "first.toml", runs=1, repetitions=2, variants=["baseline"],
                            slam={"name": "first_sighting"})
    done = subprocess.run([_installed_command(), "run", str(toml), "--out", str(tmp_path / "out"), "--jobs", "2",
                           "--backend", "loky", "--no-progress"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stdout + done.stderr
    rows = load_results(tmp_path / "out")
    assert len(rows) == 6 and (rows["status"] == "ok").all(), rows[["case", "rep", "status"]]
    assert rows["rms_mm"].notna().all()
